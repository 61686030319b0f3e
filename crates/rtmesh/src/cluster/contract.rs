//! Iterative contraction of precomputed triangle clusters (Garanzha, EGSR 2009; the
//! acceptance heuristic Acc(k) is in the module header of `cluster`): every triangle
//! starts as a cluster, each edge (k₁, k₂) of the dual graph (clusters sharing a mesh
//! edge) is weighted by Acc(k₁ ∪ k₂), and the edge of largest weight is contracted
//! while its weight is positive. The merged cluster's edges to its neighbours are
//! weighed again.
//!
//! The edges sit in a max-heap with lazy deletion: an entry names its two clusters
//! with their versions, a contraction bumps the survivor's version and retires the
//! other, and an entry whose cluster changed since is dropped when it surfaces. Only
//! edges of positive weight are pushed, so the heap empties when no contraction is
//! accepted. Ties go to the lower cluster ids, so the result is deterministic.
//!
//! Cost: O(E log E) heap work for the E ≈ 1.5 T dual edges and the ~D re-weighed
//! neighbours of each of the ≤ T contractions, each weighing O(|k₁| + |k₂|); memory is
//! one set per live cluster, against growing's one at a time.

use super::{
    acceptance, edge_neighbours, finish, morton_order, prepare, ClusterSettings, Clusters, Marks,
    Set,
};
use crate::mesh::TriMesh;
use std::collections::BinaryHeap;

/// A dual edge in the heap, ordered by Acc, then lower cluster ids first.
#[derive(PartialEq)]
struct Candidate {
    acc: f32,
    /// The two clusters, lower id first, with the versions they had when weighed.
    pair: [(u32, u32); 2],
}

impl Eq for Candidate {}

impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.acc
            .total_cmp(&other.acc)
            .then_with(|| other.pair.cmp(&self.pair))
    }
}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

/// A live cluster: its set, its version and the clusters it shares an edge with (ids
/// at the time they were seen: resolve them through `owner`).
struct Live {
    set: Set,
    version: u32,
    neighbours: Vec<u32>,
}

/// Iterative contraction (module header): clusters of `mesh`'s triangles with the
/// guarantees of [`super::grow`]'s (every triangle in exactly one, connected).
pub fn contract(mesh: &TriMesh, settings: &ClusterSettings) -> Clusters {
    let n = mesh.triangle_count();
    let (adjacency, shape, scale, mut marks) = prepare(mesh, settings);
    // A degenerate triangle has no normal to judge: it takes part in no contraction
    // and is merged afterwards with the fragments.
    let mergeable = |t: usize| shape[t].1 > 0.0;
    let mut live: Vec<Option<Live>> = (0..n)
        .map(|t| {
            let mut neighbours: Vec<u32> = edge_neighbours(&adjacency, t)
                .filter(|&u| u as usize != t && mergeable(u as usize))
                .collect();
            neighbours.sort_unstable();
            neighbours.dedup();
            Some(Live {
                set: Set::of(mesh, t as u32, shape[t]),
                version: 0,
                neighbours,
            })
        })
        .collect();
    // Which live cluster triangle t's first cluster became (a union-find over ids).
    let mut owner: Vec<u32> = (0..n as u32).collect();
    fn find(owner: &mut [u32], mut c: u32) -> u32 {
        while owner[c as usize] != c {
            owner[c as usize] = owner[owner[c as usize] as usize];
            c = owner[c as usize];
        }
        c
    }
    let weigh = |live: &[Option<Live>], a: u32, b: u32, marks: &mut Marks| {
        let (ka, kb) = (live[a as usize].as_ref()?, live[b as usize].as_ref()?);
        marks.mark(&ka.set.vertices);
        let acc = acceptance(ka.set.summary(), kb.set.summary(), &scale, |v| {
            marks.is_marked(v)
        })?;
        let (lo, hi) = if a < b {
            ((a, ka), (b, kb))
        } else {
            ((b, kb), (a, ka))
        };
        (acc > 0.0).then_some(Candidate {
            acc,
            pair: [(lo.0, lo.1.version), (hi.0, hi.1.version)],
        })
    };
    let mut heap = BinaryHeap::new();
    for (t, k) in live.iter().enumerate().filter(|&(t, _)| mergeable(t)) {
        let neighbours = k.as_ref().map_or(&[][..], |k| &k.neighbours);
        for &u in neighbours.iter().filter(|&&u| u as usize > t) {
            heap.extend(weigh(&live, t as u32, u, &mut marks));
        }
    }
    while let Some(Candidate { pair, .. }) = heap.pop() {
        let current = |c: (u32, u32)| {
            live[c.0 as usize]
                .as_ref()
                .is_some_and(|k| k.version == c.1)
        };
        if !current(pair[0]) || !current(pair[1]) {
            continue;
        }
        // The larger cluster survives, so that fewer triangles move.
        let size = |c: u32| {
            live[c as usize]
                .as_ref()
                .map_or(0, |k| k.set.triangles.len())
        };
        let (a, b) = (pair[0].0, pair[1].0);
        let (keep, gone) = if size(b) > size(a) { (b, a) } else { (a, b) };
        let absorbed = live[gone as usize].take().expect("current");
        owner[gone as usize] = keep;
        let mut neighbours = {
            let k = live[keep as usize].as_mut().expect("current");
            k.set.absorb(mesh, absorbed.set, &mut marks);
            k.version += 1;
            std::mem::take(&mut k.neighbours)
        };
        neighbours.extend(absorbed.neighbours);
        for c in &mut neighbours {
            *c = find(&mut owner, *c);
        }
        neighbours.sort_unstable();
        neighbours.dedup();
        neighbours.retain(|&c| c != keep);
        for &c in &neighbours {
            heap.extend(weigh(&live, keep, c, &mut marks));
        }
        live[keep as usize].as_mut().expect("current").neighbours = neighbours;
    }
    // The clusters in the Morton order of their first-met triangle.
    let mut emitted = vec![false; n];
    let mut groups = Vec::new();
    for t in morton_order(mesh) {
        let c = find(&mut owner, t) as usize;
        if !std::mem::replace(&mut emitted[c], true) {
            groups.push(std::mem::take(
                &mut live[c].as_mut().expect("a root is live").set.triangles,
            ));
        }
    }
    finish(mesh, &adjacency, groups, settings)
}

//! Strip-RT: SAH-aware triangle strips (C. Lauterbach, "Interactive ray tracing of
//! massive and deformable models", PhD thesis, UNC 2010, ch. 3, the ReduceM
//! stripification; `../shared/papers/strip-rt-lauterbach-thesis.txt`).
//!
//! 1. **Adjacency**: each triangle's strip neighbour across each side
//!    ([`super::strip_neighbours`]: two-triangle edges of the index topology, the
//!    other way round, within one group and material).
//! 2. **Partitioning**: a binned-SAH BVH down to single triangles (rtmesh's builder with
//!    leaves of one); each triangle keeps the node that references it. The 8-wide
//!    collapse makes up to eight triangles share a node, at distance 0.
//! 3. **Ordering**: every triangle starts as a sequence of length one, tied to its node.
//!    Each round, every active sequence ranks each merge with an adjacent active
//!    sequence at its open ends (up to four open sides; three for a lone triangle) by
//!
//!    ```text
//!    score = (1 − d(a, b) / (depth(a) + depth(b)))    tree distance, relative
//!          + 4·|a|·|b| / (|a| + |b|)²                 balance: harmonic mean of the
//!                                                     lengths over their total, × 2
//!    ```
//!
//!    (both terms in [0, 1], weighted equally, as published). The merges are taken best
//!    first, each sequence in at most one merge per round; the merged sequence gets the
//!    lowest common ancestor of the two nodes. A sequence with no possible merge leaves
//!    the active list; no merge may pass `max_length` triangles.
//! 4. **Output** in rtmesh's strip format ([`super::Strips`]), strips in the order the
//!    BVH's leaves reach their first triangle, so that neighbouring strips are near in
//!    memory.
//!
//! Cost: O(T log T) for the partition; each ordering round is O(active) with a sort of
//! the candidate merges, and relabelling the shorter sequence of each merge costs
//! O(T log L) in all; the rounds number about log₂ L plus a tail.

use super::{strip_neighbours, Encoder, Strips, NONE};
use crate::bvh::{BuildSettings, Bvh, Child};
use crate::mesh::TriMesh;
use crate::trace::Triangle;

/// Settings of Strip-RT.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StripSettings {
    /// Most triangles in one strip (the published reason for a limit: strips of uneven
    /// length trace worse).
    pub max_length: usize,
}

impl Default for StripSettings {
    fn default() -> Self {
        Self { max_length: 32 }
    }
}

/// The partition: a node per triangle, and each node's parent and depth.
struct Partition {
    node_of: Vec<u32>,
    parent: Vec<u32>,
    depth: Vec<u32>,
    /// Input triangle ids in the BVH's leaf order.
    leaf_order: Vec<u32>,
}

impl Partition {
    fn build(mesh: &TriMesh) -> Self {
        let triangles: Vec<Triangle> = (0..mesh.triangle_count())
            .map(|t| Triangle::new(mesh.corners(t), t as u32))
            .collect();
        let settings = BuildSettings {
            max_leaf_size: 1,
            ..BuildSettings::quality()
        };
        let bvh = Bvh::build(triangles, &settings);
        // Node 0 stands for the root even when the root is a leaf or empty; triangles
        // the BVH left out (non-finite) hang from it.
        let nodes = bvh.nodes.len().max(1);
        let mut node_of = vec![0u32; mesh.triangle_count()];
        let mut parent = vec![NONE; nodes];
        let mut depth = vec![1u32; nodes];
        let mut assign =
            |reference: u32, node: u32, parent: &mut [u32], depth: &mut [u32]| match Child::decode(
                reference,
            ) {
                Child::Inner(i) => {
                    parent[i as usize] = node;
                    depth[i as usize] = depth[node as usize] + 1;
                }
                Child::Leaf { first, count } => {
                    for p in first..first + count {
                        node_of[bvh.primitives[p as usize].id as usize] = node;
                    }
                }
                Child::Empty => {}
            };
        if bvh.nodes.is_empty() {
            assign(bvh.root, 0, &mut parent, &mut depth);
        } else {
            // Parents come before children in `nodes`.
            for (i, node) in bvh.nodes.iter().enumerate() {
                for &child in &node.children {
                    assign(child, i as u32, &mut parent, &mut depth);
                }
            }
        }
        Self {
            node_of,
            parent,
            depth,
            leaf_order: bvh.primitives.iter().map(|t| t.id).collect(),
        }
    }

    /// Lowest common ancestor and the path length between `a` and `b`.
    fn meet(&self, mut a: u32, mut b: u32) -> (u32, u32) {
        let mut distance = 0;
        while self.depth[a as usize] > self.depth[b as usize] {
            a = self.parent[a as usize];
            distance += 1;
        }
        while self.depth[b as usize] > self.depth[a as usize] {
            b = self.parent[b as usize];
            distance += 1;
        }
        while a != b {
            a = self.parent[a as usize];
            b = self.parent[b as usize];
            distance += 2;
        }
        (a, distance)
    }
}

/// A sequence of triangles being grown.
#[derive(Clone, Copy)]
struct Sequence {
    ends: [u32; 2],
    length: u32,
    node: u32,
    active: bool,
}

/// A possible merge: end `x` of sequence `a` with end `y` of sequence `b` across side
/// `side_x` of `x` (side `side_y` of `y`).
#[derive(Clone, Copy)]
struct Merge {
    score: f32,
    a: u32,
    b: u32,
    x: u32,
    y: u32,
    side_x: u8,
    side_y: u8,
}

/// Strip-RT over `mesh`'s triangles (by vertex index: weld first to share vertices).
pub fn stripify(mesh: &TriMesh, settings: &StripSettings) -> Strips {
    let n = mesh.triangle_count();
    let neighbours = strip_neighbours(mesh);
    let partition = Partition::build(mesh);
    let max_length = settings.max_length.max(1) as u32;

    // Per triangle: its sequence, and up to two links (neighbour, own side).
    let mut sequence_of: Vec<u32> = (0..n as u32).collect();
    let mut links = vec![[(NONE, 0u8); 2]; n];
    let mut sequences: Vec<Sequence> = (0..n)
        .map(|t| Sequence {
            ends: [t as u32; 2],
            length: 1,
            node: partition.node_of[t],
            active: true,
        })
        .collect();
    let mut active: Vec<u32> = (0..n as u32)
        .filter(|&t| neighbours[t as usize].iter().any(|&(o, _)| o != NONE))
        .collect();
    let mut merges: Vec<Merge> = Vec::with_capacity(active.len());
    let mut merged_this_round = vec![false; n];

    while !active.is_empty() {
        merges.clear();
        active.retain(|&a| {
            let sa = sequences[a as usize];
            let mut best: Option<Merge> = None;
            let ends: &[u32] = if sa.length == 1 {
                &sa.ends[..1]
            } else {
                &sa.ends
            };
            for &x in ends {
                let link = links[x as usize];
                for (side_x, &(y, side_y)) in neighbours[x as usize].iter().enumerate() {
                    if y == NONE || link.iter().any(|l| l.0 == y && l.1 == side_x as u8) {
                        continue;
                    }
                    let b = sequence_of[y as usize];
                    let sb = sequences[b as usize];
                    if b == a
                        || !sb.active
                        || sa.length + sb.length > max_length
                        || (sb.ends[0] != y && sb.ends[1] != y)
                    {
                        continue;
                    }
                    let (_, distance) = partition.meet(sa.node, sb.node);
                    let depths =
                        partition.depth[sa.node as usize] + partition.depth[sb.node as usize];
                    let (la, lb) = (sa.length as f32, sb.length as f32);
                    let score = 1.0 - distance as f32 / depths as f32
                        + 4.0 * la * lb / ((la + lb) * (la + lb));
                    if best.is_none_or(|m| score > m.score) {
                        best = Some(Merge {
                            score,
                            a,
                            b,
                            x,
                            y,
                            side_x: side_x as u8,
                            side_y,
                        });
                    }
                }
            }
            match best {
                Some(m) => {
                    merges.push(m);
                    true
                }
                None => {
                    sequences[a as usize].active = false;
                    false
                }
            }
        });
        merges.sort_unstable_by(|p, q| q.score.total_cmp(&p.score));
        for m in &merges {
            if merged_this_round[m.a as usize] || merged_this_round[m.b as usize] {
                continue;
            }
            let (sa, sb) = (sequences[m.a as usize], sequences[m.b as usize]);
            // Keep the longer sequence's id; relabel the shorter one's triangles.
            let (keep, gone, gone_end) = if sa.length >= sb.length {
                (m.a, m.b, m.y)
            } else {
                (m.b, m.a, m.x)
            };
            for (t, _) in walk(&links, gone_end) {
                sequence_of[t as usize] = keep;
            }
            link(&mut links, m.x, m.y, m.side_x);
            link(&mut links, m.y, m.x, m.side_y);
            let other_end = |s: Sequence, end: u32| {
                if s.ends[0] == end {
                    s.ends[1]
                } else {
                    s.ends[0]
                }
            };
            let (node, _) = partition.meet(sa.node, sb.node);
            sequences[keep as usize] = Sequence {
                ends: [other_end(sa, m.x), other_end(sb, m.y)],
                length: sa.length + sb.length,
                node,
                active: true,
            };
            sequences[gone as usize].active = false;
            merged_this_round[keep as usize] = true;
            merged_this_round[gone as usize] = true;
        }
        active.retain(|&a| sequences[a as usize].active);
        for m in &merges {
            merged_this_round[m.a as usize] = false;
            merged_this_round[m.b as usize] = false;
        }
    }

    // Output in leaf order, each sequence walked from one end.
    let mut encoder = Encoder::new(&mesh.triangles);
    let mut emitted = vec![false; n];
    let mut order = partition.leaf_order;
    let mut in_bvh = vec![false; n];
    for &t in &order {
        in_bvh[t as usize] = true;
    }
    order.extend((0..n as u32).filter(|&t| !in_bvh[t as usize]));
    let mut sequence = Vec::with_capacity(max_length as usize);
    let mut exits = Vec::with_capacity(max_length as usize);
    for t in order {
        let s = sequence_of[t as usize];
        if emitted[s as usize] {
            continue;
        }
        emitted[s as usize] = true;
        sequence.clear();
        exits.clear();
        for (t, exit) in walk(&links, sequences[s as usize].ends[0]) {
            sequence.push(t);
            exits.extend(exit);
        }
        encoder.push(&sequence, &exits);
    }
    encoder.finish()
}

/// Record that `from`'s side `side` links to `to`.
fn link(links: &mut [[(u32, u8); 2]], from: u32, to: u32, side: u8) {
    let slots = &mut links[from as usize];
    let free = if slots[0].0 == NONE { 0 } else { 1 };
    slots[free] = (to, side);
}

/// The triangles of the sequence that has `end` as an end, from that end, each with the
/// side it leaves by to the next (none for the last).
fn walk(links: &[[(u32, u8); 2]], end: u32) -> impl Iterator<Item = (u32, Option<u8>)> + '_ {
    let mut previous = NONE;
    let mut current = end;
    std::iter::from_fn(move || {
        if current == NONE {
            return None;
        }
        let here = current;
        let next = links[here as usize]
            .iter()
            .find(|l| l.0 != NONE && l.0 != previous)
            .copied();
        previous = here;
        current = next.map_or(NONE, |l| l.0);
        Some((here, next.map(|l| l.1)))
    })
}

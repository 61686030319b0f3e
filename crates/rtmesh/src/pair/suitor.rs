//! Greedy matching without sorting: the Suitor algorithm (Manne & Halappanavar, "New
//! Effective Multithreaded Matching Algorithms", IPDPS 2014).
//!
//! The greedy scan of the pairing paper takes couples of triangles in descending key
//! order and keeps a couple when both triangles are still free. When the keys are
//! distinct (a strict total order), that matching is the unique *locally dominant* one,
//! and Suitor finds it with no order over all couples: each triangle proposes to its
//! neighbour with the largest key whose current suitor offers less, displacing that
//! suitor, which proposes again. Two triangles that are each other's suitors at the
//! end are a pair. Every displacement raises a triangle's best offer, so the work is
//! a few proposals per triangle; the reads follow the mesh's own order, which keeps
//! them in cache, where a global sort's scan jumps all over the couples.
//! Cost: O(T) proposals in practice (O(E · max degree) at worst), 20 bytes per
//! triangle.
//!
//! The dual graph is kept per side of every triangle ([`Couples`], built from runs of
//! half-edges that hold every edge whole): the triangle across it, or a mark that the
//! side's edge has three or more half-edges, whose couples are listed apart with their
//! keys ([`ExtraCouple`]). Keys are `u128`s from the pairing method, computed when a
//! triangle proposes.

use super::Pairing;
use crate::mesh::{HalfEdgeRuns, TriMesh};
use crate::pages::filled_on_huge_pages;
use crate::radix::SharedSlice;
use rayon::prelude::*;

/// `Couples::across` value of a side whose edge has no couple (the slot's default).
const NO_COUPLE: u32 = 0;
/// `Couples::across` value of a side whose edge has three or more half-edges: its
/// couples are in [`Couples::extra`].
const SHARED_BY_MORE: u32 = u32::MAX;

/// The couples (pairable neighbours across an edge) of every triangle.
pub(super) struct Couples {
    /// For half-edge `3t + k` (side `k` of triangle `t`): 1 + the triangle it couples
    /// with, [`NO_COUPLE`] or [`SHARED_BY_MORE`].
    across: Vec<u32>,
    /// The couples on edges of three or more half-edges, once from each triangle,
    /// sorted by triangle.
    extra: Vec<ExtraCouple>,
}

impl Couples {
    /// The couples of `mesh`'s half-edges in `runs` (per smaller vertex, half-edge ids
    /// ascending, as in the pairing table): two neighbouring half-edges of one edge
    /// (in run order) couple when they run opposite ways. An edge with three or more
    /// half-edges lists its couples in [`Couples::extra`], the `i`-th in run order with
    /// key `extra_key(first, second, n - 1 - i)` for `n` half-edges, so that earlier
    /// couples rank higher. Blocks of vertices in parallel: every half-edge is in one
    /// run, so blocks write disjoint slots.
    pub(super) fn from_runs(
        mesh: &TriMesh,
        runs: &HalfEdgeRuns<u32>,
        extra_key: impl Fn(usize, u32, u32) -> u128 + Sync,
    ) -> Self {
        let triangle_count = mesh.triangle_count();
        let mut across = filled_on_huge_pages(3 * triangle_count, NO_COUPLE);
        let destination = SharedSlice(across.as_mut_ptr());
        let destination = &destination;
        let extras: Vec<Vec<ExtraCouple>> = HalfEdgeRuns::vertex_blocks(runs.vertex_count())
            .into_par_iter()
            .map(|block| {
                let mut extra = Vec::new();
                let (mut edges, mut starts_at_first) = (Vec::new(), Vec::new());
                for r in block {
                    let run = runs.run(r);
                    // Each half-edge's larger vertex, and whether it starts at the
                    // smaller one.
                    edges.clear();
                    starts_at_first.clear();
                    for &h in run {
                        let tri = mesh.triangles[(h / 3) as usize];
                        let (a, b) = (tri[(h % 3) as usize], tri[(h % 3 + 1) as usize % 3]);
                        edges.push(a.max(b));
                        starts_at_first.push(a < b);
                    }
                    let coupled = |i: usize, j: usize| starts_at_first[i] != starts_at_first[j];
                    for (i, edge) in edges.iter().enumerate() {
                        // How many half-edges of the run lie on this edge, and (when
                        // there are two) where the other one is; counted without
                        // branches.
                        let (mut count, mut index_sum) = (0, 0);
                        for (j, other) in edges.iter().enumerate() {
                            let same = (other == edge) as usize;
                            count += same;
                            index_sum += same * j;
                        }
                        // Each half-edge writes its own slot, without a branch: the
                        // triangle across, or no couple.
                        let j = index_sum - i;
                        let across_i = if count == 2 && coupled(i, j) {
                            run[j] / 3 + 1
                        } else {
                            NO_COUPLE
                        };
                        if count <= 2 {
                            // SAFETY: half-edge run[i] belongs to this block only.
                            unsafe { destination.0.add(run[i] as usize).write(across_i) };
                        } else if !edges[..i].contains(edge) {
                            let on_edge: Vec<usize> =
                                (i..run.len()).filter(|&j| edges[j] == *edge).collect();
                            for (rank, w) in on_edge.windows(2).enumerate() {
                                if coupled(w[0], w[1]) {
                                    let rank = (on_edge.len() - 1 - rank) as u32;
                                    let key = extra_key(r, *edge, rank);
                                    let (a, b) = (run[w[0]] / 3, run[w[1]] / 3);
                                    extra.push(ExtraCouple {
                                        triangle: a,
                                        neighbour: b,
                                        key,
                                    });
                                    extra.push(ExtraCouple {
                                        triangle: b,
                                        neighbour: a,
                                        key,
                                    });
                                }
                            }
                            for &j in &on_edge {
                                // SAFETY: as above.
                                unsafe { destination.0.add(run[j] as usize).write(SHARED_BY_MORE) };
                            }
                        }
                    }
                }
                extra
            })
            .collect();
        let mut extra = extras.concat();
        extra.sort_unstable_by_key(|e| e.triangle);
        Couples { across, extra }
    }
}

/// A couple on an edge of three or more half-edges, seen from `triangle`.
#[derive(Clone, Copy, Debug)]
struct ExtraCouple {
    /// The proposing triangle.
    triangle: u32,
    /// The triangle across the edge.
    neighbour: u32,
    /// The couple's key.
    key: u128,
}

/// The greedy matching of `couples` by descending key, where `side_keys(t)` gives the
/// keys of triangle `t`'s three sides (called only for triangles with a couple on a side
/// that is not [`SHARED_BY_MORE`]). Keys must be distinct between couples and above 0.
pub(super) fn match_greedily(couples: &Couples, side_keys: impl Fn(usize) -> [u128; 3]) -> Pairing {
    let n = couples.across.len() / 3;
    // suitor[t]: 1 + the triangle proposing to t (0: none); offer[t]: its couple's key.
    let mut suitor = filled_on_huge_pages(n, 0u32);
    let mut offer = filled_on_huge_pages(n, 0u128);
    for first in 0..n {
        let mut proposer = first;
        loop {
            let (mut best_key, mut best) = (0u128, usize::MAX);
            let across: [u32; 3] = std::array::from_fn(|k| couples.across[3 * proposer + k]);
            let coupled = across.map(|a| a != NO_COUPLE && a != SHARED_BY_MORE);
            if coupled.contains(&true) {
                // Selects rather than branches: which side wins is a coin toss.
                let keys = side_keys(proposer);
                for k in 0..3 {
                    let v = if coupled[k] {
                        (across[k] - 1) as usize
                    } else {
                        proposer
                    };
                    let better = coupled[k] & (keys[k] > offer[v]) & (keys[k] > best_key);
                    best_key = if better { keys[k] } else { best_key };
                    best = if better { v } else { best };
                }
            }
            if across.contains(&SHARED_BY_MORE) {
                let from = couples
                    .extra
                    .partition_point(|e| (e.triangle as usize) < proposer);
                for e in couples.extra[from..]
                    .iter()
                    .take_while(|e| e.triangle as usize == proposer)
                {
                    let v = e.neighbour as usize;
                    if e.key > best_key && e.key > offer[v] {
                        (best_key, best) = (e.key, v);
                    }
                }
            }
            if best == usize::MAX {
                break;
            }
            let displaced = std::mem::replace(&mut suitor[best], proposer as u32 + 1);
            offer[best] = best_key;
            if displaced == 0 {
                break;
            }
            proposer = (displaced - 1) as usize;
        }
    }
    let mut pairing = Pairing::default();
    for (t, &s) in suitor.iter().enumerate() {
        let mutual = s != 0 && suitor[(s - 1) as usize] as usize == t + 1;
        if !mutual {
            pairing.unpaired.push(t as u32);
        } else if (s - 1) as usize > t {
            pairing.pairs.push([t as u32, s - 1]);
        }
    }
    pairing
}

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
//! The dual graph is given per side of every triangle ([`Couples`]): the triangle across
//! it, or a mark that the side's edge has three or more half-edges, whose couples are
//! listed apart with their keys ([`ExtraCouple`]). Keys are `u128`s from the pairing
//! method, computed when a triangle proposes.

use super::Pairing;
use crate::pages::filled_on_huge_pages;

/// `Couples::across` value of a side whose edge has no couple (the slot's default).
pub(super) const NO_COUPLE: u32 = 0;
/// `Couples::across` value of a side whose edge has three or more half-edges: its
/// couples are in [`Couples::extra`].
pub(super) const SHARED_BY_MORE: u32 = u32::MAX;

/// The couples (pairable neighbours across an edge) of every triangle.
pub(super) struct Couples {
    /// For half-edge `3t + k` (side `k` of triangle `t`): 1 + the triangle it couples
    /// with, [`NO_COUPLE`] or [`SHARED_BY_MORE`].
    pub(super) across: Vec<u32>,
    /// The couples on edges of three or more half-edges, once from each triangle,
    /// sorted by triangle.
    pub(super) extra: Vec<ExtraCouple>,
}

/// A couple on an edge of three or more half-edges, seen from `triangle`.
#[derive(Clone, Copy, Debug)]
pub(super) struct ExtraCouple {
    /// The proposing triangle.
    pub(super) triangle: u32,
    /// The triangle across the edge.
    pub(super) neighbour: u32,
    /// The couple's key.
    pub(super) key: u128,
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

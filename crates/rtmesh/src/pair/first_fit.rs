//! The first-fit pairers of production ray tracers, as test oracles: do they recover
//! the pairs rtmesh wrote?
//!
//! - **Embree's quadifier** (Embree 4, `kernels/common/quadifier.h`, used for Intel's
//!   ray tracing hardware): triangles enter a window of 32 in primitive order; the
//!   oldest leaves it and pairs with the first triangle still in the window that
//!   shares two vertex indices with it, at most 31 primitives later
//!   ([`embree_window`]).
//! - **HIPRT and AMD GPURT**: each warp or wave of 32 or 64 consecutive triangles
//!   pairs first-fit among its own triangles ([`waves`]).
//!
//! Both match vertex *indices*, in any rotation and either winding. rtmesh writes a
//! pair as two consecutive triangles that share the two indices of their edge
//! ([`super::PairSettings::by_index`]), pairs first from an even position, so both
//! rules find it at distance 1 and never across a wave. Cost: O(n · window).

use super::{Pairing, UNPAIRED};

/// Two triangles share an edge by vertex index: two (or more) of `b`'s indices are
/// among `a`'s (Embree's `pair_triangles`).
pub fn share_indices(a: &[u32; 3], b: &[u32; 3]) -> bool {
    b.iter().filter(|v| a.contains(v)).count() >= 2
}

/// Embree's quadifier over `triangles` in order: each triangle not yet paired takes
/// the first unpaired triangle at most `max_distance` (31) later that shares two
/// indices with it.
pub fn embree_window(triangles: &[[u32; 3]], max_distance: usize) -> Pairing {
    first_fit(triangles, |i| {
        (i + 1)..(i + 1 + max_distance).min(triangles.len())
    })
}

/// HIPRT / GPURT: each block of `wave` consecutive triangles (32 or 64) pairs first-fit
/// within itself.
pub fn waves(triangles: &[[u32; 3]], wave: usize) -> Pairing {
    let wave = wave.max(1);
    first_fit(triangles, |i| {
        (i + 1)..((i / wave + 1) * wave).min(triangles.len())
    })
}

/// Each triangle in order, if still free, pairs with the first free one in
/// `candidates(i)` that shares two indices with it.
fn first_fit<R: Iterator<Item = usize>>(
    triangles: &[[u32; 3]],
    candidates: impl Fn(usize) -> R,
) -> Pairing {
    let mut partner = vec![UNPAIRED; triangles.len()];
    for i in 0..triangles.len() {
        if partner[i] != UNPAIRED {
            continue;
        }
        if let Some(j) = candidates(i)
            .find(|&j| partner[j] == UNPAIRED && share_indices(&triangles[i], &triangles[j]))
        {
            partner[i] = j as u32;
            partner[j] = i as u32;
        }
    }
    Pairing::from_partners(&partner)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embree_takes_the_first_match_within_31() {
        // 0 and 1 share the edge 1-2; 2 shares 0-2 with 0 but comes later.
        let t = [[0, 1, 2], [2, 1, 3], [0, 2, 4], [5, 6, 7]];
        let p = embree_window(&t, 31);
        assert_eq!(p.pairs, vec![[0, 1]]);
        assert_eq!(p.unpaired, vec![2, 3]);
        // Out of reach 32 triangles apart, in reach at 31.
        let mut far = vec![[0, 1, 2]];
        far.extend((0..31).map(|k| [10 + 3 * k, 11 + 3 * k, 12 + 3 * k]));
        far.push([2, 1, 3]);
        assert!(embree_window(&far, 31).pairs.is_empty());
        far.remove(1);
        assert_eq!(embree_window(&far, 31).pairs, vec![[0, 31]]);
    }

    #[test]
    fn waves_do_not_pair_across_their_border() {
        let t = [[9, 9, 9], [0, 1, 2], [2, 1, 3], [7, 8, 9]];
        assert!(waves(&t, 2).pairs.is_empty());
        assert_eq!(waves(&t, 4).pairs, vec![[1, 2]]);
        // Either winding and any rotation.
        assert!(share_indices(&[0, 1, 2], &[1, 2, 5]));
        assert!(!share_indices(&[0, 1, 2], &[2, 5, 6]));
    }
}

//! Pair leaves: a BVH primitive that is a triangle pair (one box for two triangles,
//! from [`crate::pair`]) and a ray–pair test built on the common edge.
//!
//! A pair is the quad `(v0, v1, v2, v3)` with triangles A = `(v0, v1, v2)` and
//! B = `(v2, v1, v3)`. The test runs Möller–Trumbore (Möller & Trumbore, JGT 1997) on
//! A as `(v1, v2, v0)` and on B as `(v1, v3, v2)`: both start at `v1`, so they share
//! the corner and `T = O − v1`, and the common edge `s = v2 − v1` is A's first edge and
//! B's second. [`Pair4`] stores each pair's `v1` once and, per axis, the edges
//! `p = v0 − v1`, `s`, `q = v3 − v1` of its four pairs in one row of twelve lanes, so
//! the eight triangles' first edges `[s | q]` and second edges `[p | s]` are two
//! overlapping loads of that row: 224 bytes for eight triangles, against 320 for two
//! [`super::triangle::Triangle4`]s. One Möller–Trumbore pass over eight lanes tests
//! them all, in 256-bit AVX registers where the CPU has them (as Embree's quad leaves
//! are tested on AVX, both triangles of four quads at once) and as `wide::f32x8`
//! elsewhere: the same operations in the same order, so the same hits. One pair counts
//! as one pair test.
//!
//! An earlier test shared arithmetic instead of lanes: B's first barycentric numerator
//! `T · (D × s)` is `−D · (T × s)`, which A computes, so four pairs in 4-wide lanes
//! took three cross and seven dot products per pair instead of four and eight. On
//! eight lanes A and B run side by side in the same instructions, so that saving is
//! gone and the leaf test costs what one [`super::triangle::Triangle4`] test costs;
//! the arithmetic-sharing form traced no faster than unpaired triangle leaves
//! (`rtmesh bench pairing`), this one does.
//!
//! A single (unpaired) triangle is a pair whose B has zero edges: its determinant is 0
//! and it never hits.
//!
//! Hits report `u`, `v` as barycentrics of corners 1 and 2 of the triangle in the
//! quad convention (`(v0, v1, v2)` or `(v2, v1, v3)`), the order
//! [`crate::pair::reorder`] writes.

use super::intersect::LaneHits;
use super::{Counters, Hit, LeafBlock, RayQuery};
use crate::bvh::Primitive;
use crate::geom::Aabb;
use crate::mesh::TriMesh;
use crate::pair::{quad, Pairing};
#[cfg(target_arch = "x86_64")]
use crate::simd::Avx8;
use crate::simd::{Lanes, V3};
use glam::Vec3;
use std::ops::Sub;
use wide::f32x8;

/// A pair (or a single triangle) as the BVH builder sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrianglePair {
    /// `v0, v1, v2, v3` (a single triangle repeats `v2` as `v3`).
    pub corners: [Vec3; 4],
    /// Input ids of A and B (`u32::MAX` for B of a single triangle).
    pub ids: [u32; 2],
}

impl TrianglePair {
    /// Whether this holds two triangles.
    pub fn is_pair(&self) -> bool {
        self.ids[1] != u32::MAX
    }
}

impl Primitive for TrianglePair {
    /// The box of the corners as [`Pair4`] stores them (`v1` plus an edge, rounded),
    /// so that a leaf's recomputed box is bit-identical to the box it was built with.
    fn bounds(&self) -> Aabb {
        let [v0, v1, v2, v3] = self.corners;
        let b = Aabb::from_points(&[v1, v1 + (v2 - v1), v1 + (v0 - v1)]);
        if self.is_pair() {
            b.grown_by_point(v1 + (v3 - v1))
        } else {
            b
        }
    }
}

/// The tracer's pairs of `mesh` for `pairing` (found on `mesh`): pairs in the quad
/// convention, then the unpaired triangles with indices in range.
pub fn mesh_pairs(mesh: &TriMesh, pairing: &Pairing) -> Vec<TrianglePair> {
    let position = |v: u32| mesh.positions[v as usize];
    let n = mesh.positions.len();
    let pairs = pairing.pairs.iter().map(|&[a, b]| {
        let (q, _) = quad(&mesh.triangles[a as usize], &mesh.triangles[b as usize])
            .expect("paired triangles share an edge in opposite directions");
        TrianglePair {
            corners: q.map(position),
            ids: [a, b],
        }
    });
    let singles = pairing
        .unpaired
        .iter()
        .filter(|&&t| mesh.triangles[t as usize].iter().all(|&v| (v as usize) < n))
        .map(|&t| {
            let [a, b, c] = mesh.corners(t as usize);
            TrianglePair {
                corners: [a, b, c, c],
                ids: [t, u32::MAX],
            }
        });
    pairs.chain(singles).collect()
}

/// Pairs in a [`Pair4`].
pub const PAIR4_LANES: usize = 4;

/// Up to four pairs, structure of arrays, laid out so that their eight triangles are
/// eight lanes of one Möller–Trumbore test (A of pairs 0–3 in lanes 0–3, B in 4–7).
/// 224 bytes for up to eight triangles, against 320 for two
/// [`super::triangle::Triangle4`]s.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Pair4 {
    /// `v1` of each pair: the corner both its triangles start from.
    pub v1: [[f32; 4]; 3],
    /// Per axis, twelve lanes: `p = v0 − v1` of the four pairs, then the shared edge
    /// `s = v2 − v1`, then `q = v3 − v1` (zero for a single triangle). Lanes 0–7 are
    /// the second edges `[p | s]` of A and B, lanes 4–11 their first edges `[s | q]`.
    pub edges: [[f32; 12]; 3],
    /// Input ids of A in pairs 0–3, then of B (`u32::MAX` where there is none).
    pub ids: [u32; 8],
}

impl Pair4 {
    /// Pack one to four pairs.
    pub fn new(pairs: &[TrianglePair]) -> Self {
        assert!(
            !pairs.is_empty() && pairs.len() <= PAIR4_LANES,
            "1 to 4 pairs per block"
        );
        let mut block = Pair4 {
            v1: [[0.0; 4]; 3],
            edges: [[0.0; 12]; 3],
            ids: [u32::MAX; 8],
        };
        for lane in 0..PAIR4_LANES {
            // Unused lanes repeat lane 0's corner with zero edges: they never hit.
            let pair = pairs.get(lane);
            let [v0, v1, v2, v3] = pair.unwrap_or(&pairs[0]).corners;
            let used = pair.is_some();
            let single = pair.is_none_or(|p| !p.is_pair());
            let p = if used { v0 - v1 } else { Vec3::ZERO };
            let s = if used { v2 - v1 } else { Vec3::ZERO };
            let q = if single { Vec3::ZERO } else { v3 - v1 };
            for axis in 0..3 {
                block.v1[axis][lane] = v1[axis];
                block.edges[axis][lane] = p[axis];
                block.edges[axis][4 + lane] = s[axis];
                block.edges[axis][8 + lane] = q[axis];
            }
            if let Some(pair) = pair {
                block.ids[lane] = pair.ids[0];
                block.ids[4 + lane] = pair.ids[1];
            }
        }
        block
    }

    /// Used pairs and singles (1..=4).
    #[inline(always)]
    pub fn count(&self) -> u32 {
        self.ids[..4].iter().filter(|&&id| id != u32::MAX).count() as u32
    }

    /// Lanes that hold two triangles.
    #[inline(always)]
    pub fn pairs(&self) -> u32 {
        self.ids[4..].iter().filter(|&&id| id != u32::MAX).count() as u32
    }

    /// Möller–Trumbore on the eight triangles as lanes of `L` (eight wide): A as
    /// `(v1, v2, v0)` with edges `(s, p)`, B as `(v1, v3, v2)` with edges `(q, s)`, so
    /// that both start at `v1` and each edge row is one load. The lanes hit inside
    /// `(t_min, t_max)` (`None` when none is), with `(u, v)` in the quad convention.
    #[inline(always)]
    fn test<L: Lanes>(&self, ray: &RayQuery, t_max: f32) -> Option<LaneHits<L>> {
        debug_assert_eq!(L::WIDTH, 8);
        let row = |offset: usize| V3 {
            x: L::load(&self.edges[0][offset..]),
            y: L::load(&self.edges[1][offset..]),
            z: L::load(&self.edges[2][offset..]),
        };
        let (e2, e1) = (row(0), row(4));
        let corner = V3 {
            x: L::load_repeated(&self.v1[0]),
            y: L::load_repeated(&self.v1[1]),
            z: L::load_repeated(&self.v1[2]),
        };
        let direction = V3::<L>::splat(ray.direction);
        let p = direction.cross(e2);
        let determinant = e1.dot(p);
        let inverse = L::splat(1.0) / determinant;
        let to_origin = V3::<L>::splat(ray.origin).sub(corner);
        let u = to_origin.dot(p) * inverse;
        // A zero or non-finite determinant makes `u` NaN or fails here: such lanes miss.
        let mask = L::le(L::splat(0.0), u) & L::le(u, L::splat(1.0)) & determinant.is_finite();
        let q = to_origin.cross(e1);
        let v = direction.dot(q) * inverse;
        let t = e2.dot(q) * inverse;
        let mask = mask
            & L::le(L::splat(0.0), v)
            & L::le(u + v, L::splat(1.0))
            & L::lt(L::splat(ray.t_min), t)
            & L::lt(t, L::splat(t_max));
        // MT's (u, v) weigh corners 2 and 3 of (v1, v2, v0) and (v1, v3, v2); the quad
        // convention's weigh v1 and then v2 (for A) or v3 (for B).
        L::any(mask).then(|| LaneHits {
            mask,
            t,
            u: L::splat(1.0) - u - v,
            v: u,
        })
    }

    /// The nearest hit of `L`'s test, recorded into `hit`.
    #[inline(always)]
    fn intersect_into_with<L: Lanes>(&self, ray: &RayQuery, hit: &mut Hit) -> bool {
        let Some((lane, t, u, v)) = self.test::<L>(ray, hit.t).and_then(|h| h.nearest()) else {
            return false;
        };
        hit.t = t;
        hit.u = u;
        hit.v = v;
        hit.triangle = self.ids[lane];
        true
    }
}

impl LeafBlock for Pair4 {
    #[inline(always)]
    fn intersect_into(&self, ray: &RayQuery, hit: &mut Hit) -> bool {
        self.intersect_into_with::<f32x8>(ray, hit)
    }

    #[inline(always)]
    fn occludes(&self, ray: &RayQuery, t_max: f32) -> bool {
        self.test::<f32x8>(ray, t_max).is_some()
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn intersect_into_avx(&self, ray: &RayQuery, hit: &mut Hit) -> bool {
        self.intersect_into_with::<Avx8>(ray, hit)
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn occludes_avx(&self, ray: &RayQuery, t_max: f32) -> bool {
        occludes_avx(self, ray, t_max)
    }

    #[inline(always)]
    fn count_tests<C: Counters>(&self, counters: &mut C) {
        let pairs = self.pairs();
        counters.pair_tests(pairs);
        counters.triangle_tests(self.count() - pairs);
    }
}

/// The AVX occlusion test of a block, as a function of its own. Inlined into the
/// occlusion traversal, the test's intrinsics were left as calls (LLVM stops inlining
/// `#[inline]` intrinsics into a kernel that large), which made shadow rays through pair
/// leaves 7× slower than through triangle leaves; compiled apart, with AVX, they inline.
///
/// # Safety
/// Only call it on a CPU with AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline(never)]
unsafe fn occludes_avx(block: &Pair4, ray: &RayQuery, t_max: f32) -> bool {
    block.test::<Avx8>(ray, t_max).is_some()
}

impl Primitive for Pair4 {
    fn bounds(&self) -> Aabb {
        (0..self.count() as usize).fold(Aabb::EMPTY, |b, lane| {
            let v1 = Vec3::from_array(self.v1.map(|row| row[lane]));
            let edge = |offset: usize| Vec3::from_array(self.edges.map(|row| row[offset + lane]));
            let b = b.union(Aabb::from_points(&[v1, v1 + edge(4), v1 + edge(0)]));
            if self.ids[4 + lane] == u32::MAX {
                b
            } else {
                b.grown_by_point(v1 + edge(8))
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Ray;
    use crate::random::SplitMix64;
    use crate::trace::Triangle;

    fn point(rng: &mut SplitMix64) -> Vec3 {
        Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())
    }

    /// Random blocks of one to four pairs and singles, random rays through them: the
    /// eight-lane test (portable and AVX) finds exactly the triangle, `t` and
    /// barycentrics that the scalar Möller–Trumbore test of each triangle finds nearest.
    #[test]
    fn eight_lane_test_finds_the_scalar_tests_nearest_triangle() {
        let mut rng = SplitMix64::new(7);
        let (mut hits, mut misses) = (0, 0);
        for block in 0..300u32 {
            let n = 1 + (rng.next_u64() % 4) as usize;
            let pairs: Vec<TrianglePair> = (0..n as u32)
                .map(|k| {
                    let [v0, v1, v2, v3] = std::array::from_fn(|_| point(&mut rng));
                    let single = rng.next_u64().is_multiple_of(3);
                    let id = 100 * block + 2 * k;
                    TrianglePair {
                        corners: [v0, v1, v2, if single { v2 } else { v3 }],
                        ids: [id, if single { u32::MAX } else { id + 1 }],
                    }
                })
                .collect();
            let packed = Pair4::new(&pairs);
            assert_eq!(packed.count(), n as u32);
            assert_eq!(
                packed.pairs(),
                pairs.iter().filter(|p| p.is_pair()).count() as u32
            );
            // A as (v1, v2, v0), B as (v1, v3, v2), in lane order A0..A3, B0..B3.
            let mut scalar: Vec<Triangle> = pairs
                .iter()
                .map(|p| Triangle::new([p.corners[1], p.corners[2], p.corners[0]], p.ids[0]))
                .collect();
            scalar.extend(
                pairs
                    .iter()
                    .filter(|p| p.is_pair())
                    .map(|p| Triangle::new([p.corners[1], p.corners[3], p.corners[2]], p.ids[1])),
            );
            for _ in 0..40 {
                let origin = point(&mut rng) * 3.0 - Vec3::ONE;
                let ray = RayQuery::new(&Ray::new(origin, point(&mut rng) - origin));
                let mut expected = Hit::MISS;
                for triangle in &scalar {
                    if let Some((t, u, v)) = triangle.intersect(&ray, expected.t) {
                        // The quad convention: weights of v1, then of v2 (A) or v3 (B).
                        (expected.t, expected.u, expected.v) = (t, 1.0 - u - v, u);
                        expected.triangle = triangle.id;
                    }
                }
                let mut got = Hit::MISS;
                let found = packed.intersect_into(&ray, &mut got);
                assert_eq!(found, expected.is_hit());
                assert_eq!(got, expected, "block {block}");
                assert_eq!(packed.occludes(&ray, f32::INFINITY), found);
                #[cfg(target_arch = "x86_64")]
                if crate::simd::has_avx() {
                    let mut avx = Hit::MISS;
                    // SAFETY: the CPU has AVX (in a function compiled without it the
                    // intrinsics run as calls, same instructions).
                    unsafe {
                        assert_eq!(packed.intersect_into_avx(&ray, &mut avx), found);
                        assert_eq!(packed.occludes_avx(&ray, f32::INFINITY), found);
                    }
                    assert_eq!(avx, got);
                }
                if found {
                    hits += 1;
                } else {
                    misses += 1;
                }
            }
        }
        assert!(hits > 1000 && misses > 1000, "{hits} hits, {misses} misses");
    }
}

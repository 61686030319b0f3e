//! Pair leaves: a BVH primitive that is a triangle pair (one box for two triangles,
//! from [`crate::pair`]) and a ray–pair test that shares the common edge's arithmetic.
//!
//! A pair is the quad `(v0, v1, v2, v3)` with triangles A = `(v0, v1, v2)` and
//! B = `(v2, v1, v3)`. The test runs Möller–Trumbore (Möller & Trumbore, JGT 1997) on
//! A as `(v1, v2, v0)` and on B as `(v1, v3, v2)`: both start at `v1`, so they share
//! `T = O − v1`, and the shared edge `s = v2 − v1` is A's first edge and B's second.
//! B's first barycentric numerator `T · (D × s)` equals `−D · (T × s)`, which A has
//! already computed, and B's determinant `(v3 − v1) · (D × s)` is `D · (s × (v3 − v1))`
//! with the normal `s × (v3 − v1)` stored: per pair three cross products, seven dot
//! products and two divisions, against four, eight and two for two separate tests.
//! [`Pair4`] packs four pairs structure-of-arrays (288 bytes, up to eight triangles)
//! and tests them in one 4-wide SIMD pass. A single (unpaired) triangle is a pair
//! whose B has zero edges: its determinant is 0 and it never hits.
//!
//! Hits report `u`, `v` as barycentrics of corners 1 and 2 of the triangle in the
//! quad convention (`(v0, v1, v2)` or `(v2, v1, v3)`), the order
//! [`crate::pair::reorder`] writes.

use super::lanes::V3;
use super::{Counters, Hit, LeafBlock, RayQuery};
use crate::bvh::Primitive;
use crate::geom::Aabb;
use crate::mesh::TriMesh;
use crate::pair::{quad, Pairing};
use glam::Vec3;
use std::ops::Sub;
use wide::f32x4;

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

/// Lanes in a [`Pair4`].
pub const PAIR4_LANES: usize = 4;

/// Up to four pairs, structure of arrays, in the form the shared-edge test reads.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct Pair4 {
    /// `v1`: the corner both triangles start from.
    pub v1: [[f32; 4]; 3],
    /// `s = v2 − v1`: the shared edge.
    pub s: [[f32; 4]; 3],
    /// `p = v0 − v1`.
    pub p: [[f32; 4]; 3],
    /// `q = v3 − v1` (zero for a single triangle).
    pub q: [[f32; 4]; 3],
    /// `s × q`: B's normal (zero for a single triangle).
    pub normal_b: [[f32; 4]; 3],
    /// Input ids of A and of B per lane (`u32::MAX` where there is none).
    pub ids: [[u32; 4]; 2],
    /// Used lanes (1..=4).
    pub count: u32,
    /// Lanes that hold two triangles.
    pub pairs: u32,
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
            s: [[0.0; 4]; 3],
            p: [[0.0; 4]; 3],
            q: [[0.0; 4]; 3],
            normal_b: [[0.0; 4]; 3],
            ids: [[u32::MAX; 4]; 2],
            count: pairs.len() as u32,
            pairs: pairs.iter().filter(|p| p.is_pair()).count() as u32,
        };
        for lane in 0..PAIR4_LANES {
            // Unused lanes repeat lane 0's corner with zero edges: they never hit.
            let pair = pairs.get(lane);
            let [v0, v1, v2, v3] = pair.unwrap_or(&pairs[0]).corners;
            let used = pair.is_some();
            let single = pair.is_none_or(|p| !p.is_pair());
            let s = if used { v2 - v1 } else { Vec3::ZERO };
            let p = if used { v0 - v1 } else { Vec3::ZERO };
            let q = if single { Vec3::ZERO } else { v3 - v1 };
            for axis in 0..3 {
                block.v1[axis][lane] = v1[axis];
                block.s[axis][lane] = s[axis];
                block.p[axis][lane] = p[axis];
                block.q[axis][lane] = q[axis];
                block.normal_b[axis][lane] = s.cross(q)[axis];
            }
            if let Some(pair) = pair {
                block.ids[0][lane] = pair.ids[0];
                block.ids[1][lane] = pair.ids[1];
            }
        }
        block
    }

    /// The shared-edge test on all lanes: for A and B, the mask of lanes hit inside
    /// `(t_min, t_max)`, `t`, and the quad-convention `(u, v)`.
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn test(&self, ray: &RayQuery, t_max: f32) -> [(u32, [f32; 4], f32x4, f32x4); 2] {
        let direction = V3::<f32x4>::splat(ray.direction);
        let to_origin = V3::<f32x4>::splat(ray.origin).sub(V3::from_rows(&self.v1));
        let s = V3::from_rows(&self.s);
        let p = V3::from_rows(&self.p);
        let zero = f32x4::ZERO;
        let one = f32x4::ONE;
        let (t_min, t_max) = (f32x4::splat(ray.t_min), f32x4::splat(t_max));
        let inside = |u: f32x4, v: f32x4, t: f32x4, determinant: f32x4| {
            (u.simd_ge(zero)
                & v.simd_ge(zero)
                & (u + v).simd_le(one)
                & t.simd_gt(t_min)
                & t.simd_lt(t_max)
                & determinant.simd_ne(zero)
                & determinant.is_finite())
            .to_bitmask()
        };
        // A = (v1, v2, v0): edges s and p.
        let p_a = direction.cross(p);
        let det_a = s.dot(p_a);
        let inv_a = one / det_a;
        let u_a = to_origin.dot(p_a) * inv_a; // weight of v2
        let q_a = to_origin.cross(s);
        let shared = direction.dot(q_a); // the shared edge's term
        let v_a = shared * inv_a; // weight of v0
        let t_a = p.dot(q_a) * inv_a;
        // B = (v1, v3, v2): edges q and s; first numerator is −shared.
        let q = V3::from_rows(&self.q);
        let det_b = direction.dot(V3::from_rows(&self.normal_b));
        let inv_b = one / det_b;
        let u_b = -shared * inv_b; // weight of v3
        let q_b = to_origin.cross(q);
        let v_b = direction.dot(q_b) * inv_b; // weight of v2
        let t_b = s.dot(q_b) * inv_b;
        [
            // (v0, v1, v2): u = weight of v1, v = weight of v2.
            (
                inside(u_a, v_a, t_a, det_a),
                t_a.to_array(),
                one - u_a - v_a,
                u_a,
            ),
            // (v2, v1, v3): u = weight of v1, v = weight of v3.
            (
                inside(u_b, v_b, t_b, det_b),
                t_b.to_array(),
                one - u_b - v_b,
                u_b,
            ),
        ]
    }
}

impl LeafBlock for Pair4 {
    #[inline(always)]
    fn intersect_into(&self, ray: &RayQuery, hit: &mut Hit) -> bool {
        let results = self.test(ray, hit.t);
        let mut best: Option<(usize, usize)> = None;
        let mut best_t = hit.t;
        for (triangle, (mask, t, _, _)) in results.iter().enumerate() {
            let mut mask = *mask;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if t[lane] < best_t {
                    best_t = t[lane];
                    best = Some((triangle, lane));
                }
            }
        }
        let Some((triangle, lane)) = best else {
            return false;
        };
        let (_, t, u, v) = &results[triangle];
        hit.t = t[lane];
        hit.u = u.to_array()[lane];
        hit.v = v.to_array()[lane];
        hit.triangle = self.ids[triangle][lane];
        true
    }

    #[inline(always)]
    fn occludes(&self, ray: &RayQuery, t_max: f32) -> bool {
        let [a, b] = self.test(ray, t_max);
        a.0 | b.0 != 0
    }

    #[inline(always)]
    fn count_tests<C: Counters>(&self, counters: &mut C) {
        counters.pair_tests(self.pairs);
        counters.triangle_tests(self.count - self.pairs);
    }
}

impl Primitive for Pair4 {
    fn bounds(&self) -> Aabb {
        (0..self.count as usize).fold(Aabb::EMPTY, |b, lane| {
            let get = |a: &[[f32; 4]; 3]| Vec3::new(a[0][lane], a[1][lane], a[2][lane]);
            let v1 = get(&self.v1);
            let b = b.union(Aabb::from_points(&[
                v1,
                v1 + get(&self.s),
                v1 + get(&self.p),
            ]));
            if self.ids[1][lane] == u32::MAX {
                b
            } else {
                b.grown_by_point(v1 + get(&self.q))
            }
        })
    }
}

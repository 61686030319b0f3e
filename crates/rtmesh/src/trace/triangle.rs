//! The triangle leaves and the Möller–Trumbore test (Möller & Trumbore, "Fast, minimum
//! storage ray/triangle intersection", JGT 1997), with the edges precomputed at build
//! time: per test two cross products, four dot products and one division.
//!
//! [`Triangle`] is one triangle (40 bytes: corner, two edges, input id) and the scalar
//! reference. [`Triangle4`] packs the up to four triangles of a BVH leaf structure-of-
//! arrays (160 bytes) and tests them in one 4-wide SIMD pass, as Embree's `triangle4`
//! leaves do: the leaf test costs about what one scalar test costs, so the builder makes
//! full leaves of four and the tree is a level shallower. Both forms evaluate the very
//! same IEEE operations in the same order, so their hits are bit-identical.

use super::intersect::{LaneHits, TriangleLanes};
use super::{Counters, Hit, LeafBlock, RayQuery};
use crate::bvh::Primitive;
use crate::geom::Aabb;
use crate::simd::V3;
use glam::Vec3;
use std::ops::{Add, Sub};
use wide::f32x4;

/// A triangle as the tracer stores it: `v0`, `e1 = v1 − v0`, `e2 = v2 − v0` and the
/// input triangle id.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// First corner.
    pub v0: Vec3,
    /// Second corner minus the first.
    pub e1: Vec3,
    /// Third corner minus the first.
    pub e2: Vec3,
    /// Input triangle id.
    pub id: u32,
}

impl Triangle {
    /// From three corners.
    pub fn new(corners: [Vec3; 3], id: u32) -> Self {
        Self {
            v0: corners[0],
            e1: corners[1] - corners[0],
            e2: corners[2] - corners[0],
            id,
        }
    }

    /// Möller–Trumbore: `(t, u, v)` when the ray hits inside `(t_min, t_max)`.
    /// Degenerate triangles, rays in the triangle's plane, zero and NaN directions miss.
    #[inline(always)]
    pub fn intersect(&self, ray: &RayQuery, t_max: f32) -> Option<(f32, f32, f32)> {
        let p = ray.direction.cross(self.e2);
        let determinant = self.e1.dot(p);
        if determinant == 0.0 || !determinant.is_finite() {
            return None;
        }
        let inverse = 1.0 / determinant;
        let s = ray.origin - self.v0;
        let u = s.dot(p) * inverse;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(self.e1);
        let v = ray.direction.dot(q) * inverse;
        if !(v >= 0.0 && u + v <= 1.0) {
            return None;
        }
        let t = self.e2.dot(q) * inverse;
        (t > ray.t_min && t < t_max).then_some((t, u, v))
    }

    /// Test and, when closer, record the hit.
    #[inline(always)]
    pub fn intersect_into(&self, ray: &RayQuery, hit: &mut Hit) -> bool {
        match self.intersect(ray, hit.t) {
            Some((t, u, v)) => {
                hit.t = t;
                hit.u = u;
                hit.v = v;
                hit.triangle = self.id;
                true
            }
            None => false,
        }
    }
}

impl Primitive for Triangle {
    fn bounds(&self) -> Aabb {
        Aabb::from_points(&[self.v0, self.v0 + self.e1, self.v0 + self.e2])
    }
}

/// Lanes in a [`Triangle4`].
pub const TRIANGLE4_LANES: usize = 4;

/// Up to four triangles, structure of arrays: `v0[axis][lane]`, and likewise `e1`, `e2`
/// (160 bytes, 32-byte aligned so that a block spans exactly three cache lines).
/// Unused lanes have zero edges (their determinant is 0, so they never hit).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Triangle4 {
    /// First corners.
    pub v0: [[f32; 4]; 3],
    /// First edges.
    pub e1: [[f32; 4]; 3],
    /// Second edges.
    pub e2: [[f32; 4]; 3],
    /// Input triangle ids (`u32::MAX` in unused lanes, which come last).
    pub ids: [u32; 4],
}

impl Triangle4 {
    /// Pack up to four triangles.
    pub fn new(triangles: &[Triangle]) -> Self {
        assert!(
            !triangles.is_empty() && triangles.len() <= TRIANGLE4_LANES,
            "1 to 4 triangles per block"
        );
        let mut block = Self::of_one(&triangles[0]);
        for (lane, t) in triangles.iter().enumerate().skip(1) {
            block.set(lane, t);
        }
        block
    }

    /// The block of `t` alone. Unused lanes repeat its first corner with zero edges:
    /// inside the leaf's box.
    #[inline(always)]
    pub fn of_one(t: &Triangle) -> Self {
        let lane0 = |x: f32| [x, 0.0, 0.0, 0.0];
        Triangle4 {
            v0: [[t.v0.x; 4], [t.v0.y; 4], [t.v0.z; 4]],
            e1: [lane0(t.e1.x), lane0(t.e1.y), lane0(t.e1.z)],
            e2: [lane0(t.e2.x), lane0(t.e2.y), lane0(t.e2.z)],
            ids: [t.id, u32::MAX, u32::MAX, u32::MAX],
        }
    }

    /// Put `t` in `lane` (one [`Self::of_one`] left unused, or one to overwrite).
    #[inline(always)]
    pub fn set(&mut self, lane: usize, t: &Triangle) {
        for axis in 0..3 {
            self.v0[axis][lane] = t.v0[axis];
            self.e1[axis][lane] = t.e1[axis];
            self.e2[axis][lane] = t.e2[axis];
        }
        self.ids[lane] = t.id;
    }

    /// Used lanes (1..=4).
    #[inline(always)]
    pub fn count(&self) -> u32 {
        self.ids.iter().filter(|&&id| id != u32::MAX).count() as u32
    }

    /// The triangle in `lane`.
    pub fn triangle(&self, lane: usize) -> Triangle {
        let get = |a: &[[f32; 4]; 3]| Vec3::new(a[0][lane], a[1][lane], a[2][lane]);
        Triangle {
            v0: get(&self.v0),
            e1: get(&self.e1),
            e2: get(&self.e2),
            id: self.ids[lane],
        }
    }

    /// Möller–Trumbore on all four lanes: the lanes hit inside `(t_min, t_max)` and
    /// their `(t, u, v)`.
    #[inline(always)]
    fn test(&self, ray: &RayQuery, t_max: f32) -> LaneHits<f32x4> {
        let direction = V3::<f32x4>::splat(ray.direction);
        let e1 = V3::from_rows(&self.e1);
        let e2 = V3::from_rows(&self.e2);
        let p = direction.cross(e2);
        let determinant = e1.dot(p);
        let inverse = f32x4::ONE / determinant;
        let s = V3::<f32x4>::splat(ray.origin).sub(V3::from_rows(&self.v0));
        let u = s.dot(p) * inverse;
        let q = s.cross(e1);
        let v = direction.dot(q) * inverse;
        let t = e2.dot(q) * inverse;
        let zero = f32x4::ZERO;
        // NaN (from a zero determinant) fails every comparison, so degenerate lanes miss.
        let inside = u.simd_ge(zero)
            & u.simd_le(f32x4::ONE)
            & v.simd_ge(zero)
            & (u + v).simd_le(f32x4::ONE)
            & t.simd_gt(f32x4::splat(ray.t_min))
            & t.simd_lt(f32x4::splat(t_max))
            & determinant.simd_ne(zero)
            & determinant.is_finite();
        LaneHits {
            mask: inside,
            t,
            u,
            v,
        }
    }
}

impl LeafBlock for Triangle4 {
    /// The closest lane hit before `hit.t`, recorded into `hit`.
    #[inline(always)]
    fn intersect_into(&self, ray: &RayQuery, hit: &mut Hit) -> bool {
        let Some((lane, t, u, v)) = self.test(ray, hit.t).nearest() else {
            return false;
        };
        hit.t = t;
        hit.u = u;
        hit.v = v;
        hit.triangle = self.ids[lane];
        true
    }

    /// Whether any lane is hit inside `(t_min, t_max)`.
    #[inline(always)]
    fn occludes(&self, ray: &RayQuery, t_max: f32) -> bool {
        self.test(ray, t_max).mask.any()
    }

    #[inline(always)]
    fn count_tests<C: Counters>(&self, counters: &mut C) {
        counters.triangle_tests(self.count());
    }
}

impl Primitive for Triangle4 {
    fn bounds(&self) -> Aabb {
        (0..self.count() as usize)
            .fold(Aabb::EMPTY, |b, lane| b.union(self.triangle(lane).bounds()))
    }
}

/// A leaf block as intersector lanes: `P0`, `E1`, `E2` as stored, `P1 = P0 + E1`,
/// `P2 = P0 + E2` and `N = E1 × E2` derived.
impl TriangleLanes<f32x4> for Triangle4 {
    #[inline(always)]
    fn v0(&self) -> V3<f32x4> {
        V3::from_rows(&self.v0)
    }
    #[inline(always)]
    fn v1(&self) -> V3<f32x4> {
        self.v0().add(self.e1())
    }
    #[inline(always)]
    fn v2(&self) -> V3<f32x4> {
        self.v0().add(self.e2())
    }
    #[inline(always)]
    fn e1(&self) -> V3<f32x4> {
        V3::from_rows(&self.e1)
    }
    #[inline(always)]
    fn e2(&self) -> V3<f32x4> {
        V3::from_rows(&self.e2)
    }
    #[inline(always)]
    fn normal(&self) -> V3<f32x4> {
        self.e1().cross(self.e2())
    }
}

//! The triangle leaf and the Möller–Trumbore test (Möller & Trumbore, "Fast, minimum
//! storage ray/triangle intersection", JGT 1997), with the edges precomputed at build
//! time: per test two cross products, four dot products and one division.
//! Cost: 40 bytes per triangle (corner, two edges, input id).

use super::{Hit, RayQuery};
use crate::bvh::Primitive;
use crate::geom::Aabb;
use glam::Vec3;

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

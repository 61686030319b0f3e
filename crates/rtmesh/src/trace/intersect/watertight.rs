//! Woop, Benthin & Wald, "Watertight ray/triangle intersection" (JCGT 2013): translate
//! to the origin, permute so the direction's largest axis is z, shear, and evaluate
//! the 2D edge functions, which are antisymmetric in floating point, so a ray through a
//! shared edge or vertex of a closed mesh hits at least one of the triangles.

use super::{accept_t, BasicRay, Intersector, IntersectorKind, LaneHits, TriangleLanes};
use crate::simd::{Lanes, V3};
use glam::Vec3;
use std::ops::Sub;

/// The watertight test's per-ray terms: axes `[kx, ky, kz]` (`kz` the largest
/// |direction| component, `kx` and `ky` the next two, swapped when `direction[kz] < 0`
/// to keep the winding) and the shear `(d[kx] / d[kz], d[ky] / d[kz], 1 / d[kz])` (as
/// products with `1 / d[kz]`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Shear {
    axes: [usize; 3],
    shear: Vec3,
}

/// Woop et al.'s watertight test.
#[derive(Clone, Copy, Debug, Default)]
pub struct Watertight;

impl Intersector for Watertight {
    const KIND: IntersectorKind = IntersectorKind::Watertight;
    type PerRay = Shear;
    /// The corners relative to the packet origin.
    type Shared<L: Lanes> = [V3<L>; 3];
    #[inline(always)]
    fn prepare(ray: &BasicRay) -> Shear {
        let d = ray.direction;
        let magnitude = d.abs();
        let kz = if magnitude.x >= magnitude.y && magnitude.x >= magnitude.z {
            0
        } else if magnitude.y >= magnitude.z {
            1
        } else {
            2
        };
        let (kx, ky) = if d[kz] < 0.0 {
            ((kz + 2) % 3, (kz + 1) % 3)
        } else {
            ((kz + 1) % 3, (kz + 2) % 3)
        };
        // An exact division: a zero direction gives NaN shears, so it misses.
        let inverse_z = 1.0 / d[kz];
        Shear {
            axes: [kx, ky, kz],
            shear: Vec3::new(d[kx] * inverse_z, d[ky] * inverse_z, inverse_z),
        }
    }
    #[inline(always)]
    fn share<L: Lanes>(triangles: &impl TriangleLanes<L>, origin: Vec3) -> [V3<L>; 3] {
        let o = V3::splat(origin);
        [
            triangles.v0().sub(o),
            triangles.v1().sub(o),
            triangles.v2().sub(o),
        ]
    }
    #[inline(always)]
    fn test<L: Lanes>(
        _: &impl TriangleLanes<L>,
        corners: &[V3<L>; 3],
        ray: &BasicRay,
        shear: &Shear,
        t_max: f32,
    ) -> Option<LaneHits<L>> {
        let [kx, ky, kz] = shear.axes;
        let (sx, sy) = (L::splat(shear.shear.x), L::splat(shear.shear.y));
        let sheared = |p: &V3<L>| {
            let z = p.axis(kz);
            (p.axis(kx) - sx * z, p.axis(ky) - sy * z)
        };
        let (ax, ay) = sheared(&corners[0]);
        let (bx, by) = sheared(&corners[1]);
        let (cx, cy) = sheared(&corners[2]);
        let edge_u = cx * by - cy * bx;
        let edge_v = ax * cy - ay * cx;
        let edge_w = bx * ay - by * ax;
        let zero = L::splat(0.0);
        let mask = (L::le(zero, edge_u) & L::le(zero, edge_v) & L::le(zero, edge_w))
            | (L::le(edge_u, zero) & L::le(edge_v, zero) & L::le(edge_w, zero));
        let determinant = edge_u + edge_v + edge_w;
        let mask = mask & L::ne(determinant, zero);
        if !L::any(mask) {
            return None;
        }
        let sz = L::splat(shear.shear.z);
        let scaled_t = edge_u * (sz * corners[0].axis(kz))
            + edge_v * (sz * corners[1].axis(kz))
            + edge_w * (sz * corners[2].axis(kz));
        let inverse = L::splat(1.0) / determinant;
        accept_t(
            mask,
            scaled_t * inverse,
            edge_v * inverse,
            edge_w * inverse,
            ray,
            t_max,
        )
    }
}

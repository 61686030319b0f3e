//! Möller–Trumbore (JGT 1997) and the two forms of Komatsu et al.: `MollerPre` with
//! precomputed edges and normal (Eq. 2) and `MollerPacket`, whose terms shared by the
//! rays of a packet are computed once per packet and triangle (Eq. 3). Per test: two
//! cross and four dot products; one cross and three dots; three dots.

use super::{
    accept_t, scaled_test, unit_range, BasicRay, Intersector, IntersectorKind, LaneHits,
    TriangleLanes,
};
use crate::simd::{Lanes, V3};
use glam::Vec3;
use std::ops::Sub;

/// Möller–Trumbore as published: edges and determinant per test.
#[derive(Clone, Copy, Debug, Default)]
pub struct Moller;

impl Intersector for Moller {
    const KIND: IntersectorKind = IntersectorKind::Moller;
    type PerRay = ();
    type Shared<L: Lanes> = ();
    #[inline(always)]
    fn prepare(_: &BasicRay) {}
    #[inline(always)]
    fn share<L: Lanes>(_: &impl TriangleLanes<L>, _: Vec3) {}
    #[inline(always)]
    fn test<L: Lanes>(
        triangles: &impl TriangleLanes<L>,
        _: &(),
        ray: &BasicRay,
        _: &(),
        t_max: f32,
    ) -> Option<LaneHits<L>> {
        let v0 = triangles.v0();
        let e1 = triangles.v1().sub(v0);
        let e2 = triangles.v2().sub(v0);
        let d = V3::splat(ray.direction);
        let p = d.cross(e2);
        let determinant = e1.dot(p);
        let inverse = L::splat(1.0) / determinant;
        let s = V3::splat(ray.origin).sub(v0);
        let u = s.dot(p) * inverse;
        let mask = unit_range(u) & determinant.is_finite();
        if !L::any(mask) {
            return None;
        }
        let q = s.cross(e1);
        let v = d.dot(q) * inverse;
        let mask = mask & L::le(L::splat(0.0), v) & L::le(u + v, L::splat(1.0));
        if !L::any(mask) {
            return None;
        }
        let t = e2.dot(q) * inverse;
        accept_t(mask, t, u, v, ray, t_max)
    }
}

/// The "improved Möller" of Eq. (2): `N`, `E1`, `E2` precomputed per triangle.
#[derive(Clone, Copy, Debug, Default)]
pub struct MollerPre;

impl Intersector for MollerPre {
    const KIND: IntersectorKind = IntersectorKind::MollerPre;
    type PerRay = ();
    type Shared<L: Lanes> = ();
    #[inline(always)]
    fn prepare(_: &BasicRay) {}
    #[inline(always)]
    fn share<L: Lanes>(_: &impl TriangleLanes<L>, _: Vec3) {}
    #[inline(always)]
    fn test<L: Lanes>(
        triangles: &impl TriangleLanes<L>,
        _: &(),
        ray: &BasicRay,
        _: &(),
        t_max: f32,
    ) -> Option<LaneHits<L>> {
        let d = V3::splat(ray.direction);
        let n = triangles.normal();
        let denominator = n.dot(d);
        let s = V3::splat(ray.origin) - triangles.v0();
        let c = d.cross(s);
        scaled_test(
            denominator,
            c.dot(triangles.e2()),
            || -c.dot(triangles.e1()),
            || -n.dot(s),
            ray,
            t_max,
        )
    }
}

/// Eq. (3): per (packet, triangle) `−N·S`, `S × E2`, `E1 × S`; per ray three dots.
#[derive(Clone, Copy, Debug, Default)]
pub struct MollerPacket;

/// [`MollerPacket`]'s shared terms.
#[derive(Clone, Copy)]
pub struct MollerPacketTerms<L> {
    normal: V3<L>,
    u_axis: V3<L>,
    v_axis: V3<L>,
    minus_n_dot_s: L,
}

impl Intersector for MollerPacket {
    const KIND: IntersectorKind = IntersectorKind::MollerPacket;
    type PerRay = ();
    type Shared<L: Lanes> = MollerPacketTerms<L>;
    #[inline(always)]
    fn prepare(_: &BasicRay) {}
    #[inline(always)]
    fn share<L: Lanes>(triangles: &impl TriangleLanes<L>, origin: Vec3) -> MollerPacketTerms<L> {
        let s = V3::splat(origin).sub(triangles.v0());
        let normal = triangles.normal();
        MollerPacketTerms {
            normal,
            u_axis: s.cross(triangles.e2()),
            v_axis: triangles.e1().cross(s),
            minus_n_dot_s: -normal.dot(s),
        }
    }
    #[inline(always)]
    fn test<L: Lanes>(
        _: &impl TriangleLanes<L>,
        terms: &MollerPacketTerms<L>,
        ray: &BasicRay,
        _: &(),
        t_max: f32,
    ) -> Option<LaneHits<L>> {
        let d = V3::splat(ray.direction);
        scaled_test(
            terms.normal.dot(d),
            d.dot(terms.u_axis),
            || d.dot(terms.v_axis),
            || terms.minus_n_dot_s,
            ray,
            t_max,
        )
    }
}

//! The packet Plücker test, the packet paper's other baseline: the corners moved to the
//! packet origin and the three edge moments computed once per packet; per ray three
//! dot products whose signs must agree.

use super::{accept_t, BasicRay, Intersector, IntersectorKind, LaneHits, TriangleLanes};
use crate::simd::{Lanes, V3};
use glam::Vec3;
use std::ops::{Add, Sub};

/// The packet Plücker test: edge moments about the packet origin, three signs per ray.
#[derive(Clone, Copy, Debug, Default)]
pub struct Pluecker;

/// [`Pluecker`]'s shared terms.
#[derive(Clone, Copy)]
pub struct PlueckerTerms<L> {
    moments: [V3<L>; 3],
    normal_dot_a: L,
}

impl Intersector for Pluecker {
    const KIND: IntersectorKind = IntersectorKind::Pluecker;
    type PerRay = ();
    type Shared<L: Lanes> = PlueckerTerms<L>;
    #[inline(always)]
    fn prepare(_: &BasicRay) {}
    #[inline(always)]
    fn share<L: Lanes>(triangles: &impl TriangleLanes<L>, origin: Vec3) -> PlueckerTerms<L> {
        let o = V3::splat(origin);
        let (a, b, c) = (
            triangles.v0().sub(o),
            triangles.v1().sub(o),
            triangles.v2().sub(o),
        );
        let moments = [b.cross(c), c.cross(a), a.cross(b)];
        let normal = moments[0].add(moments[1]).add(moments[2]);
        PlueckerTerms {
            moments,
            normal_dot_a: normal.dot(a),
        }
    }
    #[inline(always)]
    fn test<L: Lanes>(
        _: &impl TriangleLanes<L>,
        terms: &PlueckerTerms<L>,
        ray: &BasicRay,
        _: &(),
        t_max: f32,
    ) -> Option<LaneHits<L>> {
        let d = V3::splat(ray.direction);
        let zero = L::splat(0.0);
        let w0 = d.dot(terms.moments[0]);
        let w1 = d.dot(terms.moments[1]);
        let positive = L::le(zero, w0) & L::le(zero, w1);
        let negative = L::le(w0, zero) & L::le(w1, zero);
        if !L::any(positive | negative) {
            return None;
        }
        let w2 = d.dot(terms.moments[2]);
        let denominator = w0 + w1 + w2;
        let mask = ((positive & L::le(zero, w2)) | (negative & L::le(w2, zero)))
            & L::ne(denominator, zero);
        if !L::any(mask) {
            return None;
        }
        let inverse = L::splat(1.0) / denominator;
        accept_t(
            mask,
            terms.normal_dot_a * inverse,
            w1 * inverse,
            w2 * inverse,
            ray,
            t_max,
        )
    }
}

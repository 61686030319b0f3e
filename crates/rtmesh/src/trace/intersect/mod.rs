//! Ray–triangle intersectors of Komatsu et al., "Accelerating Möller intersection
//! algorithm using ray packets", and the two references they are judged against:
//!
//! - [`Moller`]: Möller–Trumbore as published (JGT 1997): edges `E1 = P1 − P0`,
//!   `E2 = P2 − P0` and the determinant per test; two cross and four dot products.
//! - [`MollerPre`]: the paper's "improved Möller", Eq. (2): `N = E1 × E2`, `E1`, `E2`
//!   stored per triangle; per test `C = D × S`, then `u = C·E2 / N·D`,
//!   `v = −C·E1 / N·D`, `t = −N·S / N·D` with `S = O − P0`: one cross, three dots.
//!   Range tests run on the numerators against |N·D| (signs folded in), and the one
//!   division happens only for a hit, as in Embree's Möller–Trumbore.
//! - [`MollerPacket`]: Eq. (3): rays of a packet share the origin `O`, so per (packet,
//!   triangle) `N·S`, `S × E2` and `E1 × S` are computed once (the paper's `−S' × E2`
//!   and `S' × E1` with `S' = P0 − O`); per ray only `D·(S × E2)`, `D·(E1 × S)` and
//!   `N·D`: three dot products, and a division only for hits (numerators tested
//!   against |N·D| as in `MollerPre`). It rejects on `u` before computing `v`, and on
//!   `v` before `t`, as the paper does.
//! - [`Pluecker`]: the packet Plücker test, the paper's other baseline: per packet the
//!   corners move to the packet origin (`A = P0 − O`, ...), the three edge moments
//!   `B × C`, `C × A`, `A × B` are computed once; per ray three dots whose signs must
//!   agree (Möller–Trumbore's barycentrics fall out as the normalised moments).
//! - [`Watertight`]: Woop, Benthin & Wald, "Watertight ray/triangle intersection"
//!   (JCGT 2013): translate to the origin, permute so the direction's largest axis is
//!   z, shear, and evaluate the 2D edge functions. Each edge function is antisymmetric
//!   in floating point, so a ray through a shared edge or vertex of a closed mesh hits
//!   at least one of the triangles: the robust reference.
//!
//! All five are written once over [`Lanes`]: `f32` is the scalar reference (one
//! triangle per test, with the early-outs as real branches), `wide::f32x4` and the AVX
//! `Avx8` (module `crate::simd`) test 4 and 8 triangles at once (an early-out then needs every
//! lane to fail). No fused multiply-add is used, so all widths agree bit for bit.
//!
//! Conventions: `(u, v)` weight the second and third corner, a hit needs
//! `t_min < t < t_max`, and degenerate triangles, rays in a triangle's plane, zero and
//! NaN directions all miss (a zero or non-finite denominator fails every range test).

mod moller;
mod pluecker;
mod soa;
mod watertight;

pub use moller::{Moller, MollerPacket, MollerPacketTerms, MollerPre};
pub use pluecker::{Pluecker, PlueckerTerms};
pub use soa::{
    closest_without_bvh, closest_without_bvh_by_kind, packet_closest_without_bvh, Simd,
    TriangleSoa, MAX_LANES, MAX_PACKET_RAYS,
};
pub use watertight::{Shear, Watertight};

use crate::geom::Ray;
use crate::simd::{Lanes, V3};
use glam::Vec3;
use std::fmt;

/// The intersector names accepted on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IntersectorKind {
    /// [`Moller`].
    Moller,
    /// [`MollerPre`].
    MollerPre,
    /// [`MollerPacket`].
    MollerPacket,
    /// [`Pluecker`].
    Pluecker,
    /// [`Watertight`].
    Watertight,
}

impl IntersectorKind {
    /// Every intersector, in the paper's order, then the robust one.
    pub const ALL: [IntersectorKind; 5] = [
        Self::Moller,
        Self::MollerPre,
        Self::MollerPacket,
        Self::Pluecker,
        Self::Watertight,
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Moller => "moller",
            Self::MollerPre => "moller-pre",
            Self::MollerPacket => "moller-packet",
            Self::Pluecker => "pluecker",
            Self::Watertight => "watertight",
        }
    }
}

/// Code generic over the intersector, run for a name chosen at run time with
/// [`IntersectorKind::dispatch`].
pub trait WithIntersector {
    /// What the code returns.
    type Output;
    /// Run with intersector `I`.
    fn run<I: Intersector>(self) -> Self::Output;
}

impl IntersectorKind {
    /// Run `code` with the intersector this names.
    pub fn dispatch<W: WithIntersector>(self, code: W) -> W::Output {
        match self {
            Self::Moller => code.run::<Moller>(),
            Self::MollerPre => code.run::<MollerPre>(),
            Self::MollerPacket => code.run::<MollerPacket>(),
            Self::Pluecker => code.run::<Pluecker>(),
            Self::Watertight => code.run::<Watertight>(),
        }
    }
}

impl fmt::Display for IntersectorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Lanes of triangles as an intersector reads them. Storage that keeps a quantity
/// returns it; other storage derives it (a BVH leaf keeping `P0, E1, E2` derives
/// `P1 = P0 + E1` and `N = E1 × E2`).
pub trait TriangleLanes<L: Lanes> {
    /// First corners.
    fn v0(&self) -> V3<L>;
    /// Second corners.
    fn v1(&self) -> V3<L>;
    /// Third corners.
    fn v2(&self) -> V3<L>;
    /// `P1 − P0`.
    fn e1(&self) -> V3<L>;
    /// `P2 − P0`.
    fn e2(&self) -> V3<L>;
    /// `E1 × E2`.
    fn normal(&self) -> V3<L>;
}

/// The lanes one test hit, with their `t`, `u`, `v` (meaningful where `mask` is set).
#[derive(Clone, Copy)]
pub struct LaneHits<L: Lanes> {
    /// Lanes hit inside `(t_min, t_max)`.
    pub mask: L::Mask,
    /// Distances.
    pub t: L,
    /// Barycentric weight of the second corner.
    pub u: L,
    /// Barycentric weight of the third corner.
    pub v: L,
}

impl<L: Lanes> LaneHits<L> {
    /// `(lane, t, u, v)` of the nearest lane hit (the lowest lane on equal `t`).
    #[inline(always)]
    pub fn nearest(&self) -> Option<(usize, f32, f32, f32)> {
        let mut mask = L::bitmask(self.mask);
        if mask == 0 {
            return None;
        }
        let t = self.t.to_array();
        let mut best = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        while mask != 0 {
            let lane = mask.trailing_zeros() as usize;
            if t[lane] < t[best] {
                best = lane;
            }
            mask &= mask - 1;
        }
        Some((
            best,
            t[best],
            self.u.to_array()[best],
            self.v.to_array()[best],
        ))
    }
}

/// What every intersector reads of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BasicRay {
    /// Origin.
    pub origin: Vec3,
    /// Direction.
    pub direction: Vec3,
    /// Smallest accepted distance.
    pub t_min: f32,
}

impl From<&Ray> for BasicRay {
    #[inline(always)]
    fn from(ray: &Ray) -> Self {
        Self {
            origin: ray.origin,
            direction: ray.direction,
            t_min: ray.t_min,
        }
    }
}

/// A ray–triangle test over [`Lanes`], split into what each ray needs once
/// ([`Intersector::prepare`]), what rays sharing an origin share
/// ([`Intersector::share`], once per packet and triangle lanes) and what each ray
/// does per test ([`Intersector::test`]). Single rays call all three.
pub trait Intersector: Copy + Default + Send + Sync + 'static {
    /// Which one this is.
    const KIND: IntersectorKind;
    /// Per-ray terms beyond [`BasicRay`] (`()` for all but the watertight test).
    type PerRay: Copy + Default;
    /// The per-(packet, triangle lanes) terms.
    type Shared<L: Lanes>: Copy;
    /// Per-ray terms of `ray`.
    fn prepare(ray: &BasicRay) -> Self::PerRay;
    /// Terms shared by all rays from `origin`.
    fn share<L: Lanes>(triangles: &impl TriangleLanes<L>, origin: Vec3) -> Self::Shared<L>;
    /// The lanes `ray` hits inside `(ray.t_min, t_max)`, or `None` when none is.
    fn test<L: Lanes>(
        triangles: &impl TriangleLanes<L>,
        shared: &Self::Shared<L>,
        ray: &BasicRay,
        per_ray: &Self::PerRay,
        t_max: f32,
    ) -> Option<LaneHits<L>>;
}

/// The last range test, on `t`.
#[inline(always)]
pub(super) fn accept_t<L: Lanes>(
    mask: L::Mask,
    t: L,
    u: L,
    v: L,
    ray: &BasicRay,
    t_max: f32,
) -> Option<LaneHits<L>> {
    let mask = mask & L::lt(L::splat(ray.t_min), t) & L::lt(t, L::splat(t_max));
    L::any(mask).then_some(LaneHits { mask, t, u, v })
}

/// The last range test for numerators scaled by `scale` = |denominator| (the division
/// is deferred until some lane has passed every other test): `t_min·scale < t`, then
/// `t`, `u`, `v` divided by `scale` and `t < t_max` on the quotient, so that whether a
/// lane beats the closest hit so far is decided on the same value whatever the lane
/// width (a scaled comparison against `t_max` would round differently per lane). A
/// zero or NaN scale fails, so degenerate triangles and NaN rays miss.
#[inline(always)]
pub(super) fn accept_scaled<L: Lanes>(
    mask: L::Mask,
    t: L,
    u: L,
    v: L,
    scale: L,
    ray: &BasicRay,
    t_max: f32,
) -> Option<LaneHits<L>> {
    let mask = mask & L::lt(L::splat(ray.t_min) * scale, t);
    if !L::any(mask) {
        return None;
    }
    let inverse = L::splat(1.0) / scale;
    accept_t(mask, t * inverse, u * inverse, v * inverse, ray, t_max)
}

/// The range tests of the deferred-division Möller forms: the `u` numerator, then the
/// `v` numerator (computed only when some lane passed), against |denominator| with
/// the denominator's sign folded in, then `t` by [`accept_scaled`].
#[inline(always)]
pub(super) fn scaled_test<L: Lanes>(
    denominator: L,
    u: L,
    v: impl FnOnce() -> L,
    t: impl FnOnce() -> L,
    ray: &BasicRay,
    t_max: f32,
) -> Option<LaneHits<L>> {
    let u = u.xor_sign(denominator);
    let scale = denominator.abs();
    let mask = L::le(L::splat(0.0), u) & L::le(u, scale);
    if !L::any(mask) {
        return None;
    }
    let v = v().xor_sign(denominator);
    let mask = mask & L::le(L::splat(0.0), v) & L::le(u + v, scale);
    if !L::any(mask) {
        return None;
    }
    accept_scaled(mask, t().xor_sign(denominator), u, v, scale, ray, t_max)
}

/// `0 ≤ x ≤ 1` per lane.
#[inline(always)]
pub(super) fn unit_range<L: Lanes>(x: L) -> L::Mask {
    L::le(L::splat(0.0), x) & L::le(x, L::splat(1.0))
}

/// One triangle as scalar lanes (corners as given, edges and normal derived once).
struct OneTriangle {
    corners: [Vec3; 3],
    e1: Vec3,
    e2: Vec3,
    normal: Vec3,
}

impl TriangleLanes<f32> for OneTriangle {
    #[inline(always)]
    fn v0(&self) -> V3<f32> {
        V3::splat(self.corners[0])
    }
    #[inline(always)]
    fn v1(&self) -> V3<f32> {
        V3::splat(self.corners[1])
    }
    #[inline(always)]
    fn v2(&self) -> V3<f32> {
        V3::splat(self.corners[2])
    }
    #[inline(always)]
    fn e1(&self) -> V3<f32> {
        V3::splat(self.e1)
    }
    #[inline(always)]
    fn e2(&self) -> V3<f32> {
        V3::splat(self.e2)
    }
    #[inline(always)]
    fn normal(&self) -> V3<f32> {
        V3::splat(self.normal)
    }
}

/// `(t, u, v)` where `ray` hits the triangle `corners` inside `(t_min, t_max)` by the
/// scalar form of `I`.
pub fn intersect_triangle<I: Intersector>(
    corners: [Vec3; 3],
    ray: &Ray,
) -> Option<(f32, f32, f32)> {
    let (e1, e2) = (corners[1] - corners[0], corners[2] - corners[0]);
    let triangle = OneTriangle {
        corners,
        e1,
        e2,
        normal: e1.cross(e2),
    };
    let shared = I::share::<f32>(&triangle, ray.origin);
    let basic = BasicRay::from(ray);
    let hit = I::test::<f32>(&triangle, &shared, &basic, &I::prepare(&basic), ray.t_max)?;
    hit.nearest().map(|(_, t, u, v)| (t, u, v))
}

/// [`intersect_triangle`] with the intersector named by `kind`.
pub fn intersect_triangle_by_kind(
    kind: IntersectorKind,
    corners: [Vec3; 3],
    ray: &Ray,
) -> Option<(f32, f32, f32)> {
    struct One<'a>([Vec3; 3], &'a Ray);
    impl WithIntersector for One<'_> {
        type Output = Option<(f32, f32, f32)>;
        fn run<I: Intersector>(self) -> Self::Output {
            intersect_triangle::<I>(self.0, self.1)
        }
    }
    kind.dispatch(One(corners, ray))
}

/// The reference the intersectors are tested against: Möller–Trumbore in double
/// precision with no range tests: `(t, u, v)` where the ray's line meets the
/// triangle's plane, or `None` for a degenerate triangle or a ray parallel to it.
pub fn reference_f64(ray: &Ray, corners: [Vec3; 3]) -> Option<(f64, f64, f64)> {
    let [a, b, c] = corners.map(|p| p.as_dvec3());
    let (o, d) = (ray.origin.as_dvec3(), ray.direction.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let determinant = e1.dot(p);
    if determinant == 0.0 || !determinant.is_finite() {
        return None;
    }
    let s = o - a;
    let q = s.cross(e1);
    Some((
        e2.dot(q) / determinant,
        s.dot(p) / determinant,
        d.dot(q) / determinant,
    ))
}

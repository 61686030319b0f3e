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
//! `Avx8` (module `lanes`) test 4 and 8 triangles at once (an early-out then needs every
//! lane to fail). No fused multiply-add is used, so all widths agree bit for bit.
//!
//! Conventions: `(u, v)` weight the second and third corner, a hit needs
//! `t_min < t < t_max`, and degenerate triangles, rays in a triangle's plane, zero and
//! NaN directions all miss (a zero or non-finite denominator fails every range test).

use super::Hit;
use crate::geom::Ray;
use crate::mesh::TriMesh;
use crate::simd::{dispatch, Isa, Kernel, Lanes, V3};
use glam::Vec3;
use std::fmt;
use std::ops::{Add, Sub};

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
fn accept_t<L: Lanes>(
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
fn accept_scaled<L: Lanes>(
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
fn scaled_test<L: Lanes>(
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
fn unit_range<L: Lanes>(x: L) -> L::Mask {
    L::le(L::splat(0.0), x) & L::le(x, L::splat(1.0))
}

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

/// Triangles stored structure-of-arrays with every quantity any intersector reads
/// (corners, edges, normal: 72 bytes per triangle), padded with degenerate triangles
/// (all corners at the origin: they never hit) to a multiple of 8 for the widest lanes.
/// This is the storage of the paper's experiment, which has no acceleration structure.
#[derive(Clone, Debug)]
pub struct TriangleSoa {
    v0: [Vec<f32>; 3],
    v1: [Vec<f32>; 3],
    v2: [Vec<f32>; 3],
    e1: [Vec<f32>; 3],
    e2: [Vec<f32>; 3],
    normal: [Vec<f32>; 3],
    /// Input triangle id per slot (`u32::MAX` in padding).
    pub ids: Vec<u32>,
}

/// The widest [`Lanes`] (padding unit of [`TriangleSoa`]).
pub const MAX_LANES: usize = 8;

impl TriangleSoa {
    /// The valid triangles of `mesh` (in-range indices, finite corners).
    pub fn from_mesh(mesh: &TriMesh) -> Self {
        let valid: Vec<u32> = (0..mesh.triangle_count())
            .filter(|&t| mesh.finite_corners(t).is_some())
            .map(|t| t as u32)
            .collect();
        let padded = valid.len().div_ceil(MAX_LANES) * MAX_LANES;
        let column = || [vec![0.0; padded], vec![0.0; padded], vec![0.0; padded]];
        let mut soa = Self {
            v0: column(),
            v1: column(),
            v2: column(),
            e1: column(),
            e2: column(),
            normal: column(),
            ids: vec![u32::MAX; padded],
        };
        for (slot, &t) in valid.iter().enumerate() {
            let [a, b, c] = mesh.corners(t as usize);
            let (e1, e2) = (b - a, c - a);
            let n = e1.cross(e2);
            for axis in 0..3 {
                soa.v0[axis][slot] = a[axis];
                soa.v1[axis][slot] = b[axis];
                soa.v2[axis][slot] = c[axis];
                soa.e1[axis][slot] = e1[axis];
                soa.e2[axis][slot] = e2[axis];
                soa.normal[axis][slot] = n[axis];
            }
            soa.ids[slot] = t;
        }
        soa
    }

    /// Slots (valid triangles plus padding).
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// True when no triangle is stored.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Slots `index .. index + L::WIDTH` as lanes.
    #[inline(always)]
    fn lanes(&self, index: usize) -> SoaLanes<'_> {
        SoaLanes { soa: self, index }
    }
}

/// A [`TriangleSoa`] window of lanes.
struct SoaLanes<'a> {
    soa: &'a TriangleSoa,
    index: usize,
}

impl<L: Lanes> TriangleLanes<L> for SoaLanes<'_> {
    #[inline(always)]
    fn v0(&self) -> V3<L> {
        V3::load(&self.soa.v0, self.index)
    }
    #[inline(always)]
    fn v1(&self) -> V3<L> {
        V3::load(&self.soa.v1, self.index)
    }
    #[inline(always)]
    fn v2(&self) -> V3<L> {
        V3::load(&self.soa.v2, self.index)
    }
    #[inline(always)]
    fn e1(&self) -> V3<L> {
        V3::load(&self.soa.e1, self.index)
    }
    #[inline(always)]
    fn e2(&self) -> V3<L> {
        V3::load(&self.soa.e2, self.index)
    }
    #[inline(always)]
    fn normal(&self) -> V3<L> {
        V3::load(&self.soa.normal, self.index)
    }
}

/// The most rays in one packet.
pub const MAX_PACKET_RAYS: usize = 64;

/// Closest hits of `rays` (all from one origin, at most [`MAX_PACKET_RAYS`]) against
/// every triangle of `soa`, with intersector `I` over lanes `L`: per `L::WIDTH`
/// triangles, `I::share` once, then `I::test` per ray. `hits[i].t` starts as the
/// bound for ray `i` (set it to the ray's `t_max`).
#[inline(always)]
pub fn packet_closest_without_bvh<I: Intersector, L: Lanes>(
    soa: &TriangleSoa,
    rays: &[Ray],
    hits: &mut [Hit],
) {
    let Some(first) = rays.first() else {
        return;
    };
    let mut prepared = [(BasicRay::from(first), I::PerRay::default()); MAX_PACKET_RAYS];
    for (p, ray) in prepared.iter_mut().zip(rays) {
        let basic = BasicRay::from(ray);
        *p = (basic, I::prepare(&basic));
    }
    let prepared = &prepared[..rays.len()];
    for index in (0..soa.len()).step_by(L::WIDTH) {
        let lanes = soa.lanes(index);
        let shared = I::share::<L>(&lanes, first.origin);
        for ((ray, per_ray), hit) in prepared.iter().zip(hits.iter_mut()) {
            if let Some(found) = I::test::<L>(&lanes, &shared, ray, per_ray, hit.t) {
                if let Some((lane, t, u, v)) = found.nearest() {
                    *hit = Hit {
                        t,
                        u,
                        v,
                        triangle: soa.ids[index + lane],
                        instance: 0,
                        geometry: 0,
                    };
                }
            }
        }
    }
}

/// How many triangles one intersector test covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Simd {
    /// One (`f32`): the reference.
    Scalar,
    /// Four (`wide::f32x4`: SSE, NEON, or emulated).
    X4,
    /// Eight (AVX, detected at run time).
    X8,
}

impl Simd {
    /// The widths this CPU runs.
    pub fn available() -> Vec<Simd> {
        let mut widths = vec![Simd::Scalar, Simd::X4];
        if crate::simd::has_avx() {
            widths.push(Simd::X8);
        }
        widths
    }

    /// A short name: `scalar`, `x4`, `x8`.
    pub fn name(self) -> &'static str {
        match self {
            Simd::Scalar => "scalar",
            Simd::X4 => "x4",
            Simd::X8 => "x8",
        }
    }
}

/// [`packet_closest_without_bvh`] over a whole list of packets (`packets` = consecutive
/// runs of `rays` of the given lengths) with `I` and `simd` (X8 runs `wide`'s 8 lanes on
/// CPUs without AVX).
pub fn closest_without_bvh<I: Intersector>(
    simd: Simd,
    soa: &TriangleSoa,
    rays: &[Ray],
    hits: &mut [Hit],
    packet: usize,
) {
    assert_eq!(rays.len(), hits.len());
    assert!((1..=MAX_PACKET_RAYS).contains(&packet));
    for (hit, ray) in hits.iter_mut().zip(rays) {
        *hit = Hit::MISS;
        hit.t = ray.t_max;
    }
    for (rays, hits) in rays.chunks(packet).zip(hits.chunks_mut(packet)) {
        match simd {
            Simd::Scalar => packet_closest_without_bvh::<I, f32>(soa, rays, hits),
            Simd::X4 => packet_closest_without_bvh::<I, wide::f32x4>(soa, rays, hits),
            Simd::X8 => dispatch(EightWide::<I> {
                soa,
                rays,
                hits,
                intersector: std::marker::PhantomData,
            }),
        }
    }
    for hit in hits.iter_mut() {
        if !hit.is_hit() {
            hit.t = f32::INFINITY;
        }
    }
}

/// [`packet_closest_without_bvh`] on the CPU's 8 lanes, as a [`Kernel`].
struct EightWide<'a, I> {
    soa: &'a TriangleSoa,
    rays: &'a [Ray],
    hits: &'a mut [Hit],
    intersector: std::marker::PhantomData<I>,
}

impl<I: Intersector> Kernel for EightWide<'_, I> {
    type Output = ();
    #[inline(always)]
    fn run<S: Isa>(self) {
        packet_closest_without_bvh::<I, S::Lanes8>(self.soa, self.rays, self.hits)
    }
}

/// [`closest_without_bvh`] with the intersector named by `kind`.
pub fn closest_without_bvh_by_kind(
    kind: IntersectorKind,
    simd: Simd,
    soa: &TriangleSoa,
    rays: &[Ray],
    hits: &mut [Hit],
    packet: usize,
) {
    struct All<'a>(Simd, &'a TriangleSoa, &'a [Ray], &'a mut [Hit], usize);
    impl WithIntersector for All<'_> {
        type Output = ();
        fn run<I: Intersector>(self) {
            closest_without_bvh::<I>(self.0, self.1, self.2, self.3, self.4)
        }
    }
    kind.dispatch(All(simd, soa, rays, hits, packet))
}

//! Triangles as a structure of arrays, tested without a BVH: the packet paper's
//! experiment, every ray of a packet against every triangle, `L::WIDTH` triangles per
//! test. Cost: rays × triangles.

use super::{BasicRay, Intersector, IntersectorKind, TriangleLanes, WithIntersector};
use crate::geom::Ray;
use crate::mesh::TriMesh;
use crate::simd::{dispatch, Isa, Kernel, Lanes, V3};
use crate::trace::Hit;

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

//! The measuring ray tracer: hits, counters, prepared rays, the triangle leaves, ordered
//! 8-wide BVH traversal, one- and two-level scenes, deterministic workloads, runners
//! and measurement.
//!
//! Counters are a type parameter ([`Counters`]): with [`NoCounters`] every count is an
//! empty inline function and the compiler removes it, so timed runs pay nothing; with
//! [`RayCounters`] the same code counts box tests, primitive tests and nodes.

pub mod accel;
pub mod intersect;
pub mod measure;
pub mod packet;
pub mod pair;
pub mod run;
pub mod strip;
pub(crate) mod traverse;
pub mod triangle;
pub mod workload;

pub(crate) use accel::transform_query;
pub use accel::SceneAccel;
pub use measure::TraceRun;
pub use pair::{Pair4, TrianglePair};
pub use triangle::Triangle;
pub use workload::{Camera, RayKind, View, Workload};

use crate::bvh::Primitive;
use crate::geom::Ray;
use glam::Vec3;
use serde::Serialize;

/// Side of the square pixel tiles rays are generated and traced in.
pub const TILE: usize = 8;

/// The closest (or any) hit of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray (in units of the direction's length).
    pub t: f32,
    /// Barycentric coordinate of the second corner.
    pub u: f32,
    /// Barycentric coordinate of the third corner.
    pub v: f32,
    /// Input triangle id within its mesh (`u32::MAX` for a miss).
    pub triangle: u32,
    /// Instance (placement) id in the scene.
    pub instance: u32,
    /// Mesh (geometry) id in the scene.
    pub geometry: u32,
}

impl Hit {
    /// No hit.
    pub const MISS: Hit = Hit {
        t: f32::INFINITY,
        u: 0.0,
        v: 0.0,
        triangle: u32::MAX,
        instance: u32::MAX,
        geometry: u32::MAX,
    };

    /// True when something was hit.
    #[inline]
    pub fn is_hit(&self) -> bool {
        self.triangle != u32::MAX
    }
}

/// Per-ray work counters, compiled away when not wanted.
pub trait Counters: Default + Send {
    /// Whether this type counts anything (lets callers skip work done only to count).
    const ENABLED: bool;
    /// `n` ray–box tests.
    fn box_tests(&mut self, n: u32);
    /// `n` ray–triangle tests.
    fn triangle_tests(&mut self, n: u32);
    /// `n` ray–pair tests (one test of a triangle pair's two triangles).
    fn pair_tests(&mut self, n: u32);
    /// One node visited.
    fn node_visited(&mut self);
    /// Add another set of counts.
    fn merge(&mut self, other: &Self);
}

/// Counts nothing, costs nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoCounters;

impl Counters for NoCounters {
    const ENABLED: bool = false;
    #[inline(always)]
    fn box_tests(&mut self, _: u32) {}
    #[inline(always)]
    fn triangle_tests(&mut self, _: u32) {}
    #[inline(always)]
    fn pair_tests(&mut self, _: u32) {}
    #[inline(always)]
    fn node_visited(&mut self) {}
    #[inline(always)]
    fn merge(&mut self, _: &Self) {}
}

/// Totals of box tests, triangle tests and visited nodes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RayCounters {
    /// Ray–box tests (each non-empty child box of a visited node is one).
    pub box_tests: u64,
    /// Ray–triangle tests.
    pub triangle_tests: u64,
    /// Ray–pair tests (each tests two triangles sharing an edge).
    pub pair_tests: u64,
    /// Inner nodes visited.
    pub nodes_visited: u64,
}

impl Counters for RayCounters {
    const ENABLED: bool = true;
    #[inline(always)]
    fn box_tests(&mut self, n: u32) {
        self.box_tests += n as u64;
    }
    #[inline(always)]
    fn triangle_tests(&mut self, n: u32) {
        self.triangle_tests += n as u64;
    }
    #[inline(always)]
    fn pair_tests(&mut self, n: u32) {
        self.pair_tests += n as u64;
    }
    #[inline(always)]
    fn node_visited(&mut self) {
        self.nodes_visited += 1;
    }
    fn merge(&mut self, other: &Self) {
        self.box_tests += other.box_tests;
        self.triangle_tests += other.triangle_tests;
        self.pair_tests += other.pair_tests;
        self.nodes_visited += other.nodes_visited;
    }
}

/// A packed BVH leaf block the tracer tests a ray against: [`triangle::Triangle4`] or
/// [`pair::Pair4`].
pub trait LeafBlock: Primitive + Clone + Send + Sync {
    /// The closest primitive hit before `hit.t`, recorded into `hit`.
    fn intersect_into(&self, ray: &RayQuery, hit: &mut Hit) -> bool;
    /// Whether anything in the block is hit inside `(t_min, t_max)`.
    fn occludes(&self, ray: &RayQuery, t_max: f32) -> bool;
    /// [`Self::intersect_into`] for callers compiled with AVX: a block whose test is
    /// wider than 4 lanes runs it in 256-bit registers here (the same operations, so
    /// the same hits). Off x86-64, and by default, the same as `intersect_into`.
    ///
    /// # Safety
    /// On x86-64, only call it from code compiled with AVX, on a CPU that has it.
    #[inline(always)]
    unsafe fn intersect_into_avx(&self, ray: &RayQuery, hit: &mut Hit) -> bool {
        self.intersect_into(ray, hit)
    }
    /// [`Self::occludes`] for callers compiled with AVX, as [`Self::intersect_into_avx`].
    ///
    /// # Safety
    /// As for [`Self::intersect_into_avx`].
    #[inline(always)]
    unsafe fn occludes_avx(&self, ray: &RayQuery, t_max: f32) -> bool {
        self.occludes(ray, t_max)
    }
    /// Count one test of this block.
    fn count_tests<C: Counters>(&self, counters: &mut C);
}

/// Anything that traces single rays: rtmesh's [`SceneAccel`], and Embree or other
/// BVH libraries in comparisons, so that all run through the same parallel loop.
pub trait Tracer: Sync {
    /// Closest hit.
    fn intersect<C: Counters>(&self, ray: &Ray, counters: &mut C) -> Hit;
    /// Whether anything blocks the ray.
    fn occluded<C: Counters>(&self, ray: &Ray, counters: &mut C) -> bool;
}

/// A ray prepared for box tests: safe reciprocal direction and, per axis, which box
/// plane is entered first.
#[derive(Clone, Copy, Debug)]
pub struct RayQuery {
    /// Origin.
    pub origin: Vec3,
    /// Direction.
    pub direction: Vec3,
    /// Smallest accepted distance.
    pub t_min: f32,
    /// `1 / direction`, with components of magnitude below 1e-18 replaced by ±1e-18 so
    /// that no box test ever computes `0 · ∞` (Embree's `rcp_safe`).
    pub inverse_direction: Vec3,
    /// `inverse_direction` scaled by 1 + 2γ₃ (γ₃ = 3ε / (1 − 3ε), ε = 2⁻²⁴) for far
    /// planes, so rounding never culls a box the ray touches (Ize, JCGT 2013).
    pub inverse_direction_far: Vec3,
    /// Per axis, the plane index (0..6 into [`crate::bvh::BvhNode::planes`]) entered first.
    pub near_plane: [usize; 3],
    /// Per axis, the plane index left last (the opposite of `near_plane`).
    pub far_plane: [usize; 3],
}

/// 1 + 2γ₃ with γ₃ = 3ε / (1 − 3ε), ε = 2⁻²⁴.
pub(crate) const ROBUST_FAR_SCALE: f32 =
    1.0 + 2.0 * (1.5 * f32::EPSILON) / (1.0 - 1.5 * f32::EPSILON);

/// `1 / d`, with `|d|` below 1e-18 replaced by ±1e-18 (the sign of `d` kept).
#[inline(always)]
pub(crate) fn safe_reciprocal(d: f32) -> f32 {
    1.0 / if d.abs() < 1e-18 {
        1e-18f32.copysign(d)
    } else {
        d
    }
}

impl RayQuery {
    /// Prepare `ray`.
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        let inverse_direction = Vec3::new(
            safe_reciprocal(ray.direction.x),
            safe_reciprocal(ray.direction.y),
            safe_reciprocal(ray.direction.z),
        );
        let near = |axis: usize| {
            if inverse_direction[axis] >= 0.0 {
                axis
            } else {
                axis + 3
            }
        };
        Self {
            origin: ray.origin,
            direction: ray.direction,
            t_min: ray.t_min,
            inverse_direction,
            inverse_direction_far: inverse_direction * ROBUST_FAR_SCALE,
            near_plane: [near(0), near(1), near(2)],
            far_plane: [(near(0) + 3) % 6, (near(1) + 3) % 6, (near(2) + 3) % 6],
        }
    }
}

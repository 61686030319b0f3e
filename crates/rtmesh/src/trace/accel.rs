//! A scene ready to trace: one BVH per mesh (BLAS) and, when the scene has more than
//! one placement or a transformed one, a top-level BVH over the instances (TLAS), as
//! DXR and Vulkan trace them. A TLAS leaf moves the ray into the instance's object
//! space (the direction is not renormalised, so `t` means the same in both spaces) and
//! traverses that mesh's BVH. A scene of one untransformed mesh skips the TLAS.

use super::intersect::Intersector;
use super::packet::{self, PacketBuffer};
use super::pair::{mesh_pairs, Pair4, PAIR4_LANES};
use super::traverse::{any_hit, closest_hit};
use super::triangle::{Triangle4, TRIANGLE4_LANES};
use super::{Counters, Hit, LeafBlock, RayQuery, Tracer, Triangle};
use crate::bvh::{BuildSettings, Bvh, BvhStats, Primitive};
use crate::geom::{Aabb, Ray};
use crate::mesh::{Scene, TriMesh};
use crate::pair::Pairing;
use crate::simd::{dispatch, Isa, Kernel};
use glam::Affine3A;
use rayon::prelude::*;
use serde::Serialize;

/// The SAH charges `ceil(n / 4)` tests for a leaf of `n` triangles, what a 4-wide leaf
/// test really costs and what Embree's BVH8 builder charges (`sahBlockSize` 4): a set
/// of at most four triangles always becomes one full block. It beat charging
/// `ceil(n / 2)` on nodes, box tests, bytes and Mrays/s (figures in
/// `docs/measurements/tracer.md`).
const TRIANGLE_LEAF_BLOCK: usize = 4;

/// A TLAS leaf: one placement of a mesh.
#[derive(Clone, Debug)]
pub struct InstanceLeaf {
    /// World-space box of the placed mesh.
    pub bounds: Aabb,
    /// World-to-object transform.
    pub world_to_object: Affine3A,
    /// Instance id.
    pub instance: u32,
    /// Mesh id (index of its BLAS).
    pub mesh: u32,
}

impl InstanceLeaf {
    /// The leaf for instance `index`, placing a mesh whose BVH has box `mesh_bounds`.
    fn new(index: usize, instance: &crate::mesh::Instance, mesh_bounds: Aabb) -> Self {
        Self {
            bounds: mesh_bounds.transformed(&instance.transform),
            world_to_object: instance.transform.inverse(),
            instance: index as u32,
            mesh: instance.mesh as u32,
        }
    }
}

impl Primitive for InstanceLeaf {
    fn bounds(&self) -> Aabb {
        self.bounds
    }
}

/// Figures of a built scene: summed over BLASes, plus the TLAS.
#[derive(Clone, Debug, Default, Serialize)]
pub struct AccelStats {
    /// 8-wide nodes, all levels.
    pub nodes: usize,
    /// Leaves, all levels.
    pub leaves: usize,
    /// SAH cost of the BLAS of a single-mesh scene, or of the TLAS otherwise.
    pub sah_cost: f32,
    /// Seconds to build all levels (wall clock).
    pub build_seconds: f64,
    /// Bytes of nodes and leaf primitives, all levels.
    pub bytes: usize,
    /// `bytes` divided by the instanced triangle count.
    pub bytes_per_triangle: f64,
    /// Deepest leaf over all levels.
    pub depth: usize,
}

/// The traceable form of a [`Scene`], with leaf blocks `L`: [`Triangle4`] (the
/// default) or [`Pair4`] (triangle pairs).
#[derive(Clone, Debug)]
pub struct SceneAccel<L = Triangle4> {
    /// One BVH per mesh, over its valid triangles, leaves packed in 4-wide blocks.
    pub blas: Vec<Bvh<L>>,
    /// BVH over instances, absent for a scene of one untransformed mesh.
    pub tlas: Option<Bvh<InstanceLeaf>>,
    /// Seconds the whole build took.
    pub build_seconds: f64,
    triangle_count: usize,
}

/// The tracer's triangles of `mesh` (NaN, infinite and out-of-range triangles are left
/// out by the builder, which skips empty or non-finite boxes).
pub fn mesh_triangles(mesh: &TriMesh) -> Vec<Triangle> {
    let n = mesh.positions.len();
    (0..mesh.triangle_count())
        .filter(|&t| mesh.triangles[t].iter().all(|&v| (v as usize) < n))
        .map(|t| Triangle::new(mesh.corners(t), t as u32))
        .collect()
}

impl SceneAccel<Triangle4> {
    /// Build every level with `settings`.
    pub fn build(scene: &Scene, settings: &BuildSettings) -> Self {
        let start = std::time::Instant::now();
        let triangle_settings = BuildSettings {
            leaf_block: TRIANGLE_LEAF_BLOCK,
            max_leaf_size: TRIANGLE4_LANES,
            ..settings.clone()
        };
        let blas: Vec<Bvh<Triangle4>> = scene
            .meshes
            .par_iter()
            .map(|mesh| {
                Bvh::build(mesh_triangles(mesh), &triangle_settings).map_leaves(Triangle4::new)
            })
            .collect();
        Self::assemble(scene, settings, blas, start)
    }

    /// Follow moved vertices without rebuilding: `scene` must have the topology this
    /// was built from (same meshes, triangles and instances; positions and transforms
    /// may change). Each leaf re-reads its triangles' corners, then every box is
    /// recomputed bottom-up. O(triangles + nodes); the tree's quality may degrade as
    /// the mesh deforms (lint's rebuild-vs-refit advice measures by how much).
    pub fn refit(&mut self, scene: &Scene) {
        self.blas
            .par_iter_mut()
            .zip(&scene.meshes)
            .for_each(|(bvh, mesh)| {
                for block in &mut bvh.primitives {
                    let count = block.count() as usize;
                    let mut triangles = [block.triangle(0); TRIANGLE4_LANES];
                    for (lane, triangle) in triangles[..count].iter_mut().enumerate() {
                        let id = block.ids[lane];
                        *triangle = Triangle::new(mesh.corners(id as usize), id);
                    }
                    *block = Triangle4::new(&triangles[..count]);
                }
                bvh.refit();
            });
        if let Some(tlas) = &mut self.tlas {
            for leaf in &mut tlas.primitives {
                let index = leaf.instance as usize;
                let instance = &scene.instances[index];
                *leaf = InstanceLeaf::new(index, instance, self.blas[instance.mesh].bounds());
            }
            tlas.refit();
        }
    }
}

impl SceneAccel<Pair4> {
    /// Build with triangle-pair leaves: `pairings[m]` pairs mesh `m` of `scene` (found
    /// on these very meshes, so paired triangles share vertex indices).
    pub fn build_paired(scene: &Scene, pairings: &[Pairing], settings: &BuildSettings) -> Self {
        assert_eq!(pairings.len(), scene.meshes.len(), "one pairing per mesh");
        let start = std::time::Instant::now();
        let pair_settings = BuildSettings {
            leaf_block: TRIANGLE_LEAF_BLOCK,
            max_leaf_size: PAIR4_LANES,
            ..settings.clone()
        };
        let blas: Vec<Bvh<Pair4>> = scene
            .meshes
            .par_iter()
            .zip(pairings)
            .map(|(mesh, pairing)| {
                Bvh::build(mesh_pairs(mesh, pairing), &pair_settings).map_leaves(Pair4::new)
            })
            .collect();
        Self::assemble(scene, settings, blas, start)
    }
}

impl<L: LeafBlock> SceneAccel<L> {
    /// The scene of one untransformed mesh of `triangle_count` triangles, from its BVH
    /// (built by another builder, such as the per-frame one over clusters), timed from
    /// `start`.
    pub(crate) fn from_single_blas(
        blas: Bvh<L>,
        triangle_count: usize,
        start: std::time::Instant,
    ) -> Self {
        Self {
            blas: vec![blas],
            tlas: None,
            build_seconds: start.elapsed().as_secs_f64(),
            triangle_count,
        }
    }

    /// The one BLAS of a scene built by [`Self::from_single_blas`], given back.
    pub(crate) fn into_single_blas(mut self) -> Option<Bvh<L>> {
        (self.blas.len() == 1 && self.tlas.is_none())
            .then(|| self.blas.pop())
            .flatten()
    }

    /// Add the TLAS (when the scene needs one) over built BLASes.
    fn assemble(
        scene: &Scene,
        settings: &BuildSettings,
        blas: Vec<Bvh<L>>,
        start: std::time::Instant,
    ) -> Self {
        let single =
            scene.instances.len() == 1 && scene.instances[0].transform == Affine3A::IDENTITY;
        let tlas = (!single).then(|| {
            let leaves = scene
                .instances
                .iter()
                .enumerate()
                .map(|(i, inst)| InstanceLeaf::new(i, inst, blas[inst.mesh].bounds()))
                .collect();
            Bvh::build(leaves, settings)
        });
        Self {
            blas,
            tlas,
            build_seconds: start.elapsed().as_secs_f64(),
            triangle_count: scene.instanced_triangle_count(),
        }
    }

    /// The SAH cost of tracing the scene through both levels: the TLAS's cost with
    /// each instance leaf charged its BLAS's own SAH cost (relative to the BLAS's
    /// root, so a transform is taken to scale areas evenly), or the BLAS's cost for a
    /// scene of one untransformed mesh. Lower is faster; it compares groupings of the
    /// same triangles into geometries (lint's estimate for merging and splitting).
    pub fn two_level_sah_cost(&self) -> f64 {
        let blas_cost: Vec<f64> = self
            .blas
            .iter()
            .map(|b| b.sah_cost_by(|leaf| leaf.len() as f64))
            .collect();
        match &self.tlas {
            Some(tlas) => tlas.sah_cost_by(|instances| {
                instances.iter().map(|i| blas_cost[i.mesh as usize]).sum()
            }),
            None => blas_cost.first().copied().unwrap_or(0.0),
        }
    }

    /// Nodes, leaves, SAH cost, bytes, build time.
    pub fn stats(&self) -> AccelStats {
        let blas_stats: Vec<BvhStats> = self.blas.iter().map(Bvh::stats).collect();
        let tlas_stats = self.tlas.as_ref().map(Bvh::stats);
        let primitive_bytes: usize = self
            .blas
            .iter()
            .map(|b| b.primitives.len() * std::mem::size_of::<L>())
            .sum::<usize>()
            + self.tlas.as_ref().map_or(0, |t| {
                t.primitives.len() * std::mem::size_of::<InstanceLeaf>()
            });
        let all = blas_stats.iter().chain(tlas_stats.iter());
        let bytes = all.clone().map(|s| s.node_bytes).sum::<usize>() + primitive_bytes;
        AccelStats {
            nodes: all.clone().map(|s| s.nodes).sum(),
            leaves: all.clone().map(|s| s.leaves).sum(),
            sah_cost: tlas_stats
                .as_ref()
                .or(blas_stats.first())
                .map_or(0.0, |s| s.sah_cost),
            build_seconds: self.build_seconds,
            bytes,
            bytes_per_triangle: bytes as f64 / self.triangle_count.max(1) as f64,
            depth: all.map(|s| s.depth).max().unwrap_or(0),
        }
    }
}

impl<L: LeafBlock> SceneAccel<L> {
    /// Closest hit of `ray` with the node test of `S` and leaf test `leaf` (which records a
    /// closer hit into its `Hit` and says whether it did).
    #[inline(always)]
    pub(crate) fn intersect_with<S: Isa, C: Counters>(
        &self,
        ray: &Ray,
        counters: &mut C,
        leaf: impl Fn(&L, &RayQuery, &mut Hit) -> bool + Copy,
    ) -> Hit {
        let query = RayQuery::new(ray);
        let mut hit = Hit::MISS;
        hit.t = ray.t_max;
        match &self.tlas {
            None => {
                if let Some(bvh) = self.blas.first() {
                    if intersect_blas::<S, _, _>(bvh, &query, &mut hit, counters, leaf) {
                        hit.instance = 0;
                        hit.geometry = 0;
                    }
                }
            }
            Some(tlas) => {
                closest_hit::<S, _, _, _>(
                    tlas,
                    &query,
                    &mut hit.t.clone(),
                    counters,
                    |instances, t_max, counters| {
                        let mut found = false;
                        for instance in instances {
                            let local = transform_query(&query, &instance.world_to_object);
                            if intersect_blas::<S, _, _>(
                                &self.blas[instance.mesh as usize],
                                &local,
                                &mut hit,
                                counters,
                                leaf,
                            ) {
                                hit.instance = instance.instance;
                                hit.geometry = instance.mesh;
                                *t_max = hit.t;
                                found = true;
                            }
                        }
                        found
                    },
                );
            }
        }
        if !hit.is_hit() {
            hit.t = f32::INFINITY;
        }
        hit
    }

    /// Whether anything blocks `ray` within `(t_min, t_max)`, with the node test of `S` and
    /// leaf test `leaf` (whether the block is hit before the given distance).
    #[inline(always)]
    pub(crate) fn occluded_with<S: Isa, C: Counters>(
        &self,
        ray: &Ray,
        counters: &mut C,
        leaf: impl Fn(&L, &RayQuery, f32) -> bool + Copy,
    ) -> bool {
        let query = RayQuery::new(ray);
        match &self.tlas {
            None => self.blas.first().is_some_and(|bvh| {
                occluded_blas::<S, _, _>(bvh, &query, ray.t_max, counters, leaf)
            }),
            Some(tlas) => any_hit::<S, _, _, _>(
                tlas,
                &query,
                ray.t_max,
                counters,
                |instances, t_max, counters| {
                    instances.iter().any(|instance| {
                        let local = transform_query(&query, &instance.world_to_object);
                        occluded_blas::<S, _, _>(
                            &self.blas[instance.mesh as usize],
                            &local,
                            t_max,
                            counters,
                            leaf,
                        )
                    })
                },
            ),
        }
    }
}

/// The test of a leaf block that [`Closest`] and [`Occluded`] run: the blocks' own
/// ([`OwnTest`]) or an intersector's ([`IntersectorTest`]), for instruction set `S`.
trait LeafTest<L>: Copy {
    /// Record a closer hit into `hit`; whether there was one.
    fn closest<S: Isa>(self, block: &L, query: &RayQuery, hit: &mut Hit) -> bool;
    /// Whether the block is hit before `t_max`.
    fn occludes<S: Isa>(self, block: &L, query: &RayQuery, t_max: f32) -> bool;
}

/// A leaf block's own test, in AVX registers when `S` has AVX.
#[derive(Clone, Copy)]
struct OwnTest;

impl<L: LeafBlock> LeafTest<L> for OwnTest {
    #[inline(always)]
    fn closest<S: Isa>(self, block: &L, query: &RayQuery, hit: &mut Hit) -> bool {
        if S::AVX {
            // SAFETY: code with an AVX `Isa` runs only on CPUs with AVX, compiled with it.
            unsafe { block.intersect_into_avx(query, hit) }
        } else {
            block.intersect_into(query, hit)
        }
    }
    #[inline(always)]
    fn occludes<S: Isa>(self, block: &L, query: &RayQuery, t_max: f32) -> bool {
        if S::AVX {
            // SAFETY: as in `closest`.
            unsafe { block.occludes_avx(query, t_max) }
        } else {
            block.occludes(query, t_max)
        }
    }
}

/// Intersector `I`'s test of a triangle block.
#[derive(Clone, Copy)]
struct IntersectorTest<I>(std::marker::PhantomData<I>);

impl<I: Intersector> LeafTest<Triangle4> for IntersectorTest<I> {
    #[inline(always)]
    fn closest<S: Isa>(self, block: &Triangle4, query: &RayQuery, hit: &mut Hit) -> bool {
        packet::block_closest::<I>(block, query, hit)
    }
    #[inline(always)]
    fn occludes<S: Isa>(self, block: &Triangle4, query: &RayQuery, t_max: f32) -> bool {
        packet::block_occludes::<I>(block, query, t_max)
    }
}

/// Closest hit of one ray through a scene with leaf test `T`, as a [`Kernel`].
struct Closest<'a, L, C, T> {
    accel: &'a SceneAccel<L>,
    ray: &'a Ray,
    counters: &'a mut C,
    leaf: T,
}

impl<L: LeafBlock, C: Counters, T: LeafTest<L>> Kernel for Closest<'_, L, C, T> {
    type Output = Hit;
    #[inline(always)]
    fn run<S: Isa>(self) -> Hit {
        let leaf = self.leaf;
        self.accel.intersect_with::<S, C>(
            self.ray,
            self.counters,
            #[inline(always)]
            move |block: &L, query: &RayQuery, hit: &mut Hit| leaf.closest::<S>(block, query, hit),
        )
    }
}

/// Occlusion of one ray through a scene with leaf test `T`, as a [`Kernel`].
struct Occluded<'a, L, C, T> {
    accel: &'a SceneAccel<L>,
    ray: &'a Ray,
    counters: &'a mut C,
    leaf: T,
}

impl<L: LeafBlock, C: Counters, T: LeafTest<L>> Kernel for Occluded<'_, L, C, T> {
    type Output = bool;
    #[inline(always)]
    fn run<S: Isa>(self) -> bool {
        let leaf = self.leaf;
        self.accel.occluded_with::<S, C>(
            self.ray,
            self.counters,
            #[inline(always)]
            move |block: &L, query: &RayQuery, t_max: f32| leaf.occludes::<S>(block, query, t_max),
        )
    }
}

impl<L: LeafBlock> Tracer for SceneAccel<L> {
    /// Closest hit of `ray`, counting work into `counters`; AVX where the CPU has it,
    /// the portable code elsewhere (bit-identical results).
    #[inline]
    fn intersect<C: Counters>(&self, ray: &Ray, counters: &mut C) -> Hit {
        dispatch(Closest {
            accel: self,
            ray,
            counters,
            leaf: OwnTest,
        })
    }

    /// Whether anything blocks `ray` within `(t_min, t_max)`.
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, counters: &mut C) -> bool {
        dispatch(Occluded {
            accel: self,
            ray,
            counters,
            leaf: OwnTest,
        })
    }
}

impl SceneAccel<Triangle4> {
    /// Closest hit of one ray with intersector `I` in the leaves (single-ray
    /// traversal: the reference for [`Self::intersect_packet`]).
    pub fn intersect_by<I: Intersector, C: Counters>(&self, ray: &Ray, counters: &mut C) -> Hit {
        dispatch(Closest {
            accel: self,
            ray,
            counters,
            leaf: IntersectorTest::<I>(std::marker::PhantomData),
        })
    }

    /// Whether anything blocks one ray, with intersector `I` in the leaves.
    pub fn occluded_by<I: Intersector, C: Counters>(&self, ray: &Ray, counters: &mut C) -> bool {
        dispatch(Occluded {
            accel: self,
            ray,
            counters,
            leaf: IntersectorTest::<I>(std::marker::PhantomData),
        })
    }

    /// Closest hits of up to 64 rays, traced as a packet with intersector `I` (ray by
    /// ray in scenes with a top level). `hits` and `counters` have one entry per ray.
    pub fn intersect_packet<I: Intersector, C: Counters>(
        &self,
        buffer: &mut PacketBuffer,
        rays: &[Ray],
        hits: &mut [Hit],
        counters: &mut [C],
    ) {
        assert!(hits.len() == rays.len() && counters.len() == rays.len());
        let (None, Some(bvh), false) = (&self.tlas, self.blas.first(), rays.is_empty()) else {
            for ((ray, hit), counter) in rays.iter().zip(hits.iter_mut()).zip(counters) {
                *hit = self.intersect_by::<I, C>(ray, counter);
            }
            return;
        };
        packet::closest::<I, C>(bvh, buffer, rays, hits, counters);
    }

    /// Occlusion of up to 64 rays (shadow rays from one hit point, say), traced as a
    /// packet with intersector `I`.
    pub fn occluded_packet<I: Intersector, C: Counters>(
        &self,
        buffer: &mut PacketBuffer,
        rays: &[Ray],
        occluded: &mut [bool],
        counters: &mut [C],
    ) {
        assert!(occluded.len() == rays.len() && counters.len() == rays.len());
        let (None, Some(bvh), false) = (&self.tlas, self.blas.first(), rays.is_empty()) else {
            for ((ray, blocked), counter) in rays.iter().zip(occluded.iter_mut()).zip(counters) {
                *blocked = self.occluded_by::<I, C>(ray, counter);
            }
            return;
        };
        packet::occluded::<I, C>(bvh, buffer, rays, occluded, counters);
    }
}

/// `query` in the object space of a placement whose inverse is `world_to_object` (the
/// direction is not renormalised, so `t` means the same in both spaces).
#[inline(always)]
pub(crate) fn transform_query(query: &RayQuery, world_to_object: &Affine3A) -> RayQuery {
    RayQuery::new(&Ray {
        origin: world_to_object.transform_point3(query.origin),
        direction: world_to_object.transform_vector3(query.direction),
        t_min: query.t_min,
        t_max: f32::INFINITY,
    })
}

#[inline(always)]
fn intersect_blas<S: Isa, L: LeafBlock, C: Counters>(
    bvh: &Bvh<L>,
    query: &RayQuery,
    hit: &mut Hit,
    counters: &mut C,
    leaf: impl Fn(&L, &RayQuery, &mut Hit) -> bool,
) -> bool {
    let mut t_max = hit.t;
    closest_hit::<S, _, _, _>(
        bvh,
        query,
        &mut t_max,
        counters,
        #[inline(always)]
        |blocks, t_max, counters| {
            let mut found = false;
            for block in blocks {
                block.count_tests(counters);
                if leaf(block, query, hit) {
                    *t_max = hit.t;
                    found = true;
                }
            }
            found
        },
    )
}

#[inline(always)]
fn occluded_blas<S: Isa, L: LeafBlock, C: Counters>(
    bvh: &Bvh<L>,
    query: &RayQuery,
    t_max: f32,
    counters: &mut C,
    leaf: impl Fn(&L, &RayQuery, f32) -> bool,
) -> bool {
    any_hit::<S, _, _, _>(
        bvh,
        query,
        t_max,
        counters,
        #[inline(always)]
        |blocks, t_max, counters| {
            blocks.iter().any(|block| {
                block.count_tests(counters);
                leaf(block, query, t_max)
            })
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::Portable;
    use crate::trace::{NoCounters, RayKind, Workload};

    #[test]
    fn dispatched_node_test_equals_the_portable_one() {
        for scene in [
            Scene::from_mesh(crate::scenes::scan_blob(5_000, 4)),
            crate::scenes::room(),
        ] {
            let accel = SceneAccel::build(&scene, &BuildSettings::default());
            for kind in [RayKind::Primary, RayKind::Diffuse, RayKind::Shadow] {
                let work = Workload::generate(kind, &scene, &accel, 64, 64, 2);
                for ray in &work.rays {
                    let portable = accel.intersect_with::<Portable, _>(
                        ray,
                        &mut NoCounters,
                        Triangle4::intersect_into,
                    );
                    assert_eq!(accel.intersect(ray, &mut NoCounters), portable);
                    let blocked = accel.occluded_with::<Portable, _>(
                        ray,
                        &mut NoCounters,
                        Triangle4::occludes,
                    );
                    assert_eq!(accel.occluded(ray, &mut NoCounters), blocked);
                }
            }
        }
    }
}

//! obvhs side by side (feature `obvhs`): its compressed wide BVH (CWBVH) over the
//! world-space triangles, traced with its own traversal, as a second Rust reference.

use crate::reference::Reference;
use crate::LabError;
use glam::Vec3A;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray as ObvhsRay, RayHit};
use obvhs::triangle::Triangle as ObvhsTriangle;
use obvhs::BvhBuildParams;
use rtmesh::trace::{Counters, Hit, Tracer};
use rtmesh::{Ray, Scene};

/// obvhs's compressed wide BVH (CWBVH) over the world-space triangles, traced with
/// its own traversal and Möller–Trumbore test.
pub struct ObvhsScene {
    bvh: CwBvh,
    triangles: Vec<ObvhsTriangle>,
    /// (instance, triangle) of each world triangle.
    ids: Vec<(u32, u32)>,
}

fn to_obvhs(ray: &Ray) -> ObvhsRay {
    ObvhsRay::new(
        Vec3A::from(ray.origin),
        Vec3A::from(ray.direction),
        ray.t_min,
        ray.t_max,
    )
}

impl Tracer for ObvhsScene {
    #[inline]
    fn intersect<C: Counters>(&self, ray: &Ray, _: &mut C) -> Hit {
        let mut hit = RayHit::none();
        let query = to_obvhs(ray);
        if !self.bvh.ray_traverse(query, &mut hit, |r, id| {
            self.triangles[self.bvh.primitive_indices[id] as usize].intersect(r)
        }) {
            return Hit::MISS;
        }
        let (instance, triangle) =
            self.ids[self.bvh.primitive_indices[hit.primitive_id as usize] as usize];
        Hit {
            t: hit.t,
            u: 0.0,
            v: 0.0,
            triangle,
            instance,
            geometry: u32::MAX,
        }
    }
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, _: &mut C) -> bool {
        !self.bvh.ray_traverse_miss(to_obvhs(ray), |r, id| {
            self.triangles[self.bvh.primitive_indices[id] as usize].intersect(r)
        })
    }
}

impl Reference for ObvhsScene {
    const NAME: &'static str = "obvhs";
    fn build(scene: &Scene, _threads: usize) -> Result<(Self, f64), LabError> {
        let mut triangles = Vec::new();
        let mut ids = Vec::new();
        for (i, instance) in scene.instances.iter().enumerate() {
            let mesh = &scene.meshes[instance.mesh];
            for t in 0..mesh.triangle_count() {
                let [v0, v1, v2] = mesh
                    .corners(t)
                    .map(|p| Vec3A::from(instance.transform.transform_point3(p)));
                if v0.is_finite() && v1.is_finite() && v2.is_finite() {
                    triangles.push(ObvhsTriangle { v0, v1, v2 });
                    ids.push((i as u32, t as u32));
                }
            }
        }
        let start = std::time::Instant::now();
        let bvh = build_cwbvh_from_tris(
            &triangles,
            BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        let seconds = start.elapsed().as_secs_f64();
        Ok((
            Self {
                bvh,
                triangles,
                ids,
            },
            seconds,
        ))
    }
}

//! rtmesh prepares triangle meshes for ray tracing and measures the gain with its own
//! CPU ray tracer.
//!
//! Data flow: [`io`] reads a file into a [`mesh::Scene`]; [`lint`] finds what makes it
//! slow to trace and [`repair`] fixes it, both on the shared [`analysis`]; [`pair`]
//! pairs triangles that share an edge; [`bvh`] builds the 8-wide SAH hierarchy that
//! [`trace`] traverses to measure box tests, triangle tests and Mrays/s on deterministic
//! workloads; [`render`] draws images and cost heatmaps; [`optimize`] is the main job,
//! all of it in one call, with the report that proves the gain. [`simd`] holds the CPU
//! detection and the one dispatch to AVX kernels. Comparisons with Embree and the
//! papers' experiments live in the `rtmesh-lab` crate.
//!
//! Read a mesh, lint it, pair it, build the tracer's BVH over the pairs and trace a
//! ray:
//!
//! ```
//! use rtmesh::bvh::BuildSettings;
//! use rtmesh::lint::{lint, LintSettings};
//! use rtmesh::pair::{pair_scene, PairSettings};
//! use rtmesh::trace::{NoCounters, SceneAccel, Tracer};
//! use rtmesh::Ray;
//! use glam::Vec3;
//!
//! // A unit square in z = 0, as two triangles, in an OBJ file.
//! let dir = std::env::temp_dir().join(format!("rtmesh-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir)?;
//! let path = dir.join("square.obj");
//! std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n")?;
//! let mut scene = rtmesh::io::read(&path)?;
//! assert_eq!(scene.instanced_triangle_count(), 2);
//!
//! // Two well-shaped triangles: nothing to report.
//! let report = lint(&scene, &LintSettings::default());
//! assert!(report.findings.is_empty());
//!
//! // They share an edge, so they pair.
//! let pairing = pair_scene(&mut scene, &PairSettings::default());
//! assert_eq!(pairing.paired_triangles, 2);
//!
//! // Build, and trace a ray down onto the square's first triangle.
//! let accel = SceneAccel::build(&scene, &BuildSettings::default());
//! let ray = Ray::new(Vec3::new(0.75, 0.25, 1.0), Vec3::new(0.0, 0.0, -1.0));
//! let hit = accel.intersect(&ray, &mut NoCounters);
//! assert!(hit.is_hit());
//! assert_eq!(hit.t, 1.0);
//! std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

pub mod analysis;
pub mod animate;
pub mod bvh;
pub mod cluster;
pub mod data;
pub mod geom;
pub mod io;
pub mod lint;
pub mod mesh;
pub mod optimize;
mod pages;
pub mod pair;
pub mod progress;
pub mod random;
pub mod render;
pub mod repair;
pub mod scenes;
pub mod simd;
pub mod strip;
pub mod trace;

pub use geom::{Aabb, Ray};
pub use mesh::{Instance, Material, Scene, TriMesh};

/// Hint the CPU to fetch the cache line of address `at`, which need not be valid nor
/// safe to read (no effect where unsupported).
#[inline(always)]
pub(crate) fn prefetch_address<T>(at: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: prefetching is a hint; it never faults, whatever the address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(at.cast::<i8>())
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = at;
}

/// Hint the CPU to fetch the cache lines of `value` (no effect where unsupported).
#[inline(always)]
pub(crate) fn prefetch<T: ?Sized>(value: &T) {
    let start = (value as *const T).cast::<u8>();
    for offset in (0..std::mem::size_of_val(value)).step_by(64) {
        prefetch_address(start.wrapping_add(offset));
    }
}

//! rtmesh prepares triangle meshes for ray tracing and measures the gain with its own
//! CPU ray tracer.
//!
//! Data flow: [`io`] reads a file into a [`mesh::Scene`]; [`mesh`] validates, welds and
//! finds edge adjacency; [`scenes`] makes procedural test scenes; [`bvh`] builds the
//! 8-wide SAH hierarchy that [`trace`] traverses to measure box tests, triangle tests and
//! Mrays/s on deterministic workloads; [`render`] draws images and cost heatmaps.
#![warn(missing_docs)]

pub mod analysis;
pub mod bvh;
pub mod data;
pub mod geom;
pub mod io;
pub mod lint;
pub mod mesh;
mod pages;
pub mod pair;
pub mod progress;
pub mod random;
pub mod render;
pub mod repair;
pub mod scenes;
pub mod simd;
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

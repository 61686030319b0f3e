//! rtmesh prepares triangle meshes for ray tracing and measures the gain with its own
//! CPU ray tracer.
//!
//! Data flow: [`io`] reads a file into a [`mesh::Scene`]; [`mesh`] validates, welds and
//! finds edge adjacency; [`scenes`] makes procedural test scenes; [`bvh`] builds the
//! 8-wide SAH hierarchy that [`trace`] traverses to measure box tests, triangle tests and
//! Mrays/s on deterministic workloads; [`render`] draws images and cost heatmaps.
#![warn(missing_docs)]

pub mod bvh;
pub mod data;
#[cfg(feature = "embree")]
pub mod embree;
pub mod geom;
pub mod io;
pub mod mesh;
pub mod pair;
pub mod radix;
pub mod random;
pub mod render;
pub mod scenes;
pub mod trace;

pub use geom::{Aabb, Ray};
pub use mesh::{Instance, Material, Scene, TriMesh};

//! rtmesh's measuring lab: what compares rtmesh with other tracers and redoes the
//! papers' experiments, kept out of the core library so that it carries no FFI.
//!
//! - [`reference`](mod@reference): the same rays through rtmesh and another tracer
//!   (`embree` with the `embree` feature, `obvhs` with the `obvhs` feature), side by
//!   side;
//! - [`harness`]: timing by alternating rounds and medians;
//! - [`tables`]: the rows of `rtmesh bench` (trace, pairing, packets, and the packet
//!   paper's experiment without a BVH).
#![warn(missing_docs)]

#[cfg(feature = "embree")]
pub mod embree;
pub mod harness;
#[cfg(feature = "obvhs")]
pub mod obvhs;
pub mod reference;
pub mod tables;

/// What can go wrong in the lab.
#[derive(Debug, thiserror::Error)]
pub enum LabError {
    /// Embree failed to start, allocate or build.
    #[error("Embree: {0}")]
    Embree(String),
    /// A comparison asked for a tracer this build does not have.
    #[error(
        "cannot compare {mesh} with {tracer}: this rtmesh was built without it; rebuild with `--features {tracer}`"
    )]
    MissingFeature {
        /// The tracer's cargo feature.
        tracer: &'static str,
        /// The mesh that was to be compared.
        mesh: String,
    },
}

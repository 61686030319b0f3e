//! The analysis that lint finds with and repair fixes by: the shape of a triangle, the
//! connected pieces of a geometry, instances whose boxes overlap, and the regrouping of
//! geometries (split scattered ones, merge overlapping ones) with the map back to the
//! input. Neither lint nor repair is imported here; both import this.

pub mod grouping;
pub mod overlap;
pub mod pieces;
pub mod shape;

pub use grouping::{proposed_grouping, RepairMap, Repaired};
pub use overlap::overlapping_instances;
pub use pieces::Pieces;
pub use shape::TriangleShape;

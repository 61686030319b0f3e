//! The rows of `rtmesh bench`: each function measures one mesh and returns typed rows
//! that the CLI prints as a table or as JSON lines.

pub mod clusters;
pub mod intersect;
pub mod packets;
pub mod pairing;
pub mod quads;
pub mod strips;
pub mod trace;

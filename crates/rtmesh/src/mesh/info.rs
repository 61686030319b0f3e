//! The figures of `rtmesh info`: counts, bounds, and topology after exact welding.
//! Counts and topology are of the geometry as stored (each mesh once), as other mesh
//! tools count a file; the instanced (world) counts stand beside them.
//! Cost: one concatenation, one weld (hashing, O(V)) and one adjacency build (O(T)).

use super::{connected_components, validate, EdgeAdjacency, Scene};
use crate::geom::Aabb;
use serde::Serialize;

/// Summary of a scene, as printed by `rtmesh info`.
#[derive(Clone, Debug, Serialize)]
pub struct MeshInfo {
    /// Vertex records in the file (or of the stored geometry when not read from a file).
    pub vertices: usize,
    /// Triangles of the stored geometry (each mesh once).
    pub triangles: usize,
    /// Triangles in the world: each mesh counted once per instance.
    pub instanced_triangles: usize,
    /// Vertices left after merging identical positions.
    pub welded_vertices: usize,
    /// World-space box of the scene (all instances).
    pub bounds: Aabb,
    /// Edge-connected components of triangles (after welding).
    pub components: usize,
    /// Edges with one triangle (after welding).
    pub boundary_edges: usize,
    /// Edges with two triangles (after welding).
    pub manifold_edges: usize,
    /// Edges with three or more triangles (after welding).
    pub nonmanifold_edges: usize,
    /// Geometries (BLAS candidates).
    pub meshes: usize,
    /// Placements of geometries (TLAS entries).
    pub instances: usize,
    /// Materials.
    pub materials: usize,
    /// Triangles with an alpha-tested material.
    pub alpha_tested_triangles: usize,
    /// Triangles with NaN or infinite corners.
    pub non_finite_triangles: usize,
    /// Triangles naming one vertex twice.
    pub repeated_vertex_triangles: usize,
    /// Triangles with distinct vertices but zero area.
    pub zero_area_triangles: usize,
    /// Degenerate triangles of PLY triangle strips (swaps and joins) dropped on reading.
    pub strip_degenerates_dropped: usize,
    /// OBJ `l` and `p` statements ignored on reading (not triangles).
    pub ignored_line_and_point_statements: usize,
}

impl MeshInfo {
    /// Compute the summary of `scene`.
    pub fn of(scene: &Scene) -> Self {
        let flat = scene.stored_geometry();
        let welded = flat.topology();
        let adjacency = EdgeAdjacency::build(&welded);
        let validation = validate(&flat);
        Self {
            vertices: scene.source_vertex_count.unwrap_or(flat.positions.len()),
            triangles: flat.triangles.len(),
            instanced_triangles: scene.instanced_triangle_count(),
            welded_vertices: welded.positions.len(),
            bounds: scene.bounds(),
            components: connected_components(&adjacency).1,
            boundary_edges: adjacency.boundary_edge_count(),
            manifold_edges: adjacency.manifold_edge_count(),
            nonmanifold_edges: adjacency.nonmanifold_edge_count(),
            meshes: scene.meshes.len(),
            instances: scene.instances.len(),
            materials: scene.materials.len(),
            alpha_tested_triangles: flat.alpha_tested.iter().filter(|&&a| a).count(),
            non_finite_triangles: validation.non_finite_positions.len(),
            repeated_vertex_triangles: validation.repeated_vertices.len(),
            zero_area_triangles: validation.zero_area.len(),
            strip_degenerates_dropped: scene.read_notes.strip_degenerates_dropped,
            ignored_line_and_point_statements: scene.read_notes.ignored_lines
                + scene.read_notes.ignored_points,
        }
    }
}

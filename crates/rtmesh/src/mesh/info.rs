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
    /// The vertex attributes besides the position, over all geometries.
    pub attributes: Vec<AttributeSummary>,
    /// The triangle attributes (a PLY face's properties), over all geometries; their
    /// `vertices` count triangles.
    pub triangle_attributes: Vec<AttributeSummary>,
    /// What the file holds that was not read, in words (a PLY's other elements).
    pub not_read: Vec<String>,
    /// Material names, in order (a reader adds an unnamed default where faces have
    /// none).
    pub material_names: Vec<String>,
    /// What the file held beyond the mesh model (glTF nodes, skins, animations, morph
    /// targets; OBJ material libraries).
    pub document: DocumentSummary,
}

/// One vertex attribute, as `rtmesh info` lists it.
#[derive(Clone, Debug, Serialize)]
pub struct AttributeSummary {
    /// glTF-style name (`NORMAL`, `TEXCOORD_0`, `target0:POSITION`, a PLY property's).
    pub name: String,
    /// Values per vertex.
    pub components: usize,
    /// Stored component type, as PLY spells it (`float`, `uchar`, ...).
    pub component_type: &'static str,
    /// Integers stand for [0, 1] or [−1, 1].
    pub normalized: bool,
    /// Geometries that have it.
    pub geometries: usize,
    /// Vertices of those geometries (triangles, for a triangle attribute).
    pub vertices: usize,
}

/// The parts of the source document rtmesh keeps and writes back.
#[derive(Clone, Debug, Default, Serialize)]
pub struct DocumentSummary {
    /// glTF scenes: rtmesh traces the default one (or the first), and writes every one
    /// back.
    pub scenes: usize,
    /// glTF nodes.
    pub nodes: usize,
    /// glTF skins.
    pub skins: usize,
    /// glTF animations.
    pub animations: usize,
    /// glTF textures.
    pub textures: usize,
    /// glTF images.
    pub images: usize,
    /// glTF cameras.
    pub cameras: usize,
    /// OBJ `mtllib` references, as written.
    pub material_libraries: Vec<String>,
    /// A PLY header's `comment` and `obj_info` lines (but MeshLab's `TextureFile`
    /// comments, which the materials hold), kept and written back.
    pub ply_comments: Vec<String>,
    /// A binary STL's header, as text (bytes that are not printable ASCII as `\xNN`,
    /// trailing spaces and NULs left out), kept and written back; empty elsewhere.
    pub stl_header: String,
}

impl DocumentSummary {
    fn of(scene: &Scene) -> Self {
        match scene.document.as_deref() {
            Some(crate::io::Document::Gltf(gltf)) => {
                let root = &gltf.root;
                Self {
                    scenes: root.scenes.len(),
                    nodes: root.nodes.len(),
                    skins: root.skins.len(),
                    animations: root.animations.len(),
                    textures: root.textures.len(),
                    images: root.images.len(),
                    cameras: root.cameras.len(),
                    ..Self::default()
                }
            }
            Some(crate::io::Document::Obj { material_libraries }) => Self {
                material_libraries: material_libraries.clone(),
                ..Self::default()
            },
            Some(crate::io::Document::Ply { comments, obj_info }) => Self {
                ply_comments: comments.iter().chain(obj_info).cloned().collect(),
                ..Self::default()
            },
            Some(crate::io::Document::Stl { header }) => Self {
                stl_header: crate::io::stl_header_text(header),
                ..Self::default()
            },
            None => Self::default(),
        }
    }
}

/// The attribute streams `streams` gives of every geometry of `scene`, by name, in
/// order of first appearance.
fn attribute_summaries(
    scene: &Scene,
    streams: fn(&super::TriMesh) -> &[super::VertexAttribute],
) -> Vec<AttributeSummary> {
    let mut out: Vec<AttributeSummary> = Vec::new();
    for mesh in &scene.meshes {
        for attribute in streams(mesh) {
            let summary = match out.iter_mut().position(|a| a.name == attribute.name) {
                Some(i) => &mut out[i],
                None => {
                    out.push(AttributeSummary {
                        name: attribute.name.clone(),
                        components: attribute.components,
                        component_type: attribute.type_name(),
                        normalized: attribute.normalized,
                        geometries: 0,
                        vertices: 0,
                    });
                    out.last_mut().expect("just pushed")
                }
            };
            summary.geometries += 1;
            summary.vertices += attribute.vertex_count();
        }
    }
    out
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
            bounds: scene.placed_bounds(),
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
            attributes: attribute_summaries(scene, |m| &m.attributes),
            triangle_attributes: attribute_summaries(scene, |m| &m.triangle_attributes),
            not_read: scene.read_notes.not_read.clone(),
            material_names: scene.materials.iter().map(|m| m.name.clone()).collect(),
            document: DocumentSummary::of(scene),
        }
    }
}

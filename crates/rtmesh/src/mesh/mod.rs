//! The mesh model: [`TriMesh`] (one geometry) and [`Scene`] (geometries plus instances).
//!
//! Positions are f32, triangles are u32 vertex indices. Every triangle carries a material
//! id, an alpha-tested flag (so that lint and repair can separate opaque from
//! alpha-tested geometry, NVIDIA's advice) and a group (the glTF primitive it came
//! from). Every vertex carries its [`VertexAttribute`] streams. Topology comes from
//! positions ([`TriMesh::topology`]), so adjacency crosses UV seams and normal creases,
//! while the vertices keep them: no operation merges two vertices whose attributes
//! differ.

mod adjacency;
mod attributes;
mod duplicates;
mod info;
mod triangle_ids;
mod validate;
mod weld;

pub use adjacency::{connected_components, EdgeAdjacency, NO_EDGE};
pub(crate) use adjacency::{has_edges, part_cursors, triangle_part_len, HalfEdgeRuns, SharedSlice};
pub(crate) use attributes::gather_all;
pub use attributes::{morph_name, AttributeValues, Semantic, VertexAttribute, MORPH_PREFIX};
pub use duplicates::{duplicates, Duplicates};
pub use info::{AttributeSummary, DocumentSummary, MeshInfo};
pub(crate) use triangle_ids::TriangleIds;
pub use validate::{validate, Validation};
pub use weld::{weld, weld_exact, WeldResult};

use crate::geom::Aabb;
use glam::{Affine3A, Vec3};
use serde::Serialize;

/// Triangle `t`'s corners rotated by `r` (0, 1 or 2) places: the same triangle, the
/// same winding.
pub fn rotate(t: [u32; 3], r: usize) -> [u32; 3] {
    [t[r], t[(r + 1) % 3], t[(r + 2) % 3]]
}

/// Triangle `t`'s corners rotated to start at the smallest index: equal for two
/// triangles exactly when they have the same corners and the same winding.
pub fn smallest_first(t: [u32; 3]) -> [u32; 3] {
    rotate(t, (0..3).min_by_key(|&k| t[k]).unwrap_or(0))
}

/// Whether triangle `t` names a vertex twice (or three times): a line or a point, and
/// in a rasterization strip a join or a swap.
pub fn names_a_vertex_twice(t: [u32; 3]) -> bool {
    t[0] == t[1] || t[1] == t[2] || t[2] == t[0]
}

/// A material as far as ray tracing cares: its name and whether it is alpha-tested
/// (any-hit shaders run on its triangles).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Material {
    /// Name from the file (`usemtl`, glTF material name), or empty.
    pub name: String,
    /// True for cut-out materials: OBJ `map_d` or `d < 1`, glTF `alphaMode` MASK or BLEND.
    pub alpha_tested: bool,
    /// How an OBJ material looks, in MTL's terms, for a writer that translates it (a
    /// glTF written from an OBJ); `None` elsewhere (a glTF's document keeps its
    /// materials whole).
    #[serde(skip)]
    pub mtl: Option<MtlLook>,
}

/// What an MTL material says about its look, as far as glTF can hold it. Texture files
/// are relative to the OBJ's folder (a library in a subfolder names them relative to
/// itself: they are prefixed with its folder).
#[derive(Clone, Debug, PartialEq)]
pub struct MtlLook {
    /// `Kd`: white when absent.
    pub diffuse: [f32; 3],
    /// `d`, the opacity: 1 when absent.
    pub dissolve: f32,
    /// `Ke`: black when absent.
    pub emissive: [f32; 3],
    /// `Pm` (MTL's PBR extension): metalness, when given.
    pub metallic: Option<f32>,
    /// `Pr` (MTL's PBR extension): roughness, when given.
    pub roughness: Option<f32>,
    /// `map_Kd`.
    pub diffuse_map: Option<MtlMap>,
    /// `map_Bump`, `bump` or `norm`: glTF takes it as a normal map.
    pub normal_map: Option<MtlMap>,
    /// `map_Ke`.
    pub emissive_map: Option<MtlMap>,
    /// `map_Pm` and `map_Pr` when both name one file (metalness and roughness in two of
    /// its channels, as glTF packs them).
    pub metallic_roughness_map: Option<MtlMap>,
    /// Whether it has a `map_d`, a cut-out mask (glTF has no place for the map itself:
    /// its opacity is the base colour's alpha).
    pub dissolve_map: bool,
}

/// One MTL texture map: its file, and where its `-s` and `-o` options place it (the
/// image is looked up at uv·scale + offset, from its bottom-left corner).
#[derive(Clone, Debug, PartialEq)]
pub struct MtlMap {
    /// The image file, relative to the OBJ's folder.
    pub file: String,
    /// `-s u v`: (1, 1) when absent.
    pub scale: [f32; 2],
    /// `-o u v`: (0, 0) when absent.
    pub offset: [f32; 2],
}

impl MtlLook {
    /// A white, opaque material whose look is its diffuse map alone (what a PLY's
    /// `TextureFile` comment says).
    pub fn plain_texture(file: &str) -> Self {
        Self {
            diffuse: [1.0; 3],
            dissolve: 1.0,
            emissive: [0.0; 3],
            metallic: None,
            roughness: None,
            diffuse_map: Some(MtlMap {
                file: file.to_owned(),
                scale: [1.0; 2],
                offset: [0.0; 2],
            }),
            normal_map: None,
            emissive_map: None,
            metallic_roughness_map: None,
            dissolve_map: false,
        }
    }

    /// Whether it is [`MtlLook::plain_texture`] of its diffuse map.
    pub fn is_plain_texture(&self) -> bool {
        self.diffuse_map
            .as_ref()
            .is_some_and(|map| *self == Self::plain_texture(&map.file))
    }

    /// The texture files it names: the diffuse, normal, emissive and
    /// metallic-roughness maps.
    pub fn texture_files(&self) -> impl Iterator<Item = &String> {
        let maps = [
            &self.diffuse_map,
            &self.normal_map,
            &self.emissive_map,
            &self.metallic_roughness_map,
        ];
        maps.into_iter().flatten().map(|map| &map.file)
    }
}

/// One triangle geometry: shared vertices, indexed triangles and per-triangle attributes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Name from the file (OBJ group/object, glTF mesh), or empty.
    pub name: String,
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Triangles as three indices into `positions`, in file order.
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle: index into [`Scene::materials`].
    pub material_ids: Vec<u32>,
    /// Per triangle: true when the triangle's material is alpha-tested.
    pub alpha_tested: Vec<bool>,
    /// Per triangle: its group, the primitive of the source document it came from (a
    /// glTF primitive, numbered over the whole file in mesh order; 0 for formats
    /// without primitives). Writers emit one primitive per run of equal group.
    pub group_ids: Vec<u32>,
    /// Per-vertex attributes besides the position, each holding one value per vertex
    /// of `positions`.
    pub attributes: Vec<VertexAttribute>,
    /// Per-triangle attributes (a PLY face's scalar properties: a colour, a label), each
    /// holding one value per triangle of `triangles`. A triangle split from another
    /// (a fan of a polygon, a bisected sliver) holds its source's values.
    pub triangle_attributes: Vec<VertexAttribute>,
}

impl TriMesh {
    /// A mesh with material 0 and opaque triangles.
    pub fn new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Self {
        let n = triangles.len();
        Self {
            name: String::new(),
            positions,
            triangles,
            material_ids: vec![0; n],
            alpha_tested: vec![false; n],
            group_ids: vec![0; n],
            attributes: Vec::new(),
            triangle_attributes: Vec::new(),
        }
    }

    /// The attribute called `name`, if the mesh has it.
    pub fn attribute(&self, name: &str) -> Option<&VertexAttribute> {
        self.attributes.iter().find(|a| a.name == name)
    }

    /// The triangle attribute called `name`, if the mesh has it.
    pub fn triangle_attribute(&self, name: &str) -> Option<&VertexAttribute> {
        self.triangle_attributes.iter().find(|a| a.name == name)
    }

    /// Group of triangle `t` (0 where none was recorded).
    #[inline]
    pub fn group_of(&self, t: usize) -> u32 {
        self.group_ids.get(t).copied().unwrap_or(0)
    }

    /// The same mesh (vertices, attributes, name) with triangle `i` being `self`'s
    /// triangle `order[i]`, its material, alpha flag and group with it.
    pub fn reordered(&self, order: &[u32]) -> TriMesh {
        let mut out = TriMesh {
            name: self.name.clone(),
            positions: self.positions.clone(),
            triangles: order.iter().map(|&t| self.triangles[t as usize]).collect(),
            attributes: self.attributes.clone(),
            ..TriMesh::default()
        };
        out.take_triangle_data(self, order);
        out
    }

    /// Set the per-triangle material, alpha flag, group and attributes of every
    /// triangle from triangle `sources[t]` of `source`.
    pub fn take_triangle_data(&mut self, source: &TriMesh, sources: &[u32]) {
        let pick = |t: u32| t as usize;
        self.material_ids = sources
            .iter()
            .map(|&t| source.material_ids[pick(t)])
            .collect();
        self.alpha_tested = sources
            .iter()
            .map(|&t| source.alpha_tested[pick(t)])
            .collect();
        self.group_ids = sources.iter().map(|&t| source.group_of(pick(t))).collect();
        self.triangle_attributes = attributes::gather_all(&source.triangle_attributes, sources);
    }

    /// Append one triangle with the material, alpha flag, group and attributes of
    /// `source`'s triangle `t`.
    pub fn push_triangle_like(&mut self, triangle: [u32; 3], source: &TriMesh, t: usize) {
        if self.triangles.is_empty() {
            self.triangle_attributes = (source.triangle_attributes.iter())
                .map(VertexAttribute::emptied)
                .collect();
        }
        self.group_ids.resize(self.triangles.len(), 0);
        self.triangles.push(triangle);
        self.material_ids.push(source.material_ids[t]);
        self.alpha_tested.push(source.alpha_tested[t]);
        self.group_ids.push(source.group_of(t));
        for (out, from) in self
            .triangle_attributes
            .iter_mut()
            .zip(&source.triangle_attributes)
        {
            out.append_vertex_of(from, t);
        }
    }

    /// Append vertices: their positions and the streams `read` (one value per new
    /// vertex each). A stream new to the mesh gets zeros for the vertices before, and a
    /// stream `read` lacks gets zeros for the new vertices (a writer of glTF writes
    /// each primitive's own attributes only).
    pub fn extend_vertices(
        &mut self,
        positions: impl Iterator<Item = Vec3>,
        read: Vec<VertexAttribute>,
    ) {
        let base = self.positions.len();
        self.positions.extend(positions);
        append_streams(&mut self.attributes, base, read, self.positions.len());
    }

    /// Append `triangle` with the material, alpha flag, group and attributes of this
    /// mesh's triangle `t` (a triangle split from it).
    pub fn push_triangle_like_self(&mut self, t: usize, triangle: [u32; 3]) {
        self.group_ids.resize(self.triangles.len(), 0);
        self.triangles.push(triangle);
        self.material_ids.push(self.material_ids[t]);
        self.alpha_tested.push(self.alpha_tested[t]);
        self.group_ids.push(self.group_of(t));
        for attribute in &mut self.triangle_attributes {
            attribute.push_copy(t);
        }
    }

    /// Append vertex `v` of `source` (its position and every attribute); the streams
    /// must match (a mesh gathered from `source`). Returns the new vertex's index.
    pub fn push_vertex_like(&mut self, source: &TriMesh, v: usize) -> u32 {
        if self.positions.is_empty() {
            self.attributes = source
                .attributes
                .iter()
                .map(VertexAttribute::emptied)
                .collect();
        }
        self.positions.push(source.positions[v]);
        for (out, from) in self.attributes.iter_mut().zip(&source.attributes) {
            out.append_vertex_of(from, v);
        }
        self.positions.len() as u32 - 1
    }

    /// Append a copy of vertex `v` (position and every attribute); returns its index.
    pub fn copy_vertex(&mut self, v: usize) -> u32 {
        self.positions.push(self.positions[v]);
        for attribute in &mut self.attributes {
            attribute.push_copy(v);
        }
        self.positions.len() as u32 - 1
    }

    /// The mesh positions alone see: vertices welded by exact position, attributes
    /// dropped, same triangles in the same order. Adjacency, pairing and pieces run on
    /// it, so that they cross UV seams and normal creases.
    pub fn topology(&self) -> TriMesh {
        weld::weld_positions(self)
    }

    /// [`TriMesh::topology`] with no edge shared across groups or materials: each
    /// vertex used by triangles of several (group, material) keys is split into one per
    /// key first. Pairing runs on it, so that a pair never spans two glTF primitives
    /// or two materials (it could not be written as two consecutive triangles of one
    /// primitive, nor built as one hardware quad of one geometry).
    pub fn topology_within_groups(&self) -> TriMesh {
        self.split_across_groups(self.topology())
    }

    /// Positions and triangles of `self` by its own vertex indices (attributes
    /// dropped, nothing welded), split across groups as in
    /// [`Self::topology_within_groups`]: pairs found on it share vertex indices, so a
    /// hardware pairer that matches indices finds them too.
    pub fn indices_within_groups(&self) -> TriMesh {
        self.split_across_groups(TriMesh {
            positions: self.positions.clone(),
            triangles: self.triangles.clone(),
            material_ids: self.material_ids.clone(),
            alpha_tested: self.alpha_tested.clone(),
            group_ids: self.group_ids.clone(),
            ..TriMesh::default()
        })
    }

    /// `topology` (the triangles of `self`, reindexed) with every vertex that
    /// triangles of several (group, material) keys use split into one per key.
    fn split_across_groups(&self, topology: TriMesh) -> TriMesh {
        let key = |t: usize| {
            (
                self.group_of(t),
                self.material_ids.get(t).copied().unwrap_or(0),
            )
        };
        if (1..self.triangle_count()).all(|t| key(t) == key(0)) {
            return topology;
        }
        let mut split: std::collections::HashMap<(u32, (u32, u32)), u32> = Default::default();
        let mut out = TriMesh {
            positions: Vec::with_capacity(topology.positions.len()),
            ..topology.clone()
        };
        for t in 0..topology.triangle_count() {
            out.triangles[t] = topology.triangles[t].map(|v| {
                let Some(&p) = topology.positions.get(v as usize) else {
                    return v;
                };
                *split.entry((v, key(t))).or_insert_with(|| {
                    out.positions.push(p);
                    out.positions.len() as u32 - 1
                })
            });
        }
        out
    }

    /// The triangles of each (group, material) key, ascending: the primitives the
    /// writers write (a glTF primitive, an OBJ `usemtl` run of a group), each in order.
    pub fn primitives(&self) -> std::collections::BTreeMap<(u32, u32), Vec<u32>> {
        let mut primitives: std::collections::BTreeMap<(u32, u32), Vec<u32>> = Default::default();
        for t in 0..self.triangle_count() {
            let key = (
                self.group_of(t),
                self.material_ids.get(t).copied().unwrap_or(0),
            );
            primitives.entry(key).or_default().push(t as u32);
        }
        primitives
    }

    /// No triangle is alpha-tested: the geometry may carry DXR's
    /// `D3D12_RAYTRACING_GEOMETRY_FLAG_OPAQUE` (Vulkan `VK_GEOMETRY_OPAQUE_BIT_KHR`),
    /// so that no any-hit shader runs on it.
    pub fn is_opaque(&self) -> bool {
        !self.alpha_tested.contains(&true)
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The three corner positions of triangle `t` (indices must be in range).
    #[inline]
    pub fn corners(&self, t: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[t];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// The centroid of triangle `t` (indices must be in range).
    #[inline]
    pub fn centroid(&self, t: usize) -> Vec3 {
        let [a, b, c] = self.corners(t);
        (a + b + c) / 3.0
    }

    /// The corners of triangle `t` when its indices are in range and its corners
    /// finite (what the tracer keeps); `None` otherwise.
    #[inline]
    pub fn finite_corners(&self, t: usize) -> Option<[Vec3; 3]> {
        let n = self.positions.len();
        if self.triangles[t].iter().any(|&v| v as usize >= n) {
            return None;
        }
        let corners = self.corners(t);
        corners.iter().all(|p| p.is_finite()).then_some(corners)
    }

    /// Box of all vertices that triangles use, skipping non-finite positions.
    pub fn bounds(&self) -> Aabb {
        self.bounds_placed(&Affine3A::IDENTITY)
    }

    /// [`TriMesh::bounds`] of the mesh placed by `transform`: the box of the moved
    /// vertices, tighter than the moved box.
    pub fn bounds_placed(&self, transform: &Affine3A) -> Aabb {
        let mut used = vec![false; self.positions.len()];
        for t in &self.triangles {
            for &v in t {
                if let Some(u) = used.get_mut(v as usize) {
                    *u = true;
                }
            }
        }
        self.positions
            .iter()
            .zip(&used)
            .filter(|(p, &u)| u && p.is_finite())
            .fold(Aabb::EMPTY, |b, (&p, _)| {
                b.grown_by_point(transform.transform_point3(p))
            })
    }

    /// Append `other`, with its vertices moved by `transform` (normals and tangents
    /// turned with them); material ids are offset by `material_offset`. Attribute
    /// streams (of vertices and of triangles) are matched by name; a vertex or triangle
    /// from a mesh without one gets zeros.
    pub fn append(&mut self, other: &TriMesh, transform: &Affine3A, material_offset: u32) {
        let base = self.positions.len() as u32;
        let linear = glam::Mat3::from(transform.matrix3);
        let turned = other
            .attributes
            .iter()
            .map(|a| {
                let mut a = a.clone();
                a.transform(linear);
                a
            })
            .collect();
        self.extend_vertices(
            other
                .positions
                .iter()
                .map(|&p| transform.transform_point3(p)),
            turned,
        );
        self.triangles.extend(
            other
                .triangles
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
        self.material_ids
            .extend(other.material_ids.iter().map(|m| m + material_offset));
        self.alpha_tested.extend_from_slice(&other.alpha_tested);
        self.group_ids
            .extend((0..other.triangle_count()).map(|t| other.group_of(t)));
        let before = self.triangles.len() - other.triangle_count();
        append_streams(
            &mut self.triangle_attributes,
            before,
            other.triangle_attributes.clone(),
            self.triangles.len(),
        );
    }
}

/// Append the streams `read` (each of `count - before` values) to `streams` (each of
/// `before`), matched by name: a stream new to `streams` gets zeros for the `before`
/// values, and a stream `read` lacks gets zeros for the new ones.
fn append_streams(
    streams: &mut Vec<VertexAttribute>,
    before: usize,
    read: Vec<VertexAttribute>,
    count: usize,
) {
    for attribute in read {
        match streams.iter_mut().find(|a| a.name == attribute.name) {
            Some(stream) => stream.append(&attribute),
            None => {
                let mut stream = attribute.emptied();
                stream.push_zeros(before);
                stream.append(&attribute);
                streams.push(stream);
            }
        }
    }
    for stream in streams {
        stream.push_zeros(count - stream.vertex_count());
    }
}

/// One placement of a mesh in the scene: `world = transform * local`.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Index into [`Scene::meshes`].
    pub mesh: usize,
    /// Object-to-world affine transform.
    pub transform: Affine3A,
    /// The node of the source document that placed it (glTF), so that a writer of the
    /// same format puts it back there; `None` for an instance rtmesh made.
    pub source_node: Option<u32>,
}

impl Instance {
    /// Mesh `mesh` placed by `transform`, from no source node.
    pub fn new(mesh: usize, transform: Affine3A) -> Self {
        Self {
            mesh,
            transform,
            source_node: None,
        }
    }
}

/// The most triangles [`Scene::flatten`] makes (about 1.4 GB of triangles and their
/// per-triangle data before positions): 77 times the full dragon. Tracing and
/// rendering keep instances and have no such limit.
pub const MAX_FLATTENED_TRIANGLES: usize = 1 << 26;

/// A scene whose instances hold more triangles than [`MAX_FLATTENED_TRIANGLES`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "its {instances} instances hold {triangles} triangles, over the {MAX_FLATTENED_TRIANGLES} rtmesh flattens into one mesh (glTF output keeps instances, as do trace and render with triangle leaves)"
)]
pub struct TooManyToFlatten {
    /// Instances in the scene.
    pub instances: usize,
    /// Triangles they hold together.
    pub triangles: usize,
}

/// Geometries and their placements: the input of a two-level (TLAS/BLAS) structure.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    /// The geometries (BLAS candidates).
    pub meshes: Vec<TriMesh>,
    /// Their placements (TLAS entries). A mesh may be placed several times, or never.
    pub instances: Vec<Instance>,
    /// Materials referenced by the meshes' `material_ids`.
    pub materials: Vec<Material>,
    /// Vertex records in the file the scene was read from, where that differs from the
    /// meshes' vertices (OBJ: unused vertices are dropped and vertices shared between
    /// groups are copied into each group's geometry).
    pub source_vertex_count: Option<usize>,
    /// What the reader dropped or changed on the way in, by documented rule.
    pub read_notes: ReadNotes,
    /// What the source file held beyond this model (the glTF document, OBJ material
    /// libraries), for a writer of the same format to write back unchanged.
    pub document: Option<std::sync::Arc<crate::io::Document>>,
}

/// The documented repairs a reader made, counted (all zero for a scene not read from a
/// file).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ReadNotes {
    /// Triangles of PLY `tristrips` and glTF `TRIANGLE_STRIP` primitives that name a
    /// vertex twice: the swaps and joins that stitch a generalized strip together, which
    /// cover no surface. Dropped.
    pub strip_degenerates_dropped: usize,
    /// OBJ `l` (polyline) statements: not triangles, so ignored.
    pub ignored_lines: usize,
    /// OBJ `p` (point) statements: not triangles, so ignored.
    pub ignored_points: usize,
    /// What else the file holds that was not read, in words: a PLY's elements other
    /// than vertices, faces and strips, and its faces' list properties; an OBJ's
    /// smoothing groups where it has no normals.
    pub not_read: Vec<String>,
}

impl Scene {
    /// The names of the meshes' triangle attributes, each once, in order of first
    /// appearance.
    pub fn triangle_attribute_names(&self) -> Vec<&str> {
        let mut names: Vec<&str> = Vec::new();
        for attribute in self.meshes.iter().flat_map(|m| &m.triangle_attributes) {
            if !names.contains(&attribute.name.as_str()) {
                names.push(&attribute.name);
            }
        }
        names
    }

    /// A scene of one mesh placed once, untransformed.
    pub fn from_mesh(mesh: TriMesh) -> Self {
        Self {
            meshes: vec![mesh],
            instances: vec![Instance::new(0, Affine3A::IDENTITY)],
            materials: vec![Material::default()],
            source_vertex_count: None,
            read_notes: ReadNotes::default(),
            document: None,
        }
    }

    /// Add a mesh placed once with `transform`; returns its mesh index.
    pub fn push_mesh(&mut self, mesh: TriMesh, transform: Affine3A) -> usize {
        self.meshes.push(mesh);
        let index = self.meshes.len() - 1;
        self.instances.push(Instance::new(index, transform));
        index
    }

    /// Triangles in the world: every instance counts its mesh's triangles.
    pub fn instanced_triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh].triangle_count())
            .sum()
    }

    /// How many instances place each mesh (0 for a mesh never placed).
    pub fn placements(&self) -> Vec<usize> {
        let mut placements = vec![0; self.meshes.len()];
        for instance in &self.instances {
            placements[instance.mesh] += 1;
        }
        placements
    }

    /// Vertices in the world: every instance counts its mesh's vertices.
    pub fn instanced_vertex_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh].positions.len())
            .sum()
    }

    /// True when every instance places a distinct mesh once with the identity transform,
    /// so that [`Scene::flatten`] is exactly the meshes one after another.
    pub fn is_flat(&self) -> bool {
        self.instances.len() == self.meshes.len()
            && self
                .instances
                .iter()
                .enumerate()
                .all(|(i, inst)| inst.mesh == i && inst.transform == Affine3A::IDENTITY)
    }

    /// One mesh holding every instance's triangles in world space, in instance order.
    /// The i-th triangle of the result is the i-th triangle in instance order. Refused
    /// past [`MAX_FLATTENED_TRIANGLES`]: a small file can place one large mesh
    /// thousands of times.
    pub fn flatten(&self) -> Result<TriMesh, TooManyToFlatten> {
        self.check_flattenable()?;
        Ok(self.concatenate(
            self.instances
                .iter()
                .map(|i| (&self.meshes[i.mesh], i.transform)),
        ))
    }

    /// Whether [`Scene::flatten`] stays within [`MAX_FLATTENED_TRIANGLES`] (writers of
    /// one-level formats ask before writing).
    pub fn check_flattenable(&self) -> Result<(), TooManyToFlatten> {
        let triangles = self.instanced_triangle_count();
        if triangles > MAX_FLATTENED_TRIANGLES {
            return Err(TooManyToFlatten {
                instances: self.instances.len(),
                triangles,
            });
        }
        Ok(())
    }

    /// One mesh holding every stored geometry once, untransformed, in mesh order: the
    /// geometry as the file stores it, whatever the instancing.
    pub fn stored_geometry(&self) -> TriMesh {
        self.concatenate(self.meshes.iter().map(|m| (m, Affine3A::IDENTITY)))
    }

    fn concatenate<'a>(
        &'a self,
        parts: impl Iterator<Item = (&'a TriMesh, Affine3A)> + Clone,
    ) -> TriMesh {
        let mut out = TriMesh {
            name: self
                .meshes
                .first()
                .filter(|_| self.meshes.len() == 1)
                .map(|m| m.name.clone())
                .unwrap_or_default(),
            ..TriMesh::default()
        };
        out.positions
            .reserve(parts.clone().map(|(m, _)| m.positions.len()).sum());
        out.triangles
            .reserve(parts.clone().map(|(m, _)| m.triangle_count()).sum());
        for (mesh, transform) in parts {
            out.append(mesh, &transform, 0);
        }
        out
    }

    /// World-space box of all instances: the union of their meshes' boxes, moved (a
    /// bound, which a rotated instance makes loose; the ray workloads aim by it).
    pub fn bounds(&self) -> Aabb {
        let mesh_bounds: Vec<Aabb> = self.meshes.iter().map(TriMesh::bounds).collect();
        self.instances.iter().fold(Aabb::EMPTY, |b, inst| {
            b.union(mesh_bounds[inst.mesh].transformed(&inst.transform))
        })
    }

    /// The exact world-space box of all instances' vertices that triangles use, as
    /// other tools report it (what [`Scene::flatten`]'s mesh bounds).
    pub fn placed_bounds(&self) -> Aabb {
        (self.instances.iter()).fold(Aabb::EMPTY, |b, inst| {
            b.union(self.meshes[inst.mesh].bounds_placed(&inst.transform))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A triangle turned 45° about Z: its exact box is that of the turned corners, which
    /// the flattened mesh has too, and the moved box is looser.
    #[test]
    fn placed_bounds_are_the_moved_vertices_box() {
        let mesh = TriMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
        let mut scene = Scene::from_mesh(mesh);
        let turn = Affine3A::from_rotation_z(std::f32::consts::FRAC_PI_4);
        scene.instances = vec![Instance::new(0, turn), Instance::new(0, Affine3A::IDENTITY)];
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let exact = scene.placed_bounds();
        assert!((exact.min - Vec3::new(-h, 0.0, 0.0)).abs().max_element() < 1e-6);
        assert!((exact.max - Vec3::new(1.0, 1.0, 0.0)).abs().max_element() < 1e-6);
        assert_eq!(exact, scene.flatten().unwrap().bounds());
        assert!(
            scene.bounds().max.y > 1.4,
            "the moved box of the turned square"
        );
    }

    /// 8,192 placements of an 8,192-triangle mesh flatten to exactly the limit; one more
    /// is refused, before anything is allocated.
    #[test]
    fn flatten_refuses_past_the_limit() {
        let side = 1usize << 13;
        let positions = (0..side + 2).map(|i| Vec3::new(i as f32, (i % 2) as f32, 0.0));
        let triangles = (0..side as u32).map(|i| [i, i + 1, i + 2]).collect();
        let mut scene = Scene::from_mesh(TriMesh::new(positions.collect(), triangles));
        scene.instances = vec![Instance::new(0, Affine3A::IDENTITY); side];
        assert_eq!(scene.instanced_triangle_count(), MAX_FLATTENED_TRIANGLES);
        assert_eq!(scene.check_flattenable(), Ok(()));
        scene.instances.push(Instance::new(0, Affine3A::IDENTITY));
        assert_eq!(
            scene.flatten().err(),
            Some(TooManyToFlatten {
                instances: side + 1,
                triangles: MAX_FLATTENED_TRIANGLES + side,
            })
        );
    }

    #[test]
    fn flatten_applies_transforms_in_instance_order() {
        let tri = TriMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
        let mut scene = Scene::from_mesh(tri);
        scene
            .instances
            .push(Instance::new(0, Affine3A::from_translation(Vec3::Z * 2.0)));
        let flat = scene.flatten().unwrap();
        assert_eq!(flat.triangles, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(flat.positions[3], Vec3::new(0.0, 0.0, 2.0));
        assert_eq!(scene.instanced_triangle_count(), 2);
        assert!(!scene.is_flat());
        assert_eq!(scene.bounds().max.z, 2.0);
    }
}

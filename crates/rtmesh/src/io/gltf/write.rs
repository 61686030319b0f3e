//! The glTF/GLB writer, through gltf-json's types. A scene read from glTF keeps its
//! document ([`GltfDocument`]): the output starts from it, so materials, textures,
//! images, samplers, cameras, nodes with their names, skins, animations, extras and
//! extensions come out equal. Only the triangle primitives are rewritten from the
//! scene's geometries (one primitive per group and material, its triangles in mesh
//! order, each taking the source primitive's material, extras, extensions and its own set of
//! attributes and morph targets); accessors and buffer views only those primitives
//! used are dropped, every other one is copied and renumbered, and all data goes to one
//! buffer; a GLB also stores the PNG and JPEG image files the document names by URI
//! (the caller reads them: `copy_side_files`), so that it is one file. A scene from
//! another format gets a fresh document: one node per instance,
//! its materials by name and alpha mode (an OBJ's MTL colours and textures translated,
//! see `material_from_mtl`), every attribute stream on every primitive.
//!
//! glTF forbids NaN and infinity: inactive triangles (a non-finite corner) are written
//! collapsed onto a finite corner, keeping their place ([`WriteNotes`]). Unit vectors
//! must be unit: normals and tangents that are not within 1e-4 of unit length are
//! renormalized (zero ones point along +z), and skin weights must sum to one: float
//! weights that do not are scaled so that they do; both are counted.

use super::{GltfDocument, QUANTIZATION};
use crate::io::{Document, WriteNotes};
use crate::mesh::{AttributeValues, Scene, Semantic, TriMesh, VertexAttribute, MORPH_PREFIX};
use glam::{Affine3A, Mat4, Vec3};
use gltf::json;
use json::validation::{Checked, USize64};
use json::Index;
use serde_json::json as value;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::Path;

/// The binary buffer being written, with its views and accessors.
#[derive(Default)]
struct Output {
    bin: Vec<u8>,
    views: Vec<json::buffer::View>,
    accessors: Vec<json::Accessor>,
}

impl Output {
    /// Append `bytes` as a new buffer view (4-byte aligned) and return its index.
    fn view(
        &mut self,
        bytes: &[u8],
        stride: Option<usize>,
        target: Option<json::buffer::Target>,
    ) -> Index<json::buffer::View> {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views.push(json::buffer::View {
            buffer: Index::new(0),
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(self.bin.len())),
            byte_stride: stride.map(json::buffer::Stride),
            name: None,
            target: target.map(Checked::Valid),
            extensions: None,
            extras: None,
        });
        self.bin.extend_from_slice(bytes);
        Index::new(self.views.len() as u32 - 1)
    }

    fn accessor(&mut self, accessor: json::Accessor) -> Index<json::Accessor> {
        self.accessors.push(accessor);
        Index::new(self.accessors.len() as u32 - 1)
    }

    /// An accessor over `attribute`'s values, each element padded to a 4-byte stride
    /// as glTF asks of vertex attributes.
    fn attribute(&mut self, attribute: &VertexAttribute) -> Index<json::Accessor> {
        use json::accessor::ComponentType as C;
        let (component, size, bytes): (C, usize, Vec<u8>) = match &attribute.values {
            AttributeValues::U8(v) => (C::U8, 1, v.clone()),
            AttributeValues::I8(v) => (C::I8, 1, v.iter().map(|&x| x as u8).collect()),
            AttributeValues::U16(v) => {
                (C::U16, 2, v.iter().flat_map(|x| x.to_le_bytes()).collect())
            }
            AttributeValues::I16(v) => {
                (C::I16, 2, v.iter().flat_map(|x| x.to_le_bytes()).collect())
            }
            AttributeValues::U32(v) => {
                (C::U32, 4, v.iter().flat_map(|x| x.to_le_bytes()).collect())
            }
            // glTF has no signed 32-bit or 64-bit components: written as float.
            AttributeValues::I32(v) => (
                C::F32,
                4,
                v.iter().flat_map(|&x| (x as f32).to_le_bytes()).collect(),
            ),
            AttributeValues::F32(v) => {
                (C::F32, 4, v.iter().flat_map(|x| x.to_le_bytes()).collect())
            }
            AttributeValues::F64(v) => (
                C::F32,
                4,
                v.iter().flat_map(|&x| (x as f32).to_le_bytes()).collect(),
            ),
        };
        let element = size * attribute.components;
        let stride = element.next_multiple_of(4);
        let padded: Cow<[u8]> = if stride == element {
            Cow::Borrowed(&bytes)
        } else {
            Cow::Owned(
                bytes
                    .chunks_exact(element)
                    .flat_map(|e| {
                        e.iter()
                            .copied()
                            .chain(std::iter::repeat_n(0, stride - element))
                    })
                    .collect(),
            )
        };
        let view = self.view(
            &padded,
            (stride != element).then_some(stride),
            Some(json::buffer::Target::ArrayBuffer),
        );
        let (min, max) = if attribute.name.ends_with("POSITION") {
            let (min, max) = bounds(attribute);
            (Some(value!(min)), Some(value!(max)))
        } else {
            (None, None)
        };
        self.accessor(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(attribute.vertex_count()),
            component_type: Checked::Valid(json::accessor::GenericComponentType(component)),
            extensions: None,
            extras: None,
            type_: Checked::Valid(element_type(attribute.components)),
            min,
            max,
            name: None,
            normalized: attribute.normalized && component != C::F32,
            sparse: None,
        })
    }
}

/// Per-component bounds of an attribute (POSITION accessors and morph-target position
/// deltas must state them).
fn bounds(attribute: &VertexAttribute) -> (Vec<f64>, Vec<f64>) {
    let k = attribute.components;
    let mut min = vec![f64::INFINITY; k];
    let mut max = vec![f64::NEG_INFINITY; k];
    for v in 0..attribute.vertex_count() {
        for c in 0..k {
            // Bounds of the values as written (f32).
            let x = attribute.get(v, c) as f32 as f64;
            min[c] = min[c].min(x);
            max[c] = max[c].max(x);
        }
    }
    if attribute.vertex_count() == 0 {
        return (vec![0.0; k], vec![0.0; k]);
    }
    (min, max)
}

fn element_type(components: usize) -> json::accessor::Type {
    match components {
        1 => json::accessor::Type::Scalar,
        2 => json::accessor::Type::Vec2,
        3 => json::accessor::Type::Vec3,
        _ => json::accessor::Type::Vec4,
    }
}

/// `mesh` as glTF can hold it, which forbids NaN and infinite positions: every triangle
/// with a non-finite corner (an inactive triangle, as DXR reads NaN) collapsed onto one
/// of its finite corners (or the mesh's first finite vertex), so that it keeps its place
/// and covers nothing, and every non-finite position replaced by a finite one. Returns
/// the mesh and how many triangles were collapsed.
fn without_non_finite(mesh: &TriMesh) -> (Cow<'_, TriMesh>, usize) {
    if mesh.positions.iter().all(|p| p.is_finite()) {
        return (Cow::Borrowed(mesh), 0);
    }
    let finite = |v: u32| {
        mesh.positions
            .get(v as usize)
            .is_some_and(|p| p.is_finite())
    };
    let first_finite = (0..mesh.positions.len() as u32)
        .find(|&v| finite(v))
        .unwrap_or(0);
    let mut out = mesh.clone();
    let mut collapsed = 0;
    for triangle in &mut out.triangles {
        if !triangle.iter().all(|&v| finite(v)) {
            let onto = triangle
                .iter()
                .copied()
                .find(|&v| finite(v))
                .unwrap_or(first_finite);
            *triangle = [onto; 3];
            collapsed += 1;
        }
    }
    let fill = mesh
        .positions
        .get(first_finite as usize)
        .copied()
        .filter(|p| p.is_finite());
    for p in &mut out.positions {
        if !p.is_finite() {
            *p = fill.unwrap_or(Vec3::ZERO);
        }
    }
    (Cow::Owned(out), collapsed)
}

/// `mesh` with its float skin weights summing to one on every vertex, as glTF asks
/// (files converted by other tools often break this); returns it and how many vertices
/// changed. All `WEIGHTS_n` sets of a vertex are scaled together.
fn with_normalized_weights(mesh: &TriMesh) -> (Cow<'_, TriMesh>, usize) {
    let sets: Vec<usize> = (0..mesh.attributes.len())
        .filter(|&a| {
            let attribute = &mesh.attributes[a];
            attribute.semantic() == Semantic::Weights
                && matches!(attribute.values, AttributeValues::F32(_))
        })
        .collect();
    // The weights of vertex `v` over every set, summed as the validator sums them.
    let sum = |mesh: &TriMesh, v: usize| -> f64 {
        sets.iter()
            .map(|&a| {
                let weights = &mesh.attributes[a];
                (0..weights.components)
                    .map(|c| weights.get(v, c))
                    .sum::<f64>()
            })
            .sum()
    };
    // The validator flags a sum 8 f32 ulps off; rounding leaves 2 or so.
    let off: Vec<usize> = (0..mesh.positions.len())
        .filter(|&v| {
            let s = sum(mesh, v);
            s > 0.0 && (s - 1.0).abs() > 2.5e-7
        })
        .collect();
    if off.is_empty() {
        return (Cow::Borrowed(mesh), 0);
    }
    let mut out = mesh.clone();
    for &v in &off {
        let scale = 1.0 / sum(mesh, v);
        let mut largest: Option<(usize, usize, f32)> = None;
        for &a in &sets {
            let k = out.attributes[a].components;
            if let AttributeValues::F32(values) = &mut out.attributes[a].values {
                for (c, x) in values[v * k..v * k + k].iter_mut().enumerate() {
                    *x = (*x as f64 * scale) as f32;
                    if largest.is_none_or(|(_, _, w)| *x > w) {
                        largest = Some((a, v * k + c, *x));
                    }
                }
            }
        }
        // What rounding left goes to the largest weight.
        let residual = 1.0 - sum(&out, v);
        if let Some((a, i, w)) = largest {
            if let AttributeValues::F32(values) = &mut out.attributes[a].values {
                values[i] = (w as f64 + residual) as f32;
            }
        }
    }
    let changed = off.len();
    (Cow::Owned(out), changed)
}

/// Whether glTF (with `KHR_mesh_quantization` where `quantized`) holds `attribute`'s
/// stored type under its semantic: float everywhere; for texture coordinates, colours
/// and weights unsigned bytes and shorts normalized; for joints unsigned bytes and
/// shorts; with the extension, the signed and unnormalized types it adds; for
/// application-specific attributes any type but unsigned int, which glTF keeps for
/// indices.
fn type_held(attribute: &VertexAttribute, quantized: bool) -> bool {
    use AttributeValues as V;
    let normalized = attribute.normalized;
    match (attribute.semantic(), &attribute.values) {
        // rtmesh writes these as f32 (glTF has no such component types).
        (_, V::F32(_) | V::I32(_) | V::F64(_)) => true,
        (_, V::U32(_)) => false,
        (Semantic::Custom | Semantic::Joints, _) => true,
        (Semantic::TexCoord | Semantic::Color | Semantic::Weights, V::U8(_) | V::U16(_))
            if normalized =>
        {
            true
        }
        (Semantic::TexCoord, _) => quantized,
        (Semantic::Normal | Semantic::Tangent, V::I8(_) | V::I16(_)) => quantized && normalized,
        (Semantic::MorphDelta, V::I8(_) | V::I16(_)) => quantized,
        _ => false,
    }
}

/// The attribute as glTF can hold it: a stored type glTF holds for its semantic
/// ([`type_held`]; others as the f32 numbers they stand for), unit normals and
/// tangents (xyz) and ±1 tangent handedness, finite floats; returns it and how many
/// vertices changed in value.
fn writable(attribute: &VertexAttribute, quantized: bool) -> (Cow<'_, VertexAttribute>, usize) {
    let attribute = match type_held(attribute, quantized) {
        true => Cow::Borrowed(attribute),
        false => Cow::Owned(attribute.to_f32()),
    };
    let unit = matches!(attribute.semantic(), Semantic::Normal | Semantic::Tangent);
    let AttributeValues::F32(values) = &attribute.values else {
        return (attribute, 0);
    };
    let k = attribute.components;
    let bad = |e: &[f32]| {
        e.iter().any(|x| !x.is_finite())
            || (unit && k >= 3 && (Vec3::from_slice(e).length() - 1.0).abs() > 1e-4)
            || (unit && k == 4 && e[3].abs() != 1.0)
    };
    if !values.chunks_exact(k).any(bad) {
        return (attribute, 0);
    }
    let mut out = attribute.into_owned();
    let mut changed = 0;
    if let AttributeValues::F32(values) = &mut out.values {
        for e in values.chunks_exact_mut(k) {
            if !bad(e) {
                continue;
            }
            changed += 1;
            for x in e.iter_mut().filter(|x| !x.is_finite()) {
                *x = 0.0;
            }
            if unit && k >= 3 {
                let n = Vec3::from_slice(e).try_normalize().unwrap_or(Vec3::Z);
                e[..3].copy_from_slice(&n.to_array());
            }
            if unit && k == 4 {
                e[3] = if e[3] < 0.0 { -1.0 } else { 1.0 };
            }
        }
    }
    (Cow::Owned(out), changed)
}

/// The glTF attribute name of a stream: its own, or `_NAME` for one from a format with
/// free names (glTF asks application-specific attributes to start with `_`).
fn gltf_name(attribute: &VertexAttribute) -> String {
    match attribute.semantic() {
        Semantic::Custom if !attribute.name.starts_with('_') => {
            format!("_{}", attribute.name.to_ascii_uppercase())
        }
        _ => attribute.name.clone(),
    }
}

fn semantic(name: &str) -> Checked<json::mesh::Semantic> {
    serde_json::from_value(value!(name)).unwrap_or(Checked::Invalid)
}

/// The stored type of source mesh `m`'s positions where its first triangle primitive
/// holds them quantized (`KHR_mesh_quantization`), as an empty stream of that type.
fn quantized_positions(document: &GltfDocument, m: usize) -> Option<VertexAttribute> {
    use json::accessor::ComponentType as C;
    let root = &document.root;
    let primitive = root
        .meshes
        .get(m)?
        .primitives
        .iter()
        .find(|p| is_triangles(p))?;
    let position = primitive
        .attributes
        .get(&Checked::Valid(json::mesh::Semantic::Positions))?;
    let accessor = root.accessors.get(position.value())?;
    let Checked::Valid(json::accessor::GenericComponentType(component)) = accessor.component_type
    else {
        return None;
    };
    let values = match component {
        C::I8 => AttributeValues::I8(vec![]),
        C::U8 => AttributeValues::U8(vec![]),
        C::I16 => AttributeValues::I16(vec![]),
        C::U16 => AttributeValues::U16(vec![]),
        _ => return None,
    };
    Some(VertexAttribute {
        name: "POSITION".to_owned(),
        components: 3,
        normalized: accessor.normalized,
        values,
        component_names: Vec::new(),
    })
}

/// Which nodes the scene rtmesh reads places (the default scene's, or the first's):
/// those under its roots.
fn traced_nodes(root: &json::Root) -> Vec<bool> {
    let mut traced = vec![false; root.nodes.len()];
    let scene = root.scene.map_or(0, |s| s.value());
    let Some(scene) = root.scenes.get(scene).or(root.scenes.first()) else {
        return traced;
    };
    let mut stack: Vec<usize> = scene.nodes.iter().map(|n| n.value()).collect();
    while let Some(n) = stack.pop() {
        match traced.get_mut(n) {
            Some(seen) if !*seen => *seen = true,
            _ => continue,
        }
        let children = root.nodes[n].children.iter().flatten();
        stack.extend(children.map(|c| c.value()));
    }
    traced
}

/// Whether `primitive` holds triangles (a list, a strip or a fan), which rtmesh reads;
/// other primitives (lines, points) are kept from the document as they are.
pub(crate) fn is_triangles(primitive: &json::mesh::Primitive) -> bool {
    use json::mesh::Mode;
    matches!(
        primitive.mode,
        Checked::Valid(Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan)
    )
}

/// The accessors and views of `source` that the rewritten primitives do not replace,
/// copied into `out`; returns the new index of every kept accessor. Renumbers the
/// references of images, skins and animation samplers in `root` (the output's copy of
/// the document).
fn keep_unchanged(
    source: &GltfDocument,
    root: &mut json::Root,
    out: &mut Output,
) -> Vec<Option<u32>> {
    let document = &source.root;
    let n = document.accessors.len();
    let mut replaced = vec![false; n];
    let mut needed = vec![false; n];
    for mesh in &document.meshes {
        for primitive in &mesh.primitives {
            let marks = if is_triangles(primitive) {
                &mut replaced
            } else {
                &mut needed
            };
            let targets = primitive.targets.iter().flatten();
            let accessors = primitive
                .attributes
                .values()
                .chain(&primitive.indices)
                .chain(
                    targets.flat_map(|t| t.positions.iter().chain(&t.normals).chain(&t.tangents)),
                );
            for a in accessors {
                if let Some(m) = marks.get_mut(a.value()) {
                    *m = true;
                }
            }
        }
    }
    for skin in &document.skins {
        if let Some(a) = skin.inverse_bind_matrices {
            needed[a.value().min(n.saturating_sub(1))] = true;
        }
    }
    for sampler in document.animations.iter().flat_map(|a| &a.samplers) {
        for a in [sampler.input, sampler.output] {
            if let Some(m) = needed.get_mut(a.value()) {
                *m = true;
            }
        }
    }
    let keep: Vec<bool> = (0..n).map(|a| !replaced[a] || needed[a]).collect();
    // Views: dropped only when every accessor that used them is dropped.
    let views = document.buffer_views.len();
    let mut used_by_kept = vec![false; views];
    let mut used_at_all = vec![false; views];
    for (a, accessor) in document.accessors.iter().enumerate() {
        let sparse = accessor
            .sparse
            .iter()
            .flat_map(|s| [s.indices.buffer_view, s.values.buffer_view]);
        for view in accessor.buffer_view.into_iter().chain(sparse) {
            if let Some(u) = used_at_all.get_mut(view.value()) {
                *u = true;
                used_by_kept[view.value()] |= keep[a];
            }
        }
    }
    for image in &document.images {
        if let Some(view) = image.buffer_view {
            if let Some(u) = used_by_kept.get_mut(view.value()) {
                *u = true;
            }
        }
    }
    let mut view_index = vec![None; views];
    for (v, view) in document.buffer_views.iter().enumerate() {
        if !used_by_kept[v] && used_at_all[v] {
            continue;
        }
        let bytes = source.view_bytes(view);
        let index = out.view(bytes, None, None);
        let copied = out.views.last_mut().expect("just added");
        *copied = json::buffer::View {
            buffer: Index::new(0),
            byte_offset: copied.byte_offset,
            ..view.clone()
        };
        view_index[v] = Some(index);
    }
    let remap_view = |v: Index<json::buffer::View>| view_index[v.value()].unwrap_or(v);
    let mut accessor_index = vec![None; n];
    for (a, accessor) in document.accessors.iter().enumerate() {
        if !keep[a] {
            continue;
        }
        let mut accessor = accessor.clone();
        accessor.buffer_view = accessor.buffer_view.map(remap_view);
        if let Some(sparse) = &mut accessor.sparse {
            sparse.indices.buffer_view = remap_view(sparse.indices.buffer_view);
            sparse.values.buffer_view = remap_view(sparse.values.buffer_view);
        }
        accessor_index[a] = Some(out.accessor(accessor).value() as u32);
    }
    let remap = |a: Index<json::Accessor>| {
        accessor_index
            .get(a.value())
            .copied()
            .flatten()
            .map_or(a, Index::new)
    };
    for image in &mut root.images {
        image.buffer_view = image.buffer_view.map(remap_view);
    }
    for skin in &mut root.skins {
        skin.inverse_bind_matrices = skin.inverse_bind_matrices.map(remap);
    }
    for sampler in root.animations.iter_mut().flat_map(|a| &mut a.samplers) {
        sampler.input = remap(sampler.input);
        sampler.output = remap(sampler.output);
    }
    accessor_index
}

/// A primitive of the source, its accessors renumbered (a point or line primitive,
/// copied as it was).
fn renumbered(primitive: &json::mesh::Primitive, index: &[Option<u32>]) -> json::mesh::Primitive {
    let remap = |a: &Index<json::Accessor>| {
        index
            .get(a.value())
            .copied()
            .flatten()
            .map_or(*a, Index::new)
    };
    let mut out = primitive.clone();
    out.attributes.values_mut().for_each(|a| *a = remap(a));
    out.indices = out.indices.as_ref().map(remap);
    for target in out.targets.iter_mut().flatten() {
        for a in [
            &mut target.positions,
            &mut target.normals,
            &mut target.tangents,
        ] {
            *a = a.as_ref().map(remap);
        }
    }
    out
}

/// The default primitive of a geometry without a source primitive: every stream, the
/// triangle's material where `root` has it (a glTF's primitives without one use the
/// reader's default material, which its document does not hold).
fn fresh_primitive(root: &json::Root, material: u32) -> json::mesh::Primitive {
    json::mesh::Primitive {
        attributes: BTreeMap::new(),
        extensions: None,
        extras: None,
        indices: None,
        material: ((material as usize) < root.materials.len()).then(|| Index::new(material)),
        mode: Checked::Valid(json::mesh::Mode::Triangles),
        targets: None,
    }
}

/// The document a scene from another format starts from: its materials, with their
/// textures and images for materials from an MTL library.
fn fresh_root(scene: &Scene) -> json::Root {
    let mut images: Vec<String> = Vec::new();
    let mut transformed = false;
    let mut texture = |map: &Option<crate::mesh::MtlMap>| {
        map.as_ref().map(|map| {
            let index = images
                .iter()
                .position(|i| *i == map.file)
                .unwrap_or_else(|| {
                    images.push(map.file.clone());
                    images.len() - 1
                });
            // OBJ's texture coordinates start at the image's bottom row, glTF's at its
            // top. The coordinates are written exactly as read (every attribute is kept
            // bit for bit), and the texture takes the flip, v' = 1 - v, after the map's
            // own placement uv·s + o: glTF's scale (s_u, -s_v), offset (o_u, 1 - o_v).
            let [su, sv] = map.scale;
            let [ou, ov] = map.offset;
            let (scale, offset) = ([su, -sv], [ou, 1.0 - ov]);
            if scale == [1.0, 1.0] && offset == [0.0, 0.0] {
                return value!({ "index": index });
            }
            transformed = true;
            value!({ "index": index, "extensions": { TEXTURE_TRANSFORM: {
                "offset": offset, "scale": scale } } })
        })
    };
    let materials = scene
        .materials
        .iter()
        .map(|m| {
            let mut material = value!({
                "name": m.name,
                "alphaMode": if m.alpha_tested { "MASK" } else { "OPAQUE" },
            });
            if let Some(look) = &m.mtl {
                material_from_mtl(&mut material, look, &mut texture);
            }
            serde_json::from_value(material).expect("a glTF material")
        })
        .collect();
    let textures = (0..images.len())
        .map(|i| serde_json::from_value(value!({ "source": i })).expect("a glTF texture"))
        .collect();
    let images: Vec<json::Image> = (images.iter())
        .map(|file| {
            let uri = crate::io::reference::percent_encode(file);
            serde_json::from_value(value!({ "uri": uri })).expect("a glTF image")
        })
        .collect();
    json::Root {
        extensions_used: transformed
            .then(|| TEXTURE_TRANSFORM.to_owned())
            .into_iter()
            .collect(),
        materials,
        textures,
        images,
        ..json::Root::default()
    }
}

/// Store each image whose file is among `images` (PNG or JPEG) in the buffer, in place
/// of its URI: a GLB is then one file.
fn embed_images(root: &mut json::Root, images: &[(String, Vec<u8>)], out: &mut Output) {
    for image in &mut root.images {
        let Some(file) = image
            .uri
            .as_deref()
            .and_then(crate::io::reference::percent_decode)
        else {
            continue;
        };
        let Some((_, bytes)) = images.iter().find(|(name, _)| *name == file) else {
            continue;
        };
        let Some(mime) = crate::io::side_files::embeddable_image_type(bytes) else {
            continue;
        };
        image.buffer_view = Some(out.view(bytes, None, None));
        image.mime_type = Some(json::image::MimeType(mime.to_owned()));
        image.uri = None;
    }
}

/// The glTF extension that flips an OBJ's texture coordinates for its textures.
const TEXTURE_TRANSFORM: &str = "KHR_texture_transform";

/// An MTL material's look in glTF's terms, as obj2gltf translates it: `Kd` and `d` are
/// the base colour (white under a `map_Kd`, which holds the colour itself), and the
/// surface is a rough dielectric (glTF's default, a smooth metal, would turn a diffuse
/// OBJ dark) unless MTL's PBR extension gives `Pm` and `Pr`, whose maps on one file are
/// the metallic-roughness texture; `Ke` is the emissive factor; the bump map becomes
/// the normal texture.
/// An opacity below 1 without a cut-out map is blended. MTL's specular terms and
/// `map_d` have no glTF place (glTF takes opacity from the base colour's alpha).
fn material_from_mtl(
    material: &mut serde_json::Value,
    look: &crate::mesh::MtlLook,
    texture: &mut dyn FnMut(&Option<crate::mesh::MtlMap>) -> Option<serde_json::Value>,
) {
    let [r, g, b] = match look.diffuse_map {
        Some(_) => [1.0; 3],
        None => look.diffuse,
    };
    let mut pbr = value!({
        "baseColorFactor": [r, g, b, look.dissolve.clamp(0.0, 1.0)],
        "metallicFactor": look.metallic.unwrap_or(0.0).clamp(0.0, 1.0),
        "roughnessFactor": look.roughness.unwrap_or(1.0).clamp(0.0, 1.0),
    });
    if let Some(base) = texture(&look.diffuse_map) {
        pbr["baseColorTexture"] = base;
    }
    if let Some(metallic_roughness) = texture(&look.metallic_roughness_map) {
        pbr["metallicRoughnessTexture"] = metallic_roughness;
    }
    material["pbrMetallicRoughness"] = pbr;
    if look.dissolve < 1.0 && !look.dissolve_map {
        material["alphaMode"] = value!("BLEND");
    }
    if look.emissive != [0.0; 3] {
        material["emissiveFactor"] = value!(look.emissive.map(|e| e.clamp(0.0, 1.0)));
    }
    if let Some(normal) = texture(&look.normal_map) {
        material["normalTexture"] = normal;
    }
    if let Some(emissive) = texture(&look.emissive_map) {
        material["emissiveTexture"] = emissive;
        if look.emissive == [0.0; 3] {
            material["emissiveFactor"] = value!([1.0, 1.0, 1.0]);
        }
    }
}

/// The geometry's streams written once each (lazily), shared by its primitives.
struct Streams<'a> {
    mesh: &'a TriMesh,
    accessor: Vec<Option<Index<json::Accessor>>>,
    position: Option<Index<json::Accessor>>,
    changed: usize,
    /// The output declares `KHR_mesh_quantization`.
    quantized: bool,
    /// The stored type of the source's quantized positions (an empty stream of it).
    position_stored: Option<VertexAttribute>,
}

impl<'a> Streams<'a> {
    fn new(mesh: &'a TriMesh, quantized: bool, position_stored: Option<VertexAttribute>) -> Self {
        Self {
            mesh,
            accessor: vec![None; mesh.attributes.len()],
            position: None,
            changed: 0,
            quantized,
            position_stored,
        }
    }

    /// The positions, in the source's quantized type where every one is held there
    /// exactly (as read, reordered or welded), else as f32 (moved by a repair or an
    /// animation).
    fn position(&mut self, out: &mut Output) -> Index<json::Accessor> {
        *self.position.get_or_insert_with(|| {
            let positions: Vec<[f32; 3]> =
                self.mesh.positions.iter().map(|p| p.to_array()).collect();
            let float = VertexAttribute::from_f32("POSITION", &positions);
            let stored = self
                .position_stored
                .as_ref()
                .and_then(|like| float.stored_as(like));
            out.attribute(stored.as_ref().unwrap_or(&float))
        })
    }

    fn stream(&mut self, out: &mut Output, name: &str) -> Option<Index<json::Accessor>> {
        let s = self.mesh.attributes.iter().position(|a| a.name == name)?;
        if self.accessor[s].is_none() {
            let (attribute, changed) = writable(&self.mesh.attributes[s], self.quantized);
            self.changed += changed;
            self.accessor[s] = Some(out.attribute(&attribute));
        }
        self.accessor[s]
    }
}

/// Write `scene` as glTF (`binary`: GLB) to `path`; a GLB stores the images among
/// `images` (file name, bytes) that it names by URI in its buffer.
pub(in crate::io) fn write(
    scene: &Scene,
    path: &Path,
    binary: bool,
    images: &[(String, Vec<u8>)],
) -> std::io::Result<WriteNotes> {
    write_with(scene, None, path, binary, images)
}

/// [`write`] with each geometry's triangles as `TRIANGLE_STRIP` primitives: `strips[m]`
/// holds the strips of `scene.meshes[m]`, all of them. glTF has no restart index, so
/// a primitive's strips are joined by degenerate triangles
/// ([`crate::strip::join_standard`]): two or three indices a join, smaller than a
/// primitive and an accessor per strip.
pub(in crate::io) fn write_strips(
    scene: &Scene,
    strips: &[crate::strip::Strips],
    path: &Path,
    binary: bool,
    images: &[(String, Vec<u8>)],
) -> std::io::Result<WriteNotes> {
    write_with(scene, Some(strips), path, binary, images)
}

fn write_with(
    scene: &Scene,
    strips: Option<&[crate::strip::Strips]>,
    path: &Path,
    binary: bool,
    images: &[(String, Vec<u8>)],
) -> std::io::Result<WriteNotes> {
    let source = match scene.document.as_deref() {
        Some(Document::Gltf(document)) => Some(document),
        _ => None,
    };
    let mut out = Output::default();
    let mut notes = WriteNotes::default();
    let (mut root, kept, group_sources) = match source {
        Some(document) => {
            let mut root = document.root.clone();
            let kept = keep_unchanged(document, &mut root, &mut out);
            (root, kept, document.group_sources())
        }
        None => (fresh_root(scene), Vec::new(), Vec::new()),
    };
    if binary {
        embed_images(&mut root, images, &mut out);
    }
    let quantized = root.extensions_used.iter().any(|e| e == QUANTIZATION);
    let source_meshes = source.map_or(0, |d| d.root.meshes.len());
    let mut other_primitives_written = vec![false; source_meshes];
    let mut meshes = Vec::new();
    // glTF has no empty mesh (a primitive needs vertices): a geometry without
    // triangles is left out, and nodes placing it keep no mesh.
    let mut gltf_mesh = vec![None; scene.meshes.len()];
    // The output mesh each source mesh became first: for the nodes of scenes rtmesh
    // does not trace, which keep placing theirs.
    let mut output_of_source: Vec<Option<u32>> = vec![None; source_meshes];
    for (index, mesh) in scene.meshes.iter().enumerate() {
        let (mesh, inactive) = without_non_finite(mesh);
        notes.inactive_collapsed += inactive;
        let (mesh, reweighted) = with_normalized_weights(&mesh);
        notes.weights_renormalized += reweighted;
        let from_group = |t: usize| group_sources.get(mesh.group_of(t) as usize).copied();
        let source_mesh = match mesh.triangles.is_empty() {
            false => from_group(0).map(|(m, _)| m),
            true => (source.is_some() && scene.meshes.len() == source_meshes).then_some(index),
        };
        let position_stored = source
            .zip(source_mesh)
            .and_then(|(d, m)| quantized_positions(d, m));
        let primitive_list = primitive_triangles(&mesh);
        let own = own_vertices(&mesh, &primitive_list);
        let mut shared = Streams::new(&mesh, quantized, position_stored.clone());
        let mut primitives = Vec::new();
        // Each primitive's strips, joined (a strip never spans two primitives).
        let strip_lists = strips.and_then(|all| all.get(index)).map(|strips| {
            let mut lists: BTreeMap<(u32, u32), Vec<Vec<u32>>> = BTreeMap::new();
            for (s, list) in strips.to_standard().into_iter().enumerate() {
                let t = strips.triangle_source[strips.triangles_of(s).start] as usize;
                let key = (
                    mesh.group_of(t),
                    mesh.material_ids.get(t).copied().unwrap_or(0),
                );
                lists.entry(key).or_default().push(list);
            }
            lists
                .into_iter()
                .map(|(key, lists)| (key, crate::strip::join_standard(&lists)))
                .collect::<BTreeMap<_, _>>()
        });
        for (p, triangles) in primitive_list.iter().enumerate() {
            let start = triangles[0] as usize;
            let mut own_streams = (own.as_ref())
                .map(|(meshes, _)| Streams::new(&meshes[p], quantized, position_stored.clone()));
            let streams = own_streams.as_mut().unwrap_or(&mut shared);
            let key = |t: usize| {
                (
                    mesh.group_of(t),
                    mesh.material_ids.get(t).copied().unwrap_or(0),
                )
            };
            let template = source
                .zip(from_group(start))
                .map(|(d, (m, p))| &d.root.meshes[m].primitives[p]);
            let mut primitive = match template {
                Some(template) => json::mesh::Primitive {
                    attributes: BTreeMap::new(),
                    indices: None,
                    mode: Checked::Valid(json::mesh::Mode::Triangles),
                    targets: None,
                    ..template.clone()
                },
                None => fresh_primitive(&root, key(start).1),
            };
            primitive.attributes.insert(
                Checked::Valid(json::mesh::Semantic::Positions),
                streams.position(&mut out),
            );
            match template {
                Some(template) => {
                    for name in template.attributes.keys().map(|s| s.to_string()) {
                        if let Some(accessor) = streams.stream(&mut out, &name) {
                            primitive.attributes.insert(semantic(&name), accessor);
                        }
                    }
                    if let Some(targets) = &template.targets {
                        let mut written = Vec::with_capacity(targets.len());
                        for (k, target) in targets.iter().enumerate() {
                            let mut stream = |present: bool, name: &str| {
                                present
                                    .then(|| {
                                        streams.stream(&mut out, &crate::mesh::morph_name(k, name))
                                    })
                                    .flatten()
                            };
                            written.push(json::mesh::MorphTarget {
                                positions: stream(target.positions.is_some(), "POSITION"),
                                normals: stream(target.normals.is_some(), "NORMAL"),
                                tangents: stream(target.tangents.is_some(), "TANGENT"),
                            });
                        }
                        primitive.targets = Some(written);
                    }
                }
                None => {
                    let names: Vec<(String, String)> = mesh
                        .attributes
                        .iter()
                        .filter(|a| !a.name.starts_with(MORPH_PREFIX))
                        .map(|a| (a.name.clone(), gltf_name(a)))
                        .collect();
                    for (name, written) in names {
                        if let Some(accessor) = streams.stream(&mut out, &name) {
                            primitive.attributes.insert(semantic(&written), accessor);
                        }
                    }
                }
            }
            let mut list: Vec<u32> = match strip_lists.as_ref().and_then(|l| l.get(&key(start))) {
                Some(list) => {
                    primitive.mode = Checked::Valid(json::mesh::Mode::TriangleStrip);
                    list.clone()
                }
                None => triangles
                    .iter()
                    .flat_map(|&t| mesh.triangles[t as usize])
                    .collect(),
            };
            if let Some((_, local)) = &own {
                for v in &mut list {
                    *v = local[*v as usize];
                }
            }
            primitive.indices = Some(indices(&mut out, &list, streams.mesh.positions.len()));
            primitives.push(primitive);
            notes.normals_renormalized += own_streams.map_or(0, |s| s.changed);
        }
        notes.normals_renormalized += shared.changed;
        if let (Some(document), Some(m)) = (source, source_mesh) {
            if !std::mem::replace(&mut other_primitives_written[m], true) {
                primitives.extend(
                    document.root.meshes[m]
                        .primitives
                        .iter()
                        .filter(|p| !is_triangles(p))
                        .map(|p| renumbered(p, &kept)),
                );
            }
        }
        if primitives.is_empty() {
            continue;
        }
        let mut gltf = match source.zip(source_mesh) {
            Some((document, m)) => document.root.meshes[m].clone(),
            None => serde_json::from_value(value!({"primitives": []})).expect("an empty mesh"),
        };
        gltf.name = (!mesh.name.is_empty()).then(|| mesh.name.clone());
        let targets = primitives
            .first()
            .and_then(|p| p.targets.as_ref())
            .map_or(0, Vec::len);
        if gltf.weights.as_ref().is_some_and(|w| w.len() != targets) {
            gltf.weights = None;
        }
        gltf.primitives = primitives;
        gltf_mesh[index] = Some(meshes.len() as u32);
        if let Some(m) = source_mesh.filter(|&m| m < source_meshes) {
            output_of_source[m].get_or_insert(meshes.len() as u32);
        }
        meshes.push(gltf);
    }
    place(
        scene,
        &mut root,
        &gltf_mesh,
        &output_of_source,
        source.is_some(),
    );
    root.meshes = meshes;
    root.accessors = out.accessors;
    root.buffer_views = out.views;
    while !out.bin.len().is_multiple_of(4) {
        out.bin.push(0);
    }
    root.buffers = Vec::new();
    if !out.bin.is_empty() {
        let uri = (!binary).then(|| {
            path.with_extension("bin")
                .file_name()
                .and_then(|n| n.to_str())
                .unwrap_or("buffer.bin")
                .to_owned()
        });
        root.buffers.push(json::Buffer {
            byte_length: USize64::from(out.bin.len()),
            name: None,
            uri,
            extensions: None,
            extras: None,
        });
    }
    if source.is_none() {
        root.asset.generator = Some(super::GENERATOR.into());
    }
    let json_bytes = json::serialize::to_vec(&root).map_err(std::io::Error::other)?;
    if binary {
        let mut json_padded = json_bytes;
        while json_padded.len() % 4 != 0 {
            json_padded.push(b' ');
        }
        let glb = gltf::binary::Glb {
            header: gltf::binary::Header {
                magic: *b"glTF",
                version: 2,
                length: 0,
            },
            json: Cow::Owned(json_padded),
            bin: (!out.bin.is_empty()).then_some(Cow::Owned(out.bin)),
        };
        let file = std::io::BufWriter::new(std::fs::File::create(path)?);
        glb.to_writer(file)
            .map_err(|e| std::io::Error::other(e.to_string()))?;
    } else {
        if !out.bin.is_empty() {
            std::fs::write(path.with_extension("bin"), &out.bin)?;
        }
        std::fs::write(path, json_bytes)?;
    }
    Ok(notes)
}

/// The triangles of each output primitive: one per (group, material), in order of
/// first appearance, each listing its triangles in mesh order. (One per run would keep
/// the order across primitives too, but after bisection or pairing the runs are
/// short, and thousands of primitives over one vertex buffer are thousands of draws.)
fn primitive_triangles(mesh: &TriMesh) -> Vec<Vec<u32>> {
    let mut index: std::collections::HashMap<(u32, u32), usize> = Default::default();
    let mut out: Vec<Vec<u32>> = Vec::new();
    for t in 0..mesh.triangle_count() {
        let key = (
            mesh.group_of(t),
            mesh.material_ids.get(t).copied().unwrap_or(0),
        );
        let i = *index.entry(key).or_insert_with(|| {
            out.push(Vec::new());
            out.len() - 1
        });
        out[i].push(t as u32);
    }
    out
}

/// Each primitive's own vertices, where every vertex is used by exactly one primitive
/// (as a glTF's primitives read, and as rtmesh's transforms keep them): the mesh of
/// each primitive's vertices, in their order, with its triangles, and every vertex's
/// index within its primitive. Each primitive then gets streams of its own vertices,
/// so that an importer that takes a primitive as a mesh (assimp, an engine's skinning
/// per draw) sees its vertices, bounds and joints alone rather than the geometry's;
/// it costs no byte, since no vertex is written twice. `None` for one primitive, or
/// where a vertex is shared or unused: the primitives then share the geometry's
/// streams (splitting would copy shared vertices and drop unused ones).
fn own_vertices(mesh: &TriMesh, primitives: &[Vec<u32>]) -> Option<(Vec<TriMesh>, Vec<u32>)> {
    if primitives.len() < 2 {
        return None;
    }
    const UNUSED: u32 = u32::MAX;
    let mut owner = vec![UNUSED; mesh.positions.len()];
    for (p, triangles) in primitives.iter().enumerate() {
        for &t in triangles {
            for v in mesh.triangles[t as usize] {
                match owner[v as usize] {
                    UNUSED => owner[v as usize] = p as u32,
                    q if q == p as u32 => {}
                    _ => return None,
                }
            }
        }
    }
    if owner.contains(&UNUSED) {
        return None;
    }
    let mut sources = vec![Vec::new(); primitives.len()];
    let mut local = vec![0; mesh.positions.len()];
    for (v, &p) in owner.iter().enumerate() {
        local[v] = sources[p as usize].len() as u32;
        sources[p as usize].push(v as u32);
    }
    let meshes = (primitives.iter().zip(&sources))
        .map(|(triangles, sources)| {
            let mut own = TriMesh {
                name: mesh.name.clone(),
                positions: sources
                    .iter()
                    .map(|&v| mesh.positions[v as usize])
                    .collect(),
                triangles: (triangles.iter())
                    .map(|&t| mesh.triangles[t as usize].map(|v| local[v as usize]))
                    .collect(),
                attributes: mesh.attributes.iter().map(|a| a.gather(sources)).collect(),
                ..TriMesh::default()
            };
            own.take_triangle_data(mesh, triangles);
            own
        })
        .collect();
    Some((meshes, local))
}

/// An index accessor for the flat index list `list` (u16 when the vertices allow, else
/// u32).
fn indices(out: &mut Output, list: &[u32], vertices: usize) -> Index<json::Accessor> {
    use json::accessor::ComponentType as C;
    let (component, bytes): (C, Vec<u8>) = if vertices <= u16::MAX as usize {
        (
            C::U16,
            list.iter()
                .flat_map(|&v| (v as u16).to_le_bytes())
                .collect(),
        )
    } else {
        (C::U32, list.iter().flat_map(|v| v.to_le_bytes()).collect())
    };
    let view = out.view(&bytes, None, Some(json::buffer::Target::ElementArrayBuffer));
    out.accessor(json::Accessor {
        buffer_view: Some(view),
        byte_offset: None,
        count: USize64::from(list.len()),
        component_type: Checked::Valid(json::accessor::GenericComponentType(component)),
        extensions: None,
        extras: None,
        type_: Checked::Valid(json::accessor::Type::Scalar),
        min: None,
        max: None,
        name: None,
        normalized: false,
        sparse: None,
    })
}

/// The nodes: with a source document, its nodes as they were, each given back the
/// output mesh of the instance it placed (a node whose geometry became several gets a
/// child node per extra one, with its skin); instances rtmesh made (merged geometries,
/// transforms baked in) become new root nodes. Without one: one root node per instance.
/// A node outside the scene rtmesh traces (another scene's, or in none) places the
/// output mesh its source mesh became first (`output_of_source`), as it did.
fn place(
    scene: &Scene,
    root: &mut json::Root,
    gltf_mesh: &[Option<u32>],
    output_of_source: &[Option<u32>],
    from_source: bool,
) {
    let source_nodes = if from_source { root.nodes.len() } else { 0 };
    let had_mesh: Vec<bool> = root.nodes.iter().map(|n| n.mesh.is_some()).collect();
    let traced = traced_nodes(root);
    for (n, node) in root.nodes.iter_mut().enumerate() {
        let source_mesh = node.mesh.map(|m| m.value());
        node.mesh = match traced.get(n) {
            Some(false) if n < source_nodes => source_mesh
                .and_then(|m| output_of_source.get(m).copied().flatten())
                .map(Index::new),
            _ => None,
        };
    }
    let mut has_mesh = vec![false; source_nodes];
    let mut new_roots = Vec::new();
    for instance in &scene.instances {
        let Some(mesh) = gltf_mesh[instance.mesh] else {
            continue;
        };
        let mesh = Some(Index::new(mesh));
        match instance
            .source_node
            .map(|n| n as usize)
            .filter(|&n| n < source_nodes)
        {
            Some(n) if !has_mesh[n] => {
                root.nodes[n].mesh = mesh;
                has_mesh[n] = true;
            }
            Some(n) => {
                let child = json::Node {
                    mesh,
                    skin: root.nodes[n].skin,
                    ..json::Node::default()
                };
                root.nodes.push(child);
                let index = Index::new(root.nodes.len() as u32 - 1);
                root.nodes[n]
                    .children
                    .get_or_insert_with(Vec::new)
                    .push(index);
            }
            None => {
                let matrix = (instance.transform != Affine3A::IDENTITY)
                    .then(|| Mat4::from(instance.transform).to_cols_array());
                root.nodes.push(json::Node {
                    mesh,
                    matrix,
                    ..json::Node::default()
                });
                new_roots.push(Index::new(root.nodes.len() as u32 - 1));
            }
        }
    }
    // A node whose geometry was left out keeps no skin or morph weights.
    for n in 0..source_nodes {
        if had_mesh[n] && !has_mesh[n] {
            root.nodes[n].skin = None;
            root.nodes[n].weights = None;
        }
    }
    if new_roots.is_empty() {
        return;
    }
    let scene_index = root.scene.map_or(0, |s| s.value());
    if root.scenes.is_empty() {
        root.scenes
            .push(serde_json::from_value(value!({"nodes": []})).expect("an empty scene"));
        root.scene = Some(Index::new(0));
    }
    let target = scene_index.min(root.scenes.len() - 1);
    root.scenes[target].nodes.extend(new_roots);
}

//! glTF 2.0 and GLB through the gltf crate. Each glTF mesh becomes one geometry (its
//! triangle primitives in order, each triangle's group naming its primitive, materials
//! per triangle, every vertex attribute and morph-target delta kept as the typed values
//! stored); each node that holds a mesh becomes an instance with its world transform;
//! `alphaMode` MASK or BLEND marks a material alpha-tested. Triangle strips and fans
//! are turned into triangles; point and line primitives are not triangles, so they are
//! left in the document, which the scene keeps whole ([`GltfDocument`]) for the writer
//! (`write.rs`). Every accessor is bounds-checked against its buffer before it is read,
//! so a lying file is an error, not a panic.

mod meshopt;
mod mtl;
mod write;

pub(crate) use mtl::{mtl_library, MtlLibrary};
pub(super) use write::{is_triangles, write, write_strips};

use super::{CountingReader, MeshError};
use crate::mesh::{
    morph_name, AttributeValues, Instance, Material, Scene, TriMesh, VertexAttribute,
};
use glam::{Affine3A, DMat4, Mat4, Vec3};
use gltf::json;
use gltf::mesh::Mode;
use std::io::BufRead;
use std::path::Path;

pub(super) fn read<R: BufRead>(
    path: &Path,
    mut reader: CountingReader<'_, R>,
    root: &Path,
) -> Result<Scene, MeshError> {
    let bytes = reader.read_all(path)?;
    if bytes.starts_with(b"glTF") {
        // The gltf crate subtracts the header size from the declared length unchecked.
        let declared = bytes
            .get(8..12)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
        if !declared.is_some_and(|n| (12..=bytes.len()).contains(&n)) {
            return Err(MeshError::invalid(
                path,
                match declared {
                    Some(n) => format!(
                        "GLB header declares length {n} but the file has {} bytes",
                        bytes.len()
                    ),
                    None => format!("{} bytes: too short for a GLB header", bytes.len()),
                },
            ));
        }
    }
    // The gltf crate's validator indexes the POSITION accessor before checking that it
    // exists, and never checks animation channels' targets, which its accessors then
    // unwrap (panics found by fuzzing), so check those references first.
    let unvalidated = gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| MeshError::invalid(path, e.to_string()))?;
    check_unvalidated_references(unvalidated.as_json()).map_err(|e| MeshError::invalid(path, e))?;
    let gltf::Gltf { document, blob } = unvalidated;
    let document = validated(document).map_err(|e| MeshError::invalid(path, e))?;
    let quantized = document.extensions_used().any(|e| e == QUANTIZATION);
    let mut buffers = read_buffers(path, &document, blob, root)?;
    let document = match document.extensions_used().any(|e| e == meshopt::MESHOPT) {
        true => meshopt::decode(document, &mut buffers).map_err(|e| MeshError::invalid(path, e))?,
        false => document,
    };
    let mut budget = ReadBudget::new(buffers.iter().map(|b| b.0.len()).sum());

    let mut scene = Scene {
        materials: document
            .materials()
            .map(|m| Material {
                name: m.name().unwrap_or_default().to_owned(),
                alpha_tested: m.alpha_mode() != gltf::material::AlphaMode::Opaque,
                mtl: None,
            })
            .collect(),
        ..Scene::default()
    };
    let default_material = scene.materials.len() as u32;
    scene.materials.push(Material::default());

    // Groups number the primitives over the whole file, in mesh order.
    let mut group = 0u32;
    for mesh in document.meshes() {
        let mut out = TriMesh {
            name: mesh.name().unwrap_or_default().to_owned(),
            ..TriMesh::default()
        };
        // The accessors of the last primitive read, and where its vertices start:
        // primitives with the same accessors share vertices.
        let mut shared: Option<(Vec<usize>, u32)> = None;
        for (p, primitive) in mesh.primitives().enumerate() {
            let g = group;
            group += 1;
            let context = |what: &str| {
                format!(
                    "mesh {} ('{}') primitive {p}: {what}",
                    mesh.index(),
                    mesh.name().unwrap_or_default()
                )
            };
            if !matches!(
                primitive.mode(),
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                continue;
            }
            let Some(position_accessor) = primitive.get(&gltf::Semantic::Positions) else {
                return Err(MeshError::invalid(path, context("no POSITION attribute")));
            };
            use gltf::accessor::{DataType, Dimensions};
            check_accessor(&position_accessor, &buffers)
                .map_err(|e| MeshError::invalid(path, context(&e)))?;
            let position_type = (
                position_accessor.data_type(),
                position_accessor.dimensions(),
            );
            let integer = matches!(
                position_type.0,
                DataType::I8 | DataType::U8 | DataType::I16 | DataType::U16
            );
            if position_type != (DataType::F32, Dimensions::Vec3)
                && !(quantized && integer && position_type.1 == Dimensions::Vec3)
            {
                return Err(MeshError::invalid(
                    path,
                    context(match quantized {
                        true => "POSITION must be a float, byte or short VEC3 accessor",
                        false => "POSITION must be a float VEC3 accessor (integers need KHR_mesh_quantization)",
                    }),
                ));
            }
            if let Some(indices) = primitive.indices() {
                check_accessor(&indices, &buffers)
                    .map_err(|e| MeshError::invalid(path, context(&e)))?;
                let integer = matches!(
                    indices.data_type(),
                    DataType::U8 | DataType::U16 | DataType::U32
                );
                if !integer || indices.dimensions() != Dimensions::Scalar {
                    return Err(MeshError::invalid(
                        path,
                        context("indices must be an unsigned integer SCALAR accessor"),
                    ));
                }
            }
            let mut streams: Vec<(String, gltf::Accessor)> = primitive
                .attributes()
                .filter(|(semantic, _)| *semantic != gltf::Semantic::Positions)
                .map(|(semantic, accessor)| (semantic.to_string(), accessor))
                .collect();
            for (k, target) in primitive.morph_targets().enumerate() {
                for (name, accessor) in [
                    ("POSITION", target.positions()),
                    ("NORMAL", target.normals()),
                    ("TANGENT", target.tangents()),
                ] {
                    if let Some(accessor) = accessor {
                        streams.push((morph_name(k, name), accessor));
                    }
                }
            }
            let signature: Vec<usize> = std::iter::once(position_accessor.index())
                .chain(streams.iter().map(|(_, a)| a.index()))
                .collect();
            let data = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let base = match &shared {
                Some((accessors, base)) if *accessors == signature => *base,
                _ => {
                    let base = out.positions.len() as u32;
                    let count = position_accessor.count();
                    let vertex_bytes: usize = std::iter::once(position_accessor.size())
                        .chain(streams.iter().map(|(_, a)| a.size()))
                        .sum();
                    budget
                        .take(count.saturating_mul(vertex_bytes), || {
                            context("its vertices")
                        })
                        .map_err(|e| MeshError::invalid(path, e))?;
                    // Dense floats through the gltf crate's reader, lazily; sparse or
                    // quantized ones as the numbers their values stand for.
                    let dense_f32 =
                        position_type.0 == DataType::F32 && position_accessor.sparse().is_none();
                    let dense = match dense_f32 {
                        true => Some(data.read_positions().ok_or_else(|| {
                            MeshError::invalid(path, context("unreadable POSITION"))
                        })?),
                        false => None,
                    };
                    let stored = match dense_f32 {
                        true => None,
                        false => Some(
                            read_attribute("POSITION", &position_accessor, &buffers)
                                .map_err(|e| MeshError::invalid(path, context(&e)))?,
                        ),
                    };
                    let numbers = stored.iter().flat_map(|p| {
                        (0..p.vertex_count())
                            .map(|v| Vec3::from_array([0, 1, 2].map(|c| p.value(v, c) as f32)))
                    });
                    let positions = dense
                        .into_iter()
                        .flatten()
                        .map(Vec3::from_array)
                        .chain(numbers);
                    let mut read = Vec::with_capacity(streams.len());
                    for (name, accessor) in &streams {
                        // Counted before reading: the budget was taken for `count`.
                        if accessor.count() != count {
                            return Err(MeshError::invalid(
                                path,
                                context(&format!(
                                    "{name} has {} elements but POSITION has {count}",
                                    accessor.count()
                                )),
                            ));
                        }
                        let attribute = read_attribute(name, accessor, &buffers)
                            .map_err(|e| MeshError::invalid(path, context(&e)))?;
                        read.push(attribute);
                    }
                    out.extend_vertices(positions, read);
                    shared = Some((signature, base));
                    base
                }
            };
            // A primitive without indices makes one u32 corner per vertex.
            let corner_bytes = primitive
                .indices()
                .map_or(4 * position_accessor.count(), |i| {
                    i.count().saturating_mul(i.size())
                });
            budget
                .take(corner_bytes, || context("its corners"))
                .map_err(|e| MeshError::invalid(path, e))?;
            let corners: Vec<u32> = match data.read_indices() {
                Some(indices) => indices.into_u32().collect(),
                None => (0..position_accessor.count() as u32).collect(),
            };
            let (triangles, dropped) = assemble(primitive.mode(), &corners);
            scene.read_notes.strip_degenerates_dropped += dropped;
            let material = primitive
                .material()
                .index()
                .map_or(default_material, |m| m as u32);
            let alpha = scene.materials[material as usize].alpha_tested;
            out.triangles
                .extend(triangles.iter().map(|t| t.map(|v| v.saturating_add(base))));
            out.material_ids
                .extend(std::iter::repeat_n(material, triangles.len()));
            out.alpha_tested
                .extend(std::iter::repeat_n(alpha, triangles.len()));
            out.group_ids
                .extend(std::iter::repeat_n(g, triangles.len()));
        }
        scene.meshes.push(out);
    }

    let roots: Vec<gltf::Node> = match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(s) => s.nodes().collect(),
        None => Vec::new(),
    };
    scene.instances = place_nodes(path, &document, &roots)?;
    if scene.instances.is_empty() {
        // No scene graph: show every mesh once, untransformed.
        scene.instances = (0..scene.meshes.len())
            .map(|mesh| Instance::new(mesh, Affine3A::IDENTITY))
            .collect();
    }
    scene.document = Some(std::sync::Arc::new(super::Document::Gltf(Box::new(
        GltfDocument {
            root: document.into_json(),
            buffers: buffers.into_iter().map(|b| b.0).collect(),
        },
    ))));
    Ok(scene)
}

/// A glTF file as read: the whole JSON document and the data of its buffers, for the
/// writer to carry over everything rtmesh does not change.
#[derive(Clone, Debug)]
pub struct GltfDocument {
    pub(crate) root: gltf::json::Root,
    pub(crate) buffers: Vec<Vec<u8>>,
}

impl GltfDocument {
    /// The JSON document as read.
    pub fn root(&self) -> &gltf::json::Root {
        &self.root
    }

    /// The data of each buffer.
    pub fn buffers(&self) -> &[Vec<u8>] {
        &self.buffers
    }

    /// The document's looks alone: its materials, textures, samplers and images (those
    /// stored in the file copied into one buffer), the extensions they use, and the
    /// asset's copyright; no meshes, nodes, skins or animations. For a geometry that
    /// no longer matches the document's meshes (an animated frame baked into one mesh)
    /// but keeps its material ids, so that the writer gives it the same materials.
    pub fn looks(&self) -> Self {
        let source = &self.root;
        let mut bin = Vec::new();
        let mut buffer_views = Vec::new();
        let mut images = source.images.clone();
        for image in &mut images {
            let Some(view) = image
                .buffer_view
                .and_then(|v| source.buffer_views.get(v.value()))
            else {
                image.buffer_view = None;
                continue;
            };
            let bytes = self.view_bytes(view);
            buffer_views.push(json::buffer::View {
                buffer: json::Index::new(0),
                byte_length: json::validation::USize64::from(bytes.len()),
                byte_offset: Some(json::validation::USize64::from(bin.len())),
                byte_stride: None,
                target: None,
                name: view.name.clone(),
                extensions: None,
                extras: None,
            });
            image.buffer_view = Some(json::Index::new(buffer_views.len() as u32 - 1));
            bin.extend_from_slice(bytes);
            // Views start on 4-byte boundaries.
            bin.resize(bin.len().next_multiple_of(4), 0);
        }
        let mut root = json::Root {
            asset: json::Asset {
                copyright: source.asset.copyright.clone(),
                generator: Some(GENERATOR.into()),
                ..json::Asset::default()
            },
            materials: source.materials.clone(),
            textures: source.textures.clone(),
            samplers: source.samplers.clone(),
            images,
            buffer_views,
            ..json::Root::default()
        };
        if !bin.is_empty() {
            root.buffers.push(json::Buffer {
                byte_length: json::validation::USize64::from(bin.len()),
                name: None,
                uri: None,
                extensions: None,
                extras: None,
            });
        }
        let mut used = Vec::new();
        let looks = [
            serde_json::to_value(&root.materials),
            serde_json::to_value(&root.textures),
            serde_json::to_value(&root.samplers),
            serde_json::to_value(&root.images),
        ];
        for value in looks.iter().flatten() {
            extensions_named(value, &mut used);
        }
        root.extensions_used = (source.extensions_used.iter())
            .filter(|e| used.contains(e))
            .cloned()
            .collect();
        root.extensions_required = (source.extensions_required.iter())
            .filter(|e| used.contains(e))
            .cloned()
            .collect();
        Self {
            root,
            buffers: vec![bin],
        }
    }

    /// The bytes of `view` within its buffer (none where they lie outside it).
    pub fn view_bytes(&self, view: &gltf::json::buffer::View) -> &[u8] {
        let start = view.byte_offset.map_or(0, |o| o.0 as usize);
        let end = start.saturating_add(view.byte_length.0 as usize);
        (self.buffers.get(view.buffer.value()))
            .and_then(|b| b.get(start..end))
            .unwrap_or_default()
    }

    /// The (mesh, primitive) of every group, in the reader's numbering.
    pub(crate) fn group_sources(&self) -> Vec<(usize, usize)> {
        self.root
            .meshes
            .iter()
            .enumerate()
            .flat_map(|(m, mesh)| (0..mesh.primitives.len()).map(move |p| (m, p)))
            .collect()
    }
}

/// The `asset.generator` of a document rtmesh makes.
pub(super) const GENERATOR: &str = concat!("rtmesh ", env!("CARGO_PKG_VERSION"));

/// Every key of an `extensions` object anywhere in `value`, added to `names`.
fn extensions_named(value: &serde_json::Value, names: &mut Vec<String>) {
    match value {
        serde_json::Value::Object(object) => {
            for (key, inner) in object {
                if let (true, Some(extensions)) = (key == "extensions", inner.as_object()) {
                    names.extend(extensions.keys().cloned());
                }
                extensions_named(inner, names);
            }
        }
        serde_json::Value::Array(items) => {
            for item in items {
                extensions_named(item, names);
            }
        }
        _ => {}
    }
}

/// `KHR_mesh_quantization`: integer positions, normals, tangents and texture
/// coordinates, read as the numbers they stand for and written back in their type.
pub(super) const QUANTIZATION: &str = "KHR_mesh_quantization";

/// Whether a required extension leaves the geometry alone (materials, textures,
/// lights), so that rtmesh may trace a file that requires it: the document keeps it,
/// and writes it back, whether or not the gltf crate knows it.
fn leaves_geometry_alone(extension: &str) -> bool {
    ["KHR_materials_", "KHR_texture_", "EXT_texture_"]
        .iter()
        .any(|prefix| extension.starts_with(prefix))
        || matches!(extension, "KHR_lights_punctual" | "MSFT_texture_dds")
}

/// The document validated by the gltf crate, except that the extensions it may
/// require are rtmesh's rule, not the crate's: `KHR_mesh_quantization` (read here),
/// `EXT_meshopt_compression` (decoded, `meshopt.rs`) and those that leave the geometry
/// alone ([`leaves_geometry_alone`]); any other (Draco, GPU instancing) is an error
/// naming it, since tracing without it would measure the wrong geometry.
fn validated(document: gltf::Document) -> Result<gltf::Document, String> {
    let mut json = document.into_json();
    if let Some(unknown) = (json.extensions_required.iter()).find(|e| {
        ![QUANTIZATION, meshopt::MESHOPT].contains(&e.as_str()) && !leaves_geometry_alone(e)
    }) {
        return Err(format!(
            "the file requires the extension {unknown}, which rtmesh cannot read (of the \
             extensions that change geometry it reads {QUANTIZATION} and {}); write the file \
             without it first",
            meshopt::MESHOPT
        ));
    }
    let required = std::mem::take(&mut json.extensions_required);
    let mut json = gltf::Document::from_json(json)
        .map_err(|e| e.to_string())?
        .into_json();
    json.extensions_required = required;
    Ok(gltf::Document::from_json_without_validation(json))
}

/// The values of a vertex attribute accessor (checked first), in its stored type.
fn read_attribute(
    name: &str,
    accessor: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
) -> Result<VertexAttribute, String> {
    use gltf::accessor::Dimensions;
    check_accessor(accessor, buffers)?;
    let components = match accessor.dimensions() {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        other => {
            return Err(format!(
                "attribute {name} (accessor {}) is a {other:?}; vertex attributes rtmesh keeps are SCALAR or VEC2..4",
                accessor.index()
            ))
        }
    };
    let size = accessor.data_type().size();
    let element = size * components;
    let count = accessor.count();
    // A sparse accessor's elements are packed into bytes of their own (from its view,
    // or zeros) and substituted there; any other is read from its view where it lies.
    // Each element's bytes where the view holds them (checked to lie within it).
    let stored = accessor.view().map(|view| {
        let data = &buffers[view.buffer().index()].0;
        let stride = view.stride().unwrap_or(element);
        let start = view.offset() + accessor.offset();
        (0..count).map(move |i| &data[start + i * stride..][..element])
    });
    let values = match accessor.sparse() {
        None => {
            let elements = stored.expect("checked: a dense accessor has a view");
            typed_values(
                accessor.data_type(),
                elements.flat_map(|e| e.chunks_exact(size)),
            )
        }
        Some(sparse) => {
            let mut dense = vec![0u8; count * element];
            for (to, from) in dense
                .chunks_exact_mut(element)
                .zip(stored.into_iter().flatten())
            {
                to.copy_from_slice(from);
            }
            let (indices, values) = (sparse.indices(), sparse.values());
            let index_size = sparse_index_size(&indices);
            let index_data = &buffers[indices.view().buffer().index()].0;
            let index_start = indices.view().offset() + indices.offset();
            let value_data = &buffers[values.view().buffer().index()].0;
            let value_start = values.view().offset() + values.offset();
            for k in 0..sparse.count() {
                let at = index_start + k * index_size;
                let index = (index_data[at..at + index_size].iter().rev())
                    .fold(0usize, |n, &b| n << 8 | b as usize);
                if index >= count {
                    return Err(format!(
                        "accessor {}: sparse index {index} (entry {k}) is past its {count} elements",
                        accessor.index()
                    ));
                }
                let from = value_start + k * element;
                dense[index * element..(index + 1) * element]
                    .copy_from_slice(&value_data[from..from + element]);
            }
            typed_values(accessor.data_type(), dense.chunks_exact(size))
        }
    };
    Ok(VertexAttribute {
        name: name.to_owned(),
        components,
        normalized: accessor.normalized(),
        values,
        component_names: Vec::new(),
    })
}

/// The data of every buffer: the GLB's binary chunk, a `data:` URI decoded in memory, or
/// a file read by the rule for references (`reference.rs`); each at least as long as
/// the buffer declares.
fn read_buffers(
    path: &Path,
    document: &gltf::Document,
    mut blob: Option<Vec<u8>>,
    root: &Path,
) -> Result<Vec<gltf::buffer::Data>, MeshError> {
    use super::reference::{percent_decode, read_referenced, MAX_REFERENCED_BYTES};
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let context =
            |what: String| MeshError::invalid(path, format!("buffer {}: {what}", buffer.index()));
        let mut data = match buffer.source() {
            // Its views are decoded from other buffers (`meshopt.rs`).
            gltf::buffer::Source::Bin if meshopt::is_fallback(&buffer) => {
                buffers.push(gltf::buffer::Data(Vec::new()));
                continue;
            }
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                context("refers to a GLB binary chunk the file does not have".into())
            })?,
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                // Base64 takes 4 bytes per 3.
                if uri.len() as u64 > MAX_REFERENCED_BYTES / 3 * 4 + 1024 {
                    return Err(context(format!(
                        "its data: URI has {} bytes, over the limit of {MAX_REFERENCED_BYTES} decoded",
                        uri.len()
                    )));
                }
                gltf::buffer::Data::from_source(buffer.source(), None)
                    .map_err(|e| context(format!("data: URI: {e}")))?
                    .0
            }
            gltf::buffer::Source::Uri(uri) => {
                let reference = percent_decode(uri)
                    .ok_or_else(|| context(format!("URI '{uri}' has a malformed %-escape")))?;
                read_referenced(path, &reference, root)?
                    .ok_or_else(|| context(format!("'{reference}' not found beside the file")))?
            }
        };
        if data.len() < buffer.length() {
            return Err(context(format!(
                "declares {} bytes but its data has {}",
                buffer.length(),
                data.len()
            )));
        }
        while data.len() % 4 != 0 {
            data.push(0);
        }
        buffers.push(gltf::buffer::Data(data));
    }
    Ok(buffers)
}

/// The references that the gltf crate's validator reads before checking them, or never
/// checks: each primitive's POSITION accessor, and each animation channel's target node
/// and path.
fn check_unvalidated_references(root: &gltf::json::Root) -> Result<(), String> {
    use gltf::json::validation::Checked;
    let position = Checked::Valid(gltf::Semantic::Positions);
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(index) = primitive.attributes.get(&position) {
                if index.value() >= root.accessors.len() {
                    return Err(format!(
                        "mesh {m} primitive {p}: POSITION names accessor {} but there are {}",
                        index.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    for (a, animation) in root.animations.iter().enumerate() {
        for (c, channel) in animation.channels.iter().enumerate() {
            let target = &channel.target;
            if target.node.value() >= root.nodes.len() {
                return Err(format!(
                    "animation {a} channel {c}: target names node {} but there are {} nodes",
                    target.node.value(),
                    root.nodes.len()
                ));
            }
            if matches!(target.path, Checked::Invalid) {
                return Err(format!(
                    "animation {a} channel {c}: target path is not translation, rotation, scale or weights"
                ));
            }
        }
    }
    Ok(())
}

/// The instances of the node trees under `roots`: every node that holds a mesh, with its
/// world transform (the product of its ancestors' local transforms, accumulated in f64).
/// The walk is iterative, so any depth is followed; a node listed as a child twice, or
/// by two parents, or reached twice from the roots (a cycle) is an error naming it.
fn place_nodes(
    path: &Path,
    document: &gltf::Document,
    roots: &[gltf::Node],
) -> Result<Vec<Instance>, MeshError> {
    let nodes: Vec<gltf::Node> = document.nodes().collect();
    let mut parent: Vec<Option<usize>> = vec![None; nodes.len()];
    for node in &nodes {
        for child in node.children() {
            if let Some(first) = parent[child.index()].replace(node.index()) {
                return Err(MeshError::invalid(
                    path,
                    format!(
                        "node {} is listed as a child of node {first} and again of node {}: glTF nodes form trees",
                        child.index(),
                        node.index()
                    ),
                ));
            }
        }
    }
    let mut placed = vec![false; nodes.len()];
    let mut instances = Vec::new();
    let mut stack: Vec<(usize, DMat4)> = roots
        .iter()
        .rev()
        .map(|r| (r.index(), DMat4::IDENTITY))
        .collect();
    while let Some((index, parent_world)) = stack.pop() {
        if std::mem::replace(&mut placed[index], true) {
            return Err(MeshError::invalid(
                path,
                format!("node {index} is reached twice from the scene's roots: the node graph has a cycle"),
            ));
        }
        let node = &nodes[index];
        let local = Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4();
        let world = parent_world * local;
        if let Some(mesh) = node.mesh() {
            instances.push(Instance {
                mesh: mesh.index(),
                transform: Affine3A::from_mat4(world.as_mat4()),
                source_node: Some(index as u32),
            });
        }
        let first_child = stack.len();
        stack.extend(node.children().map(|c| (c.index(), world)));
        // Last pushed is first walked: children in their listed order.
        stack[first_child..].reverse();
    }
    Ok(instances)
}

/// Triangles from a primitive's corner list, in order.
fn assemble(mode: Mode, corners: &[u32]) -> (Vec<[u32; 3]>, usize) {
    let triangles: Vec<[u32; 3]> = match mode {
        Mode::TriangleStrip => {
            // A strip's triangles that name a vertex twice are its joins and swaps
            // (glTF has no restart index): dropped and counted, as PLY tristrips' are.
            let mut kept = Vec::with_capacity(corners.len());
            let dropped = crate::strip::standard_triangles(corners, &mut kept);
            return (kept, dropped);
        }
        Mode::TriangleFan => corners
            .windows(2)
            .skip(1)
            .map(|w| [corners[0], w[0], w[1]])
            .collect(),
        _ => corners
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
    };
    (triangles, 0)
}

/// Checks that `accessor` is dense, has a view inside its buffer, a legal stride and
/// alignment, and elements that fit in the view, so that reading it cannot panic.
/// How many bytes of accessor data a glTF file may have read out of it: twice the
/// bytes of its buffers, plus [`READ_BUDGET_SLACK`]. A file that reads each accessor
/// once stays within its buffers; one that names the same accessor from thousands of
/// primitives or animation channels (a few kilobytes of JSON each) would make a small
/// file fill any memory, and is refused instead. Each byte read becomes at most 11
/// bytes in memory (a u8 index: a u32 corner and its share of the triangle's material,
/// flag and group).
pub(crate) struct ReadBudget {
    limit: usize,
    left: usize,
}

/// What every glTF file may read beyond twice its buffers: 16 MiB.
pub(crate) const READ_BUDGET_SLACK: usize = 16 << 20;

impl ReadBudget {
    /// The budget of a file whose buffers hold `buffer_bytes`.
    pub(crate) fn new(buffer_bytes: usize) -> Self {
        let limit = buffer_bytes
            .saturating_mul(2)
            .saturating_add(READ_BUDGET_SLACK);
        Self { limit, left: limit }
    }

    /// Take `bytes` for reading `what`, or say why not.
    pub(crate) fn take(
        &mut self,
        bytes: usize,
        what: impl FnOnce() -> String,
    ) -> Result<(), String> {
        match self.left.checked_sub(bytes) {
            Some(left) => {
                self.left = left;
                Ok(())
            }
            None => Err(format!(
                "{}: {bytes} more bytes of accessor data would pass the {} this file may read \
                 (twice its buffers, plus 16 MiB): accessors used over and over, or sparse ones over zeros",
                what(),
                self.limit
            )),
        }
    }
}

/// Values of `data_type` from their little-endian components, one slice a component.
fn typed_values<'a>(
    data_type: gltf::accessor::DataType,
    components: impl Iterator<Item = &'a [u8]>,
) -> AttributeValues {
    use gltf::accessor::DataType;
    macro_rules! typed {
        ($variant:ident, $t:ty) => {
            AttributeValues::$variant(
                components
                    .map(|b| <$t>::from_le_bytes(b.try_into().expect("component size")))
                    .collect(),
            )
        };
    }
    match data_type {
        DataType::I8 => typed!(I8, i8),
        DataType::U8 => typed!(U8, u8),
        DataType::I16 => typed!(I16, i16),
        DataType::U16 => typed!(U16, u16),
        DataType::U32 => typed!(U32, u32),
        DataType::F32 => typed!(F32, f32),
    }
}

/// Bytes per index of a sparse accessor's indices.
fn sparse_index_size(indices: &gltf::accessor::sparse::Indices) -> usize {
    use gltf::accessor::sparse::IndexType;
    match indices.index_type() {
        IndexType::U8 => 1,
        IndexType::U16 => 2,
        IndexType::U32 => 4,
    }
}

/// A buffer view lies within its buffer.
fn check_view<B: std::ops::Deref<Target = [u8]>>(
    view: &gltf::buffer::View,
    buffers: &[B],
) -> Result<(), String> {
    let buffer_len = buffers.get(view.buffer().index()).map_or(0, |b| b.len());
    let view_end = view.offset().checked_add(view.length());
    if view_end.is_none_or(|end| end > buffer_len) {
        return Err(format!(
            "buffer view {} (offset {}, length {}) runs past its buffer of {buffer_len} bytes",
            view.index(),
            view.offset(),
            view.length()
        ));
    }
    Ok(())
}

/// A sparse accessor's substitutions: at most its element count of them, their
/// indices and values within their views (which glTF packs, with no stride).
fn check_sparse<B: std::ops::Deref<Target = [u8]>>(
    accessor: &gltf::Accessor,
    sparse: &gltf::accessor::sparse::Sparse,
    buffers: &[B],
) -> Result<(), String> {
    let n = sparse.count();
    if n > accessor.count() {
        return Err(format!(
            "accessor {}: {n} sparse substitutions for {} elements",
            accessor.index(),
            accessor.count()
        ));
    }
    let (indices, values) = (sparse.indices(), sparse.values());
    let parts = [
        (
            "indices",
            indices.view(),
            indices.offset(),
            sparse_index_size(&indices),
        ),
        ("values", values.view(), values.offset(), accessor.size()),
    ];
    for (what, view, offset, size) in parts {
        check_view(&view, buffers)?;
        let end = n.checked_mul(size).and_then(|b| b.checked_add(offset));
        if end.is_none_or(|end| end > view.length()) {
            return Err(format!(
                "accessor {}: {n} sparse {what} of {size} bytes from byte {offset} run past buffer view {} of {} bytes",
                accessor.index(),
                view.index(),
                view.length()
            ));
        }
    }
    Ok(())
}

pub(crate) fn check_accessor<B: std::ops::Deref<Target = [u8]>>(
    accessor: &gltf::Accessor,
    buffers: &[B],
) -> Result<(), String> {
    if let Some(sparse) = accessor.sparse() {
        check_sparse(accessor, &sparse, buffers)?;
    }
    let Some(view) = accessor.view() else {
        return match accessor.sparse() {
            // Zeros, then the substitutions.
            Some(_) => Ok(()),
            None => Err(format!("accessor {} has no buffer view", accessor.index())),
        };
    };
    check_view(&view, buffers)?;
    let element = accessor.size();
    let component = accessor.data_type().size();
    if let Some(stride) = view.stride() {
        if stride < element || !stride.is_multiple_of(component) || stride > 252 {
            return Err(format!(
                "buffer view {} has byteStride {stride}, which is not a multiple of {component} in {element}..=252 (accessor {} has {element}-byte elements)",
                view.index(),
                accessor.index()
            ));
        }
    }
    if !accessor.offset().is_multiple_of(component) || !view.offset().is_multiple_of(component) {
        return Err(format!(
            "accessor {} starts at byte {} of buffer view {} (at byte {}), not aligned to its {component}-byte components",
            accessor.index(),
            accessor.offset(),
            view.index(),
            view.offset()
        ));
    }
    let stride = view.stride().unwrap_or(element);
    let needed = match accessor.count() {
        0 => Some(0),
        n => (n - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(element))
            .and_then(|x| x.checked_add(accessor.offset())),
    };
    if needed.is_none_or(|n| n > view.length()) {
        return Err(format!(
            "accessor {} ({} elements) runs past its buffer view of {} bytes",
            accessor.index(),
            accessor.count(),
            view.length()
        ));
    }
    Ok(())
}

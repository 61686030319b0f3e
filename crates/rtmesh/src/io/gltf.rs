//! glTF 2.0 and GLB through the gltf crate. Each glTF mesh becomes one geometry (its
//! primitives in order, materials per triangle); each node that holds a mesh becomes an
//! instance with its world transform; `alphaMode` MASK or BLEND marks a material
//! alpha-tested. Triangle strips and fans are turned into triangles; point and line
//! primitives are not triangles and are skipped. Every accessor is bounds-checked
//! against its buffer before it is read, so a lying file is an error, not a panic.

use super::{CountingReader, MeshError};
use crate::mesh::{Instance, Material, Scene, TriMesh};
use glam::{Affine3A, DMat4, Mat4, Vec3};
use gltf::mesh::Mode;
use serde_json::json;
use std::borrow::Cow;
use std::io::{BufRead, Read};
use std::path::Path;

pub(super) fn read<R: BufRead>(
    path: &Path,
    mut reader: CountingReader<'_, R>,
    root: &Path,
) -> Result<Scene, MeshError> {
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|e| MeshError::io(path, e))?;
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
    // exists (a panic found by fuzzing), so check that reference first.
    let unvalidated = gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| MeshError::invalid(path, e.to_string()))?;
    check_position_references(unvalidated.as_json()).map_err(|e| MeshError::invalid(path, e))?;
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice(&bytes).map_err(|e| MeshError::invalid(path, e.to_string()))?;
    let buffers = read_buffers(path, &document, blob, root)?;

    let mut scene = Scene {
        materials: document
            .materials()
            .map(|m| Material {
                name: m.name().unwrap_or_default().to_owned(),
                alpha_tested: m.alpha_mode() != gltf::material::AlphaMode::Opaque,
            })
            .collect(),
        ..Scene::default()
    };
    let default_material = scene.materials.len() as u32;
    scene.materials.push(Material::default());

    for mesh in document.meshes() {
        let mut out = TriMesh {
            name: mesh.name().unwrap_or_default().to_owned(),
            ..TriMesh::default()
        };
        let mut shared_positions: Option<(usize, u32)> = None;
        for (p, primitive) in mesh.primitives().enumerate() {
            let context = |what: &str| {
                format!(
                    "mesh {} ('{}') primitive {p}: {what}",
                    mesh.index(),
                    out.name
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
            if position_type != (DataType::F32, Dimensions::Vec3) {
                return Err(MeshError::invalid(
                    path,
                    context("POSITION must be a float VEC3 accessor"),
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
            let data = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            // Primitives that share one POSITION accessor share vertices.
            let base = match shared_positions {
                Some((accessor, base)) if accessor == position_accessor.index() => base,
                _ => {
                    let base = out.positions.len() as u32;
                    let positions = data
                        .read_positions()
                        .ok_or_else(|| MeshError::invalid(path, context("unreadable POSITION")))?;
                    out.positions.extend(positions.map(Vec3::from_array));
                    shared_positions = Some((position_accessor.index(), base));
                    base
                }
            };
            let corners: Vec<u32> = match data.read_indices() {
                Some(indices) => indices.into_u32().collect(),
                None => (0..position_accessor.count() as u32).collect(),
            };
            let triangles = assemble(primitive.mode(), &corners);
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
            .map(|mesh| Instance {
                mesh,
                transform: Affine3A::IDENTITY,
            })
            .collect();
    }
    Ok(scene)
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

fn check_position_references(root: &gltf::json::Root) -> Result<(), String> {
    let position = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
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
fn assemble(mode: Mode, corners: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::TriangleStrip => corners
            .windows(3)
            .enumerate()
            .map(|(i, w)| {
                if i % 2 == 0 {
                    [w[0], w[1], w[2]]
                } else {
                    [w[1], w[0], w[2]]
                }
            })
            .collect(),
        Mode::TriangleFan => corners
            .windows(2)
            .skip(1)
            .map(|w| [corners[0], w[0], w[1]])
            .collect(),
        _ => corners
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
    }
}

fn check_accessor(accessor: &gltf::Accessor, buffers: &[gltf::buffer::Data]) -> Result<(), String> {
    if accessor.sparse().is_some() {
        return Err("sparse accessors are not supported".into());
    }
    let Some(view) = accessor.view() else {
        return Err(format!("accessor {} has no buffer view", accessor.index()));
    };
    let buffer_len = buffers.get(view.buffer().index()).map_or(0, |b| b.0.len());
    let view_end = view.offset().checked_add(view.length());
    if view_end.is_none_or(|end| end > buffer_len) {
        return Err(format!(
            "buffer view {} (offset {}, length {}) runs past its buffer of {buffer_len} bytes",
            view.index(),
            view.offset(),
            view.length()
        ));
    }
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

pub(super) fn write(scene: &Scene, path: &Path, binary: bool) -> std::io::Result<usize> {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut push_view = |bin: &mut Vec<u8>, bytes: &[u8], target: u32| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len(), "target": target}));
        bin.extend_from_slice(bytes);
        views.len() - 1
    };
    let mut meshes = Vec::new();
    let mut collapsed = 0;
    // glTF has no empty mesh (a primitive needs vertices, an accessor a count): a
    // geometry without triangles is left out, and nodes placing it keep no mesh.
    let mut gltf_mesh = vec![None; scene.meshes.len()];
    for (index, mesh) in scene.meshes.iter().enumerate() {
        if mesh.triangles.is_empty() {
            continue;
        }
        gltf_mesh[index] = Some(meshes.len());
        let (mesh, inactive) = without_non_finite(mesh);
        collapsed += inactive;
        let mesh = &mesh;
        let positions: Vec<u8> = mesh
            .positions
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let finite =
            crate::geom::Aabb::from_points(mesh.positions.iter().filter(|p| p.is_finite()));
        let (min, max) = if finite.is_empty() {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (finite.min, finite.max)
        };
        let view = push_view(&mut bin, &positions, 34962);
        accessors.push(
            json!({"bufferView": view, "componentType": 5126, "count": mesh.positions.len(),
            "type": "VEC3", "min": min.to_array(), "max": max.to_array()}),
        );
        let position_accessor = accessors.len() - 1;
        let mut primitives = Vec::new();
        // One primitive per run of equal material, so triangle order is kept.
        let mut start = 0;
        while start < mesh.triangles.len() {
            let material = mesh.material_ids.get(start).copied().unwrap_or(0);
            let end = (start..mesh.triangles.len())
                .find(|&t| mesh.material_ids.get(t).copied().unwrap_or(0) != material)
                .unwrap_or(mesh.triangles.len());
            let indices: Vec<u8> = mesh.triangles[start..end]
                .iter()
                .flatten()
                .flat_map(|v| v.to_le_bytes())
                .collect();
            let view = push_view(&mut bin, &indices, 34963);
            accessors.push(json!({"bufferView": view, "componentType": 5125, "count": (end - start) * 3, "type": "SCALAR"}));
            let mut primitive = json!({"attributes": {"POSITION": position_accessor}, "indices": accessors.len() - 1, "mode": 4});
            if (material as usize) < scene.materials.len() {
                primitive["material"] = json!(material);
            }
            primitives.push(primitive);
            start = end;
        }
        meshes.push(json!({"name": mesh.name, "primitives": primitives}));
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let nodes: Vec<_> = scene
        .instances
        .iter()
        .map(|i| {
            let mut node = json!({});
            if let Some(mesh) = gltf_mesh[i.mesh] {
                node["mesh"] = json!(mesh);
            }
            if i.transform != Affine3A::IDENTITY {
                node["matrix"] = json!(Mat4::from(i.transform).to_cols_array());
            }
            node
        })
        .collect();
    let materials: Vec<_> = scene
        .materials
        .iter()
        .map(|m| json!({"name": m.name, "alphaMode": if m.alpha_tested { "MASK" } else { "OPAQUE" }}))
        .collect();
    let mut buffer = json!({"byteLength": bin.len()});
    if !binary {
        let bin_name = path.with_extension("bin");
        std::fs::write(&bin_name, &bin)?;
        buffer["uri"] = json!(bin_name
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or("buffer.bin"));
    }
    let root = json!({
        "asset": {"version": "2.0", "generator": concat!("rtmesh ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes, "meshes": meshes, "materials": materials,
        "accessors": accessors, "bufferViews": views, "buffers": [buffer],
    });
    let json_bytes = serde_json::to_vec(&root)?;
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
            bin: Some(Cow::Owned(bin)),
        };
        let file = std::io::BufWriter::new(std::fs::File::create(path)?);
        glb.to_writer(file)
            .map_err(|e| std::io::Error::other(e.to_string()))?;
    } else {
        std::fs::write(path, json_bytes)?;
    }
    Ok(collapsed)
}

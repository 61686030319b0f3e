//! Wavefront OBJ through tobj. Groups and objects become geometries (consecutive tobj
//! models of one name are one geometry, so `usemtl` switches inside a group keep the
//! group whole); polygons are fan-triangulated here so that a face with fewer than three
//! vertices is an error with its line, not a silently dropped face. Materials come from
//! the `mtllib` files beside the OBJ when present, read by the rule for references
//! (`reference.rs`: inside the OBJ's folder, regular files, size-limited): `map_d` or
//! `d < 1` marks them alpha-tested. A missing `.mtl` is not an error (many files ship
//! without one; the `usemtl` names then stand as plain materials, so that they are
//! kept); one that breaks the rule is.
//!
//! Texture coordinates (`vt`), normals (`vn`) and vertex colours after the position
//! (`v x y z r g b`) become the attributes `TEXCOORD_0`, `NORMAL` and `COLOR_0`: each
//! distinct (position, texture coordinate, normal) triple of a geometry is one vertex,
//! so seams stay. (A corner without `vt` in a file that has some takes tobj's fallback,
//! the geometry's previous one.) Where some `vt` has a third number (a 3D texture's
//! w) that is not 0, the w are the attribute [`TEXCOORD_W`], written back as
//! `vt u v w`. The `mtllib` references are kept as written and
//! written back, with `usemtl` per run of material; [`super::copy_side_files`] copies
//! the libraries and their textures beside an output in another folder.

use super::{CountingReader, MeshError};
use crate::mesh::{Material, MtlLook, MtlMap, Scene, TriMesh, VertexAttribute};
use glam::{Affine3A, Vec3};
use std::collections::HashMap;
use std::io::{BufRead, Write};
use std::path::Path;

/// The most bytes of material libraries one OBJ may read, all its `mtllib` files
/// together: 16 MiB. Real libraries take kilobytes; tobj holds about 15 bytes per byte
/// of the shortest `newmtl` records.
pub const MAX_MATERIAL_LIBRARY_BYTES: u64 = 16 << 20;

pub(super) fn read<R: BufRead>(
    path: &Path,
    mut reader: CountingReader<'_, R>,
    root: &Path,
) -> Result<Scene, MeshError> {
    let text = reader.read_all(path)?;
    check_attribute_indices(path, &text)?;
    let (text, ignored_lines, ignored_points) = without_lines_and_points(text);
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: false,
        ignore_points: false,
        ignore_lines: false,
    };
    let mut ignore = |_: u64, _: u64| {};
    let mut lines = CountingReader::new(&text[..], text.len() as u64, &mut ignore);
    // A material library is read by the rule for references (`reference.rs`); one that
    // breaks it is an error, a missing one is not (many files ship without it): then
    // the `usemtl` names that no library found defines stand as materials of their own,
    // so that faces keep them (and a found library's material is never replaced by a
    // stand-in, whatever the order of the `mtllib` lines). Each library is read once
    // however often `mtllib` names it, before tobj parses, and the libraries together
    // within MAX_MATERIAL_LIBRARY_BYTES: a short file that names one large library
    // thousands of times would otherwise fill memory.
    type Library = Option<std::rc::Rc<[u8]>>;
    let libraries = std::cell::RefCell::new(HashMap::<String, Library>::new());
    let library_bytes = std::cell::Cell::new(0u64);
    let fetch = |name: &str| -> Result<Library, MeshError> {
        if let Some(cached) = libraries.borrow().get(name) {
            return Ok(cached.clone());
        }
        let bytes = match super::reference::read_referenced(path, name, root)? {
            Some(bytes) => {
                library_bytes.set(library_bytes.get() + bytes.len() as u64);
                if library_bytes.get() > MAX_MATERIAL_LIBRARY_BYTES {
                    return Err(MeshError::invalid(
                        path,
                        format!(
                            "its material libraries hold over {MAX_MATERIAL_LIBRARY_BYTES} bytes together (at '{name}')"
                        ),
                    ));
                }
                let bytes = colours_as_triples(&bytes).map_err(|(line, message)| {
                    let library = super::reference::asset_folder(path).join(name);
                    let message = format!("{message} (a material library of {})", path.display());
                    MeshError::at_line(&library, line, message)
                })?;
                Some(std::rc::Rc::from(bytes))
            }
            None => None,
        };
        libraries
            .borrow_mut()
            .insert(name.to_owned(), bytes.clone());
        Ok(bytes)
    };
    let mut defined = std::collections::HashSet::new();
    let mut named = std::collections::HashSet::new();
    for name in arguments(&text, b"mtllib").filter(|name| named.insert(name.clone())) {
        if let Some(bytes) = fetch(&name)? {
            defined.extend(arguments(&bytes, b"newmtl"));
        }
    }
    let mut stand_ins = String::new();
    for name in arguments(&text, b"usemtl") {
        if defined.insert(name.clone()) {
            stand_ins.push_str(&format!("newmtl {name}\n"));
        }
    }
    let refused = std::cell::RefCell::new(None);
    let parse = |lines: &mut CountingReader<'_, &[u8]>| {
        let loaded = std::cell::RefCell::new(std::collections::HashSet::new());
        let stand_ins_loaded = std::cell::Cell::new(false);
        tobj::load_obj_buf(lines, &options, |mtl| {
            let name = mtl.to_string_lossy();
            if !loaded.borrow_mut().insert(name.to_string()) {
                return Ok(Default::default());
            }
            match fetch(&name) {
                Ok(Some(bytes)) => {
                    let (mut materials, names) = tobj::load_mtl_buf(&mut &bytes[..])?;
                    for material in &mut materials {
                        relative_to_obj(material, &name);
                    }
                    Ok((materials, names))
                }
                Ok(None) if stand_ins_loaded.replace(true) => Ok(Default::default()),
                Ok(None) => tobj::load_mtl_buf(&mut stand_ins.as_bytes()),
                Err(error) => {
                    refused.borrow_mut().get_or_insert(error);
                    Err(tobj::LoadError::OpenFileFailed)
                }
            }
        })
        .map_err(|e| MeshError::at_line(path, lines.line(), describe(e)))
    };
    let (models, materials) = parse(&mut lines)?;
    if let Some(error) = refused.borrow_mut().take() {
        return Err(error);
    }
    let materials = materials.unwrap_or_default();
    // tobj reads two numbers of a `vt`; where a third (a 3D texture's w) is not 0 in
    // some, the text is parsed again with each `vt u v w` written `vt w 0`, which gives
    // the same models with every texture coordinate's w in place of its u (a second
    // parse: about twice the time and peak memory of reading such a file).
    let w_text = with_texcoord_w_first(&text);
    let has_w = w_text.is_some();
    let texcoord_w = match w_text {
        Some(text) => {
            let mut ignore = |_: u64, _: u64| {};
            let mut lines = CountingReader::new(&text[..], text.len() as u64, &mut ignore);
            let (w_models, _) = parse(&mut lines)?;
            let same = |(a, b): (&tobj::Model, &tobj::Model)| {
                a.mesh.texcoord_indices == b.mesh.texcoord_indices
                    && a.mesh.texcoords.len() == b.mesh.texcoords.len()
            };
            // Always the same models; checked rather than trusted, since a mismatch
            // would put w on the wrong corners.
            (w_models.len() == models.len() && models.iter().zip(&w_models).all(same))
                .then_some(w_models)
        }
        None => None,
    };

    let mut scene = Scene {
        materials: materials
            .iter()
            .map(|m| Material {
                name: m.name.clone(),
                alpha_tested: m.dissolve_texture.is_some() || m.dissolve.is_some_and(|d| d < 1.0),
                mtl: Some(look(m)),
            })
            .collect(),
        ..Scene::default()
    };
    // Faces with no material get an extra default material at the end.
    let default_material = scene.materials.len() as u32;
    let mut needs_default = false;
    let mut faces_before = 0usize;
    for (m, model) in models.iter().enumerate() {
        let mesh = &model.mesh;
        let w = texcoord_w.as_ref().map(|w| &w[m].mesh.texcoords[..]);
        let ((positions, streams), corner_vertex) = vertices_of(mesh, w);
        let material = mesh.material_id.map_or_else(
            || {
                needs_default = true;
                default_material
            },
            |m| m as u32,
        );
        let alpha = scene
            .materials
            .get(material as usize)
            .is_some_and(|m| m.alpha_tested);
        let target = match scene.meshes.last_mut() {
            Some(last) if last.name == model.name => last,
            _ => {
                scene.push_mesh(
                    TriMesh {
                        name: model.name.clone(),
                        ..TriMesh::default()
                    },
                    Affine3A::IDENTITY,
                );
                scene.meshes.last_mut().expect("just pushed")
            }
        };
        let base = target.positions.len() as u32;
        target.extend_vertices(positions.into_iter(), streams);
        // tobj leaves `face_arities` empty when every face is a triangle.
        let arities = if mesh.face_arities.is_empty() {
            vec![3; mesh.indices.len() / 3]
        } else {
            mesh.face_arities.clone()
        };
        let mut start = 0usize;
        for (face, &arity) in arities.iter().enumerate() {
            let corners = &corner_vertex[start..start + arity as usize];
            start += arity as usize;
            if arity < 3 {
                let line = nth_face_line(&text, faces_before + face);
                return Err(MeshError::at_line(
                    path,
                    line,
                    format!("face has {arity} vertices; a face needs at least 3"),
                ));
            }
            for i in 1..corners.len() - 1 {
                target.triangles.push([
                    corners[0] + base,
                    corners[i] + base,
                    corners[i + 1] + base,
                ]);
                target.material_ids.push(material);
                target.alpha_tested.push(alpha);
                target.group_ids.push(0);
            }
        }
        faces_before += arities.len();
    }
    scene.source_vertex_count = Some(statements(&text, b"v").count());
    let material_libraries: Vec<String> = arguments(&text, b"mtllib").collect();
    if !material_libraries.is_empty() {
        scene.document = Some(std::sync::Arc::new(super::Document::Obj {
            material_libraries,
        }));
    }
    scene.read_notes.ignored_lines = ignored_lines;
    scene.read_notes.ignored_points = ignored_points;
    let names: Vec<&str> = scene.meshes.iter().map(|m| m.name.as_str()).collect();
    scene.read_notes.not_read.extend(not_kept(&text, &names));
    if has_w && texcoord_w.is_none() {
        let note = "OBJ texture coordinates' third number (`vt u v w`): tobj read the file differently the second time";
        scene.read_notes.not_read.push(note.to_owned());
    }
    if needs_default || scene.materials.is_empty() {
        scene.materials.push(Material::default());
    }
    Ok(scene)
}

/// The colour statements tobj reads as exactly three numbers.
const COLOURS: [&str; 4] = ["Ka", "Kd", "Ks", "Ke"];

/// An MTL library with every colour given as one number written as three: the MTL
/// specification lets `Kd r` stand for `Kd r r r`, and tobj 4.0.5 panics on fewer than
/// three. A colour with no number or two is an error at its line (1-based).
fn colours_as_triples(library: &[u8]) -> Result<Vec<u8>, (usize, String)> {
    let mut out = Vec::with_capacity(library.len());
    for (n, line) in library.split(|&b| b == b'\n').enumerate() {
        if n > 0 {
            out.push(b'\n');
        }
        let text = String::from_utf8_lossy(line);
        let mut words = text.split_whitespace();
        let Some(keyword) = words.next().filter(|k| COLOURS.contains(k)) else {
            out.extend_from_slice(line);
            continue;
        };
        match words.collect::<Vec<_>>()[..] {
            [r] => out.extend_from_slice(format!("{keyword} {r} {r} {r}").as_bytes()),
            ref numbers @ ([] | [_, _]) => {
                let message = format!(
                    "'{keyword}' needs one number (grey) or three (r g b), not {}",
                    numbers.len()
                );
                return Err((n + 1, message));
            }
            _ => out.extend_from_slice(line),
        }
    }
    Ok(out)
}

/// A texture statement's argument as its options and the file they place: the file is
/// what follows the options (`-s 1 1 1`, `-bm 0.5`, ...), spaces included, as the MTL
/// specification lays them out: each option takes its count of arguments, `-o`, `-s`
/// and `-t` one to three numbers.
fn texture_parts(argument: &str) -> Option<(&str, &str)> {
    let argument = argument.trim();
    // The byte where the word at or after `at` starts, and where it ends.
    let word = |at: usize| -> Option<(usize, usize)> {
        let start = at + argument[at..].find(|c: char| !c.is_whitespace())?;
        let end = start
            + argument[start..]
                .find(char::is_whitespace)
                .unwrap_or(argument.len() - start);
        Some((start, end))
    };
    let mut at = 0;
    while let Some((start, end)) = word(at) {
        let arguments = match &argument[start..end] {
            "-blendu" | "-blendv" | "-bm" | "-boost" | "-cc" | "-clamp" | "-imfchan"
            | "-texres" | "-type" => 1,
            "-mm" => 2,
            "-o" | "-s" | "-t" => 3,
            _ => break,
        };
        at = end;
        for k in 0..arguments {
            let Some((start, end)) = word(at) else { break };
            // Past the first, the numbers of -o/-s/-t are optional: a word that is no
            // number, or the last word (the file), ends them.
            let optional = k > 0 && arguments == 3;
            if optional && (argument[start..end].parse::<f32>().is_err() || word(end).is_none()) {
                break;
            }
            at = end;
        }
    }
    let (start, _) = word(at)?;
    Some((argument[..start].trim_end(), &argument[start..]))
}

/// The file a texture statement's argument names (see [`texture_parts`]).
fn texture_file(argument: &str) -> Option<&str> {
    texture_parts(argument).map(|(_, file)| file)
}

/// MTL statements whose last argument is a texture file.
fn is_texture_statement(keyword: &str) -> bool {
    keyword.starts_with("map_") || matches!(keyword, "bump" | "disp" | "decal" | "refl" | "norm")
}

/// The texture files an MTL library names, each once: the last argument of every map
/// statement (the options such as `-s 1 1 1` come before it).
pub(super) fn mtl_textures(library: &[u8]) -> Vec<String> {
    let text = String::from_utf8_lossy(library);
    let mut names: Vec<String> = Vec::new();
    for line in text.lines() {
        let line = line.trim();
        let (keyword, argument) = line.split_once(char::is_whitespace).unwrap_or((line, ""));
        if is_texture_statement(keyword) {
            if let Some(name) = texture_file(argument) {
                if !names.iter().any(|n| n == name) {
                    names.push(name.to_owned());
                }
            }
        }
    }
    names
}

/// The texture statements tobj keeps by name that glTF has a place for.
const NORM: &str = "norm";
const MAP_KE: &str = "map_Ke";
const MAP_PM: &str = "map_Pm";
const MAP_PR: &str = "map_Pr";

/// Each texture of `material`, from the library `library` (as `mtllib` names it),
/// with its file relative to the OBJ's folder, as [`MtlLook`] keeps them; the options
/// before it stay.
fn relative_to_obj(material: &mut tobj::Material, library: &str) {
    let Some(folder) = Path::new(library)
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
    else {
        return;
    };
    let relative = |argument: &mut String| {
        if let Some((options, file)) = texture_parts(argument) {
            let folder = folder.to_string_lossy();
            *argument = format!("{options} {folder}/{file}").trim_start().to_owned();
        }
    };
    let kept = (material.unknown_param.iter_mut())
        .filter(|(key, _)| [NORM, MAP_KE, MAP_PM, MAP_PR].contains(&key.as_str()))
        .map(|(_, value)| value);
    let own = [&mut material.diffuse_texture, &mut material.normal_texture];
    for texture in own.into_iter().flatten().chain(kept) {
        relative(texture);
    }
}

/// A texture statement's argument as a map: its file, and the `-s` and `-o` options
/// (each one to three numbers; the others are passed over).
fn mtl_map(argument: &str) -> Option<MtlMap> {
    let (options, file) = texture_parts(argument)?;
    let options: Vec<&str> = options.split_whitespace().collect();
    let (mut scale, mut offset) = ([1.0f32; 2], [0.0f32; 2]);
    for (at, word) in options.iter().enumerate() {
        let target = match *word {
            "-s" => &mut scale,
            "-o" => &mut offset,
            _ => continue,
        };
        let numbers = options[at + 1..]
            .iter()
            .map_while(|w| w.parse::<f32>().ok());
        for (slot, x) in target.iter_mut().zip(numbers) {
            *slot = x;
        }
    }
    Some(MtlMap {
        file: file.to_owned(),
        scale,
        offset,
    })
}

/// What glTF can hold of an MTL material's look.
fn look(material: &tobj::Material) -> MtlLook {
    let param = |key: &str| material.unknown_param.get(key);
    let number = |key: &str| param(key).and_then(|p| p.trim().parse::<f32>().ok());
    let map = |argument: Option<&String>| argument.and_then(|a| mtl_map(a));
    let (metalness, roughness) = (map(param(MAP_PM)), map(param(MAP_PR)));
    MtlLook {
        diffuse: material.diffuse.unwrap_or([1.0; 3]),
        dissolve: material.dissolve.unwrap_or(1.0),
        emissive: material.emissive.unwrap_or([0.0; 3]),
        metallic: number("Pm"),
        roughness: number("Pr"),
        diffuse_map: map(material.diffuse_texture.as_ref()),
        normal_map: map(material.normal_texture.as_ref().or(param(NORM))),
        emissive_map: map(param(MAP_KE)),
        metallic_roughness_map: metalness.filter(|m| roughness.is_some_and(|r| r == *m)),
        dissolve_map: material.dissolve_texture.is_some(),
    }
}

/// The vertices of one tobj model, each distinct (position, texture coordinate, normal)
/// triple of its corners once, in order of first use: positions and attribute streams,
/// and the vertex of every corner. A model with neither `vt` nor `vn` keeps tobj's
/// vertices as they are. `texcoord_w`, where given, holds each texture coordinate's w
/// in the place of its u (`with_texcoord_w_first`): the stream [`TEXCOORD_W`].
#[allow(clippy::type_complexity)]
fn vertices_of(
    mesh: &tobj::Mesh,
    texcoord_w: Option<&[f32]>,
) -> ((Vec<Vec3>, Vec<VertexAttribute>), Vec<u32>) {
    let position = |v: usize| {
        Vec3::new(
            mesh.positions[3 * v],
            mesh.positions[3 * v + 1],
            mesh.positions[3 * v + 2],
        )
    };
    let colour = |v: usize| -> [f32; 3] { std::array::from_fn(|c| mesh.vertex_color[3 * v + c]) };
    let has_colour =
        !mesh.vertex_color.is_empty() && mesh.vertex_color.len() == mesh.positions.len();
    let uv = (!mesh.texcoord_indices.is_empty()).then_some(&mesh.texcoord_indices);
    let normal = (!mesh.normal_indices.is_empty()).then_some(&mesh.normal_indices);
    let (mut positions, mut uvs, mut ws, mut normals, mut colours) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let corners = if uv.is_none() && normal.is_none() {
        let n = mesh.positions.len() / 3;
        positions.extend((0..n).map(position));
        if has_colour {
            colours.extend((0..n).map(colour));
        }
        mesh.indices.clone()
    } else {
        let mut vertex_of: HashMap<(u32, u32, u32), u32> =
            HashMap::with_capacity(mesh.indices.len());
        (0..mesh.indices.len())
            .map(|c| {
                let key = (
                    mesh.indices[c],
                    uv.map_or(0, |i| i[c]),
                    normal.map_or(0, |i| i[c]),
                );
                *vertex_of.entry(key).or_insert_with(|| {
                    let v = key.0 as usize;
                    positions.push(position(v));
                    if uv.is_some() {
                        let t = key.1 as usize;
                        uvs.push([mesh.texcoords[2 * t], mesh.texcoords[2 * t + 1]]);
                        if let Some(w) = texcoord_w {
                            ws.push([w[2 * t]]);
                        }
                    }
                    if normal.is_some() {
                        let n = key.2 as usize;
                        normals.push([0, 1, 2].map(|c| mesh.normals[3 * n + c]));
                    }
                    if has_colour {
                        colours.push(colour(v));
                    }
                    positions.len() as u32 - 1
                })
            })
            .collect()
    };
    let mut streams = Vec::new();
    if uv.is_some() {
        streams.push(VertexAttribute::from_f32("TEXCOORD_0", &uvs));
        if texcoord_w.is_some() {
            streams.push(VertexAttribute::from_f32(TEXCOORD_W, &ws));
        }
    }
    if normal.is_some() {
        streams.push(VertexAttribute::from_f32("NORMAL", &normals));
    }
    if has_colour {
        streams.push(VertexAttribute::from_f32("COLOR_0", &colours));
    }
    ((positions, streams), corners)
}

/// Whether `line` is a statement of `keyword`.
fn statement_is(line: &[u8], keyword: &[u8]) -> bool {
    let line = line.trim_ascii_start();
    line.starts_with(keyword) && line.get(keyword.len()).is_none_or(u8::is_ascii_whitespace)
}

/// The `keyword` statements of `text`, as lines.
fn statements<'a>(text: &'a [u8], keyword: &'a [u8]) -> impl Iterator<Item = &'a [u8]> + 'a {
    text.split(|&b| b == b'\n')
        .filter(move |line| statement_is(line, keyword))
}

/// The argument (the rest of the line, trimmed) of every `keyword` statement of `text`.
fn arguments<'a>(text: &'a [u8], keyword: &'a [u8]) -> impl Iterator<Item = String> + 'a {
    statements(text, keyword).map(move |line| {
        String::from_utf8_lossy(line.trim_ascii()[keyword.len()..].trim_ascii()).into_owned()
    })
}

/// What tobj reads of `text` without keeping, in words, from one pass over its lines:
/// smoothing groups (`s`) in a file without normals, which are how a tool would build
/// them; the names of objects and groups that name no faces of their own (a geometry
/// takes the name of the last `o` or `g` before its faces, so an object holding named
/// groups loses its own: `geometry_names` are those kept).
fn not_kept(text: &[u8], geometry_names: &[&str]) -> Vec<String> {
    let (mut smoothing, mut normals) = (0usize, false);
    let mut unnamed: Vec<String> = Vec::new();
    for line in text.split(|&b| b == b'\n') {
        let mut words = line
            .split(u8::is_ascii_whitespace)
            .filter(|w| !w.is_empty());
        match words.next() {
            Some(b"vn") => normals = true,
            Some(b"s") => {
                smoothing += words.next().is_some_and(|g| g != b"off" && g != b"0") as usize
            }
            Some(b"o" | b"g") => {
                let name = String::from_utf8_lossy(line.trim_ascii()[1..].trim_ascii());
                if !name.is_empty()
                    && !geometry_names.contains(&&*name)
                    && !unnamed.iter().any(|u| *u == name)
                {
                    unnamed.push(name.into_owned());
                }
            }
            _ => {}
        }
    }
    let mut notes = Vec::new();
    if smoothing > 0 && !normals {
        notes.push(format!(
            "OBJ smoothing groups (`s`): {smoothing} statements, in a file without normals (`vn`)"
        ));
    }
    if !unnamed.is_empty() {
        notes.push(format!(
            "OBJ object and group names that name no faces of their own: {} (each geometry takes the name of the last `o` or `g` before its faces)",
            unnamed.join(", ")
        ));
    }
    notes
}

/// The name of the stream of an OBJ's texture coordinates' third number (`vt u v w`,
/// a 3D texture's w), kept where some w is not 0: glTF's `TEXCOORD_n` hold two, so it
/// is an attribute of its own, named as glTF names an application's.
pub const TEXCOORD_W: &str = "_TEXCOORD_0_W";

/// `text` with each `vt u v [w]` written `vt w 0` (w 0 where there is none or it is no
/// number), where some w is not 0; `None` where none is. Line breaks stay where they
/// were, so tobj reads the same models from it.
fn with_texcoord_w_first(text: &[u8]) -> Option<Vec<u8>> {
    fn third(line: &[u8]) -> Option<&[u8]> {
        let mut words = line
            .split(u8::is_ascii_whitespace)
            .filter(|w| !w.is_empty());
        // tobj reads no third word, so one that is not a number stands as a missing w.
        let number = |w: &&[u8]| std::str::from_utf8(w).is_ok_and(|w| w.parse::<f32>().is_ok());
        (words.next() == Some(b"vt")).then(|| words.nth(2).filter(number).unwrap_or(b"0"))
    }
    let nonzero = |w: &[u8]| w.iter().any(|b| !b"0.+-".contains(b));
    let lines = text.split(|&b| b == b'\n');
    if !lines.clone().filter_map(third).any(nonzero) {
        return None;
    }
    let mut out = Vec::with_capacity(text.len());
    for (n, line) in lines.enumerate() {
        if n > 0 {
            out.push(b'\n');
        }
        match third(line) {
            Some(w) => {
                out.extend_from_slice(b"vt ");
                out.extend_from_slice(w);
                out.extend_from_slice(b" 0");
            }
            None => out.extend_from_slice(line),
        }
    }
    Some(out)
}

/// `text` with its `l` (polyline) and `p` (point) statements blanked, their line breaks
/// kept so that line numbers stay right, and how many of each there were. They are not
/// triangles: tobj would turn a polyline of three or more vertices into a face.
fn without_lines_and_points(mut text: Vec<u8>) -> (Vec<u8>, usize, usize) {
    let (mut lines, mut points) = (0, 0);
    let mut start = 0;
    while start < text.len() {
        let end = text[start..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(text.len(), |n| start + n);
        let line = &text[start..end];
        let (is_line, is_point) = (statement_is(line, b"l"), statement_is(line, b"p"));
        if is_line || is_point {
            lines += is_line as usize;
            points += is_point as usize;
            text[start..end].fill(b' ');
        }
        start = end + 1;
    }
    (text, lines, points)
}

fn describe(error: tobj::LoadError) -> String {
    match error {
        tobj::LoadError::ReadError => "cannot read line (not valid UTF-8 text?)".into(),
        tobj::LoadError::FaceParseError => {
            "bad face: expected 'f' followed by vertex indices (1-based or negative, in range)"
                .into()
        }
        tobj::LoadError::PositionParseError => "bad vertex: expected 'v x y z' with numbers".into(),
        other => format!("{other}"),
    }
}

/// Face indices checked at their own line before tobj sees them: a vertex index must
/// name a vertex read so far (tobj reports a bad one only where its group ends, lines
/// later), and texture coordinate and normal indices that tobj 4.0.5 would multiply
/// without an overflow check (0, a relative index before the first `vt` / `vn`, or one
/// past 2³²: a panic in a debug build, a wrapped index in a release one) are errors.
/// (Texture coordinate and normal indices past those read so far are left to tobj.)
/// `l` and `p` statements are ignored, so they are not checked.
fn check_attribute_indices(path: &Path, text: &[u8]) -> Result<(), MeshError> {
    let (mut positions, mut texcoords, mut normals) = (0i64, 0i64, 0i64);
    for (number, line) in text.split(|&b| b == b'\n').enumerate() {
        // tobj reports lines that are not UTF-8.
        let Ok(line) = std::str::from_utf8(line) else {
            continue;
        };
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => positions += 1,
            Some("vt") => texcoords += 1,
            Some("vn") => normals += 1,
            Some("f") => {
                for word in words {
                    let mut parts = word.split('/');
                    // A vertex index must name a vertex read so far (tobj would report
                    // it only where the group ends).
                    let vertex = parts.next().and_then(|p| p.parse::<i64>().ok());
                    if let Some(x) = vertex.filter(|&x| x == 0 || x < -positions || x > positions) {
                        return Err(MeshError::at_line(
                            path,
                            number + 1,
                            format!(
                                "face vertex index {x} is out of range ({positions} read so far)"
                            ),
                        ));
                    }
                    // v/vt/vn: the second and third parts.
                    for (count, what) in [(texcoords, "texture coordinate"), (normals, "normal")] {
                        let index = parts.next().and_then(|p| p.parse::<i64>().ok());
                        if let Some(x) =
                            index.filter(|&x| x == 0 || x < -count || x > u32::MAX as i64)
                        {
                            return Err(MeshError::at_line(
                                path,
                                number + 1,
                                format!(
                                    "face {what} index {x} is out of range ({count} read so far)"
                                ),
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// 1-based line of the `n`-th (0-based) face statement, found only when reporting an error.
fn nth_face_line(text: &[u8], n: usize) -> usize {
    text.split(|&b| b == b'\n')
        .enumerate()
        .filter(|(_, line)| {
            let trimmed = line.trim_ascii_start();
            trimmed.starts_with(b"f ") || trimmed.starts_with(b"f\t") || trimmed == b"f"
        })
        .nth(n)
        .map_or(0, |(i, _)| i + 1)
}

/// Write a `keyword` line for each distinct value of `values` (by bits), in order of
/// first use; returns the 1-based index (from `base`) of every vertex's value, and how
/// many lines were written.
fn write_distinct<const N: usize>(
    out: &mut impl Write,
    keyword: &str,
    values: &[[f32; N]],
    base: usize,
) -> std::io::Result<(Vec<usize>, usize)> {
    let mut index: HashMap<[u32; N], usize> = HashMap::with_capacity(values.len());
    let mut of_vertex = Vec::with_capacity(values.len());
    for value in values {
        let next = index.len();
        let i = *index.entry(value.map(f32::to_bits)).or_insert(next);
        if i == next {
            write!(out, "{keyword}")?;
            for x in value {
                // `{}` prints the shortest decimal that reads back to the same f32.
                write!(out, " {x}")?;
            }
            writeln!(out)?;
        }
        of_vertex.push(base + i);
    }
    Ok((of_vertex, index.len()))
}

/// An MTL library for `materials` that hold an MTL look (a PLY's textures) and no
/// library of their own: each material's colours and maps as MTL states them, named
/// by its name (or `materialN`, each name once).
pub(super) fn looks_library(materials: &[crate::mesh::Material]) -> super::gltf::MtlLibrary {
    use std::fmt::Write as _;
    let mut library = super::gltf::MtlLibrary::default();
    let _ = writeln!(
        library.text,
        "# written by rtmesh {}",
        env!("CARGO_PKG_VERSION")
    );
    for (i, material) in materials.iter().enumerate() {
        let mut name = material.name.replace(char::is_whitespace, "_");
        if name.is_empty() || library.names.contains(&name) {
            name = format!("material{i}");
        }
        let _ = writeln!(library.text, "\nnewmtl {name}");
        if let Some(look) = &material.mtl {
            let [r, g, b] = look.diffuse;
            let _ = writeln!(library.text, "Kd {r} {g} {b}\nd {}", look.dissolve);
            let [r, g, b] = look.emissive;
            let _ = writeln!(library.text, "Ke {r} {g} {b}");
            for (key, value) in [("Pm", look.metallic), ("Pr", look.roughness)] {
                if let Some(value) = value {
                    let _ = writeln!(library.text, "{key} {value}");
                }
            }
            let maps = [
                ("map_Kd", &look.diffuse_map),
                ("norm", &look.normal_map),
                ("map_Ke", &look.emissive_map),
                ("map_Pm", &look.metallic_roughness_map),
                ("map_Pr", &look.metallic_roughness_map),
            ];
            for (key, map) in maps {
                if let Some(MtlMap {
                    file,
                    scale,
                    offset,
                }) = map
                {
                    let ([su, sv], [ou, ov]) = (scale, offset);
                    let _ = writeln!(library.text, "{key} -s {su} {sv} 1 -o {ou} {ov} 0 {file}");
                }
            }
        }
        library.names.push(name);
    }
    library
}

/// Write `scene` as OBJ to `path`. Its materials are named as read, or, with
/// `library` (a library written for it: its file name and each material's name), by
/// that library's names.
pub(super) fn write(
    scene: &Scene,
    path: &Path,
    library: Option<(&str, &[String])>,
) -> std::io::Result<()> {
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(out, "# written by rtmesh {}", env!("CARGO_PKG_VERSION"))?;
    if let Some(super::Document::Obj { material_libraries }) = scene.document.as_deref() {
        for library in material_libraries {
            writeln!(out, "mtllib {library}")?;
        }
    }
    if let Some((file, _)) = library {
        writeln!(out, "mtllib {file}")?;
    }
    let material_name = |m: u32| match library {
        Some((_, names)) => names.get(m as usize).map(String::as_str),
        None => (scene.materials.get(m as usize))
            .map(|m| m.name.as_str())
            .filter(|name| !name.is_empty()),
    };
    let (mut position_base, mut uv_base, mut normal_base) = (1usize, 1usize, 1usize);
    for (i, instance) in scene.instances.iter().enumerate() {
        let mesh = &scene.meshes[instance.mesh];
        let name = if mesh.name.is_empty() {
            format!("geometry{i}")
        } else {
            mesh.name.replace(char::is_whitespace, "_")
        };
        writeln!(out, "o {name}")?;
        // OBJ indexes positions, texture coordinates and normals apart: each distinct
        // value is written once per geometry, as files come (seams cost an index, not
        // a line), and each vertex names its three.
        let colour = mesh.attribute("COLOR_0");
        let place = |p: &Vec3| instance.transform.transform_point3(*p).to_array();
        let position = match colour {
            Some(colour) => {
                let coloured: Vec<[f32; 6]> = (mesh.positions.iter().enumerate())
                    .map(|(v, p)| {
                        let [x, y, z] = place(p);
                        let c = |k: usize| colour.value(v, k.min(colour.components - 1)) as f32;
                        [x, y, z, c(0), c(1), c(2)]
                    })
                    .collect();
                write_distinct(&mut out, "v", &coloured, position_base)?
            }
            None => {
                let placed: Vec<[f32; 3]> = mesh.positions.iter().map(place).collect();
                write_distinct(&mut out, "v", &placed, position_base)?
            }
        };
        let vertices = 0..mesh.positions.len();
        let uv = match (mesh.attribute("TEXCOORD_0"), mesh.attribute(TEXCOORD_W)) {
            (Some(uv), Some(w)) => {
                let value = |a: &VertexAttribute, v, c| a.value(v, c) as f32;
                let values: Vec<[f32; 3]> = (vertices.clone())
                    .map(|v| [value(uv, v, 0), value(uv, v, 1), value(w, v, 0)])
                    .collect();
                Some(write_distinct(&mut out, "vt", &values, uv_base)?)
            }
            (Some(uv), None) => {
                let values: Vec<[f32; 2]> = (vertices.clone())
                    .map(|v| [uv.value(v, 0) as f32, uv.value(v, 1) as f32])
                    .collect();
                Some(write_distinct(&mut out, "vt", &values, uv_base)?)
            }
            (None, _) => None,
        };
        let normal = mesh.attribute("NORMAL").map(|n| {
            let mut n = n.dequantized().into_owned();
            n.transform(glam::Mat3::from(instance.transform.matrix3));
            let values: Vec<[f32; 3]> = (0..mesh.positions.len())
                .map(|v| [0, 1, 2].map(|c| n.get(v, c) as f32))
                .collect();
            values
        });
        let normal = match normal {
            Some(values) => Some(write_distinct(&mut out, "vn", &values, normal_base)?),
            None => None,
        };
        let mut material = None;
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let m = mesh.material_ids.get(t).copied();
            if m != material {
                material = m;
                if let Some(name) = m.and_then(material_name) {
                    writeln!(out, "usemtl {name}")?;
                }
            }
            write!(out, "f")?;
            for v in tri.map(|v| v as usize) {
                let p = position.0[v];
                match (&uv, &normal) {
                    (None, None) => write!(out, " {p}")?,
                    (Some(t), None) => write!(out, " {p}/{}", t.0[v])?,
                    (None, Some(n)) => write!(out, " {p}//{}", n.0[v])?,
                    (Some(t), Some(n)) => write!(out, " {p}/{}/{}", t.0[v], n.0[v])?,
                }
            }
            writeln!(out)?;
        }
        position_base += position.1;
        uv_base += uv.map_or(0, |t| t.1);
        normal_base += normal.map_or(0, |n| n.1);
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_texture_is_the_last_argument_of_each_map_statement() {
        let library = b"newmtl a\nKd 1 0 0\nmap_Kd -s 1 1 1 tex/a.png\nbump -bm 0.5 n.png\n\
                        map_Ks tex/a.png\nrefl -type sphere env.jpg\nmap_d\nnewmtl b\n";
        assert_eq!(mtl_textures(library), ["tex/a.png", "n.png", "env.jpg"]);
    }

    #[test]
    fn a_texture_file_is_what_follows_the_options_spaces_included() {
        let parts = |argument| texture_parts(argument).unwrap();
        assert_eq!(parts("my tex.png"), ("", "my tex.png"));
        assert_eq!(
            parts("-s 1 -1 1 -o 0 1 0 a b.png"),
            ("-s 1 -1 1 -o 0 1 0", "a b.png")
        );
        // -o and -s take one to three numbers; a file named by a number is still the file.
        assert_eq!(parts("-o 0.5 tex/a.png"), ("-o 0.5", "tex/a.png"));
        assert_eq!(parts("-s 2 3"), ("-s 2", "3"));
        assert_eq!(
            parts("-imfchan g -bm 0.5 -mm 0 1 -clamp on x.png"),
            ("-imfchan g -bm 0.5 -mm 0 1 -clamp on", "x.png")
        );
        assert_eq!(texture_parts("-bm 0.5"), None);
        assert_eq!(texture_parts("  "), None);
        let map = mtl_map("-s 2 -4 1 -o 0.5 0.75 0 a b.png").unwrap();
        assert_eq!(
            map,
            MtlMap {
                file: "a b.png".into(),
                scale: [2.0, -4.0],
                offset: [0.5, 0.75]
            }
        );
    }
}

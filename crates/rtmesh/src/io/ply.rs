//! Stanford PLY through ply-rs-bw, ascii and binary, with typed element structs (no
//! per-vertex hash maps) so the 871k-triangle dragon reads in well under a second.
//! Before any payload is read, each element count in the header is checked against the
//! bytes left in the file, so an absurd header (4e9 vertices) is an error, not an
//! allocation. Faces are `vertex_indices` (or `vertex_index`) lists of any integer type;
//! polygons are fan-triangulated. Triangle strips (a `tristrips` element, as some
//! scanned models ship: lists of vertex indices with −1 between strips) are decoded
//! with alternating winding, and the strips' degenerate triangles (the swaps and joins
//! that stitch a generalized strip, naming a vertex twice) are dropped and counted in
//! [`crate::mesh::ReadNotes`]. Every scalar vertex property is kept: `nx ny nz`,
//! `red green blue [alpha]` and `u v` (or `s t`, `texture_u texture_v`) as the
//! attributes `NORMAL`, `COLOR_0` and `TEXCOORD_0`, any other as an attribute of its
//! own name, each in its stored type and with its PLY names, which the writer writes
//! back. The writer emits binary little-endian PLY.

use super::{CountingReader, MeshError};
use crate::mesh::{AttributeValues, Material, MtlLook, Scene, TriMesh, VertexAttribute};
use glam::Vec3;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    BeginList, DefaultElement, ElementDef, Encoding, Property, PropertyAccess,
    PropertyAccessResult, PropertyDef, PropertyType, ScalarType,
};
use std::io::{BufRead, Write};
use std::path::Path;

/// Extra properties a vertex holds inline; more go to the heap.
const INLINE: usize = 8;

/// Face property values a file may hold on its triangles beyond one per byte of the
/// file (each a polygon's value, repeated on every triangle of its fan).
const FACE_VALUE_SLACK: u64 = 16 << 20;

/// An element's scalar properties besides the ones read by name, as f64 (exact for
/// every PLY scalar type) in header order, which is the order ply-rs-bw delivers them
/// in: the first `N` in place (a heap vector per vertex cost a third of the dragon's
/// read), the rest in `spill`. A face keeps none in place: most files' faces have no
/// property but their indices, and 64 bytes a face would cost the dragon 56 MB.
struct Extras<const N: usize> {
    inline: [f64; N],
    spill: Vec<f64>,
    count: usize,
}

impl<const N: usize> Default for Extras<N> {
    fn default() -> Self {
        Self {
            inline: [0.0; N],
            spill: Vec::new(),
            count: 0,
        }
    }
}

impl<const N: usize> Extras<N> {
    fn get(&self, slot: usize) -> f64 {
        match slot.checked_sub(N) {
            None => self.inline[slot],
            Some(s) => self.spill.get(s).copied().unwrap_or(0.0),
        }
    }

    fn push(&mut self, value: f64) {
        match self.inline.get_mut(self.count) {
            Some(slot) => *slot = value,
            None => self.spill.push(value),
        }
        self.count += 1;
    }

    /// Keep `property` when it is a scalar; lists are not kept.
    fn set(&mut self, property: Property) -> PropertyAccessResult {
        match scalar_value(&property) {
            Some(value) => {
                self.push(value);
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::Ignored,
        }
    }
}

/// One vertex: its position and its other scalar properties.
#[derive(Default)]
struct Vertex {
    position: Vec3,
    extras: Extras<INLINE>,
}

fn scalar_value(property: &Property) -> Option<f64> {
    Some(match *property {
        Property::Char(v) => v.into(),
        Property::UChar(v) => v.into(),
        Property::Short(v) => v.into(),
        Property::UShort(v) => v.into(),
        Property::Int(v) => v.into(),
        Property::UInt(v) => v.into(),
        Property::Float(v) => v.into(),
        Property::Double(v) => v,
        _ => return None,
    })
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let axis = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => {
                return self.extras.set(property);
            }
        };
        match property.to_f32_lossy() {
            Some(value) => {
                self.position[axis] = value;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::UnsupportedType,
        }
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        match name {
            "x" => self.position.x = value,
            "y" => self.position.y = value,
            "z" => self.position.z = value,
            _ => self.extras.push(value.into()),
        }
        PropertyAccessResult::Set
    }
}

/// Property names read as one attribute: (attribute, its components' PLY names).
const KNOWN_GROUPS: &[(&str, &[&str])] = &[
    ("NORMAL", &["nx", "ny", "nz"]),
    ("COLOR_0", &["red", "green", "blue", "alpha"]),
    ("COLOR_0", &["red", "green", "blue"]),
    ("COLOR_0", &["r", "g", "b", "a"]),
    ("COLOR_0", &["r", "g", "b"]),
    ("TEXCOORD_0", &["u", "v"]),
    ("TEXCOORD_0", &["s", "t"]),
    ("TEXCOORD_0", &["texture_u", "texture_v"]),
    ("TEXCOORD_0", &["texture_s", "texture_t"]),
    (super::obj::TEXCOORD_W, &["texture_w"]),
];

/// An element's extra properties as attributes: known groups of one type (`nx ny nz`,
/// `red green blue [alpha]`, `u v`, ...) as glTF-named streams, every other scalar
/// property as a stream of its own name; each keeps its PLY names and type. `rows[i]`
/// holds element `i`'s extra properties in `names` order.
fn attributes_of<const N: usize>(
    element: &ElementDef,
    names: &[String],
    rows: &[&Extras<N>],
) -> Vec<VertexAttribute> {
    let scalar_type = |name: &str| match element.properties.get(name).map(|p| &p.data_type) {
        Some(PropertyType::Scalar(t)) => Some(t.clone()),
        _ => None,
    };
    let mut taken = vec![false; names.len()];
    let mut out = Vec::new();
    let make = |attribute: &str, members: &[usize], taken: &mut Vec<bool>| {
        let scalar = scalar_type(&names[members[0]]).expect("a scalar property");
        let data: Vec<f64> = rows
            .iter()
            .flat_map(|row| members.iter().map(|&m| row.get(m)))
            .collect();
        let typed = match scalar {
            ScalarType::Char => AttributeValues::I8(data.iter().map(|&x| x as i8).collect()),
            ScalarType::UChar => AttributeValues::U8(data.iter().map(|&x| x as u8).collect()),
            ScalarType::Short => AttributeValues::I16(data.iter().map(|&x| x as i16).collect()),
            ScalarType::UShort => AttributeValues::U16(data.iter().map(|&x| x as u16).collect()),
            ScalarType::Int => AttributeValues::I32(data.iter().map(|&x| x as i32).collect()),
            ScalarType::UInt => AttributeValues::U32(data.iter().map(|&x| x as u32).collect()),
            ScalarType::Float => AttributeValues::F32(data.iter().map(|&x| x as f32).collect()),
            ScalarType::Double => AttributeValues::F64(data),
        };
        // Colours stored as integers stand for [0, 1].
        let normalized =
            attribute == "COLOR_0" && matches!(scalar, ScalarType::UChar | ScalarType::UShort);
        for &m in members {
            taken[m] = true;
        }
        VertexAttribute {
            name: attribute.to_owned(),
            components: members.len(),
            normalized,
            values: typed,
            component_names: members.iter().map(|&m| names[m].clone()).collect(),
        }
    };
    for (attribute, group) in KNOWN_GROUPS {
        if out.iter().any(|a: &VertexAttribute| a.name == *attribute) {
            continue;
        }
        let members: Option<Vec<usize>> = group
            .iter()
            .map(|g| names.iter().position(|n| n == g))
            .collect();
        let Some(members) = members.filter(|m| !m.iter().any(|&i| taken[i])) else {
            continue;
        };
        let types: Vec<_> = members.iter().map(|&m| scalar_type(&names[m])).collect();
        if types.iter().all(|t| t.is_some() && *t == types[0]) {
            out.push(make(attribute, &members, &mut taken));
        }
    }
    for i in 0..names.len() {
        if !taken[i] {
            out.push(make(&names[i].clone(), &[i], &mut taken));
        }
    }
    out
}

/// One face: its vertex indices and, where `X` keeps them ([`Extras`]), its other
/// scalar properties. A file whose faces hold nothing else reads them as `Face<()>`:
/// 32 bytes a face of nothing would cost the dragon's read a tenth of its time.
#[derive(Default)]
struct Face<X> {
    indices: Vec<u32>,
    extras: X,
}

/// Where a face keeps its properties besides its indices.
trait FaceExtras: Default {
    fn set(&mut self, name: &str, property: Property) -> PropertyAccessResult;
}

impl FaceExtras for () {
    fn set(&mut self, _: &str, _: Property) -> PropertyAccessResult {
        PropertyAccessResult::Ignored
    }
}

/// MeshLab's per-corner texture coordinates: a face list of u, v for each corner.
const WEDGE_TEXCOORD: &str = "texcoord";

/// A face's scalar properties, and its corners' texture coordinates ([`WEDGE_TEXCOORD`],
/// as f32: MeshLab writes them so).
#[derive(Default)]
struct FaceRest {
    extras: Extras<0>,
    texcoord: Vec<f32>,
}

impl FaceExtras for FaceRest {
    fn set(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if name != WEDGE_TEXCOORD {
            return self.extras.set(property);
        }
        self.texcoord = match property {
            Property::ListFloat(uv) => uv,
            Property::ListDouble(uv) => uv.into_iter().map(|x| x as f32).collect(),
            _ => return PropertyAccessResult::Ignored,
        };
        PropertyAccessResult::Set
    }
}

fn is_index_list(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

impl<X: FaceExtras> PropertyAccess for Face<X> {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if !is_index_list(name) {
            return self.extras.set(name, property);
        }
        match property.to_u32_list() {
            Some(list) => {
                self.indices = list;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::UnsupportedType,
        }
    }
    fn begin_list_uint(&mut self, name: &str, _len: usize) -> BeginList<'_, u32> {
        if is_index_list(name) {
            BeginList::Fill(&mut self.indices)
        } else {
            BeginList::UseSetter
        }
    }
    fn set_list_int(&mut self, name: &str, value: Vec<i32>) -> PropertyAccessResult {
        if !is_index_list(name) {
            return PropertyAccessResult::Ignored;
        }
        // Negative indices become huge ones, caught by the range check.
        self.indices = value.into_iter().map(|i| i as u32).collect();
        PropertyAccessResult::Set
    }
}

/// One `tristrips` element: vertex indices, −1 between strips (as a signed value, or
/// as the largest unsigned one in a list of unsigned indices).
#[derive(Default)]
struct Strips(Vec<i64>);

impl PropertyAccess for Strips {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if !is_index_list(name) {
            return PropertyAccessResult::Ignored;
        }
        let restart_unsigned = |v: u64, max: u64| if v == max { -1 } else { v as i64 };
        self.0 = match property {
            Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUChar(v) => v
                .into_iter()
                .map(|i| restart_unsigned(i.into(), u8::MAX.into()))
                .collect(),
            Property::ListUShort(v) => v
                .into_iter()
                .map(|i| restart_unsigned(i.into(), u16::MAX.into()))
                .collect(),
            Property::ListUInt(v) => v
                .into_iter()
                .map(|i| restart_unsigned(i.into(), u32::MAX.into()))
                .collect(),
            _ => return PropertyAccessResult::UnsupportedType,
        };
        PropertyAccessResult::Set
    }
}

/// Append the triangles of `faces` (polygons as fans) to `triangles`, calling
/// `triangle_of(f, i)` for each: face `f`'s corners 0, `i` and `i + 1`; a face of
/// fewer than three corners is an error.
fn fan<X>(
    path: &Path,
    faces: &[Face<X>],
    triangles: &mut Vec<[u32; 3]>,
    mut triangle_of: impl FnMut(usize, usize) -> Result<(), MeshError>,
) -> Result<(), MeshError> {
    triangles.reserve(faces.len());
    for (f, face) in faces.iter().enumerate() {
        let c = &face.indices;
        if c.len() < 3 {
            return Err(MeshError::invalid(
                path,
                format!("face {f} has {} vertices; a face needs at least 3", c.len()),
            ));
        }
        for i in 1..c.len() - 1 {
            triangles.push([c[0], c[i], c[i + 1]]);
            triangle_of(f, i)?;
        }
    }
    Ok(())
}

/// Append the triangles of the strips in `indices` (−1 restarts a strip) to
/// `triangles` ([`crate::strip::standard_triangles`], which drops the ones that name a
/// vertex twice); returns how many were dropped, or the first index that is neither a
/// vertex nor −1.
fn strip_triangles(indices: &[i64], triangles: &mut Vec<[u32; 3]>) -> Result<usize, i64> {
    let mut dropped = 0;
    for strip in indices.split(|&i| i == -1) {
        let strip: Vec<u32> = strip
            .iter()
            .map(|&i| u32::try_from(i).map_err(|_| i))
            .collect::<Result<_, _>>()?;
        dropped += crate::strip::standard_triangles(&strip, triangles);
    }
    Ok(dropped)
}

fn scalar_bytes(t: &ScalarType) -> u64 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// The fewest bytes one element can take in the payload.
fn min_element_bytes(element: &ElementDef, encoding: Encoding) -> u64 {
    let properties = element.properties.values();
    match encoding {
        // Each property is at least one digit and a separator; each element one line.
        Encoding::Ascii => (2 * element.properties.len() as u64).max(1),
        _ => properties
            .map(|p| match &p.data_type {
                PropertyType::Scalar(t) => scalar_bytes(t),
                PropertyType::List(count, _) => scalar_bytes(count),
            })
            .sum::<u64>()
            .max(1),
    }
}

pub(super) fn read<R: BufRead>(
    path: &Path,
    source: CountingReader<'_, R>,
    total_bytes: u64,
) -> Result<Scene, MeshError> {
    let mut reader = Reader::new(source);
    let parse_error = |reader: &Reader<CountingReader<'_, R>>, e: ply_rs_bw::parser::ParseError| {
        let text = e.to_string();
        let message = text
            .split_once(": ")
            .filter(|_| e.line().is_some())
            .map_or(text.clone(), |(_, m)| m.to_string());
        match e.line() {
            Some(line) => MeshError::at_line(path, line, message.replace('\n', " ")),
            None => MeshError::invalid(
                path,
                format!(
                    "at byte {}: {}",
                    reader.get_ref().offset(),
                    message.replace('\n', " ")
                ),
            ),
        }
    };
    let header = Parser::<DefaultElement>::new()
        .read_header(&mut reader)
        .map_err(|e| parse_error(&reader, e))?;
    if header.encoding != Encoding::Ascii {
        reader.get_mut().stop_counting_lines();
    }
    let mut remaining = total_bytes.saturating_sub(reader.get_ref().offset());
    for element in header.elements.values() {
        let needed =
            (element.count as u64).saturating_mul(min_element_bytes(element, header.encoding));
        if needed > remaining {
            return Err(MeshError::invalid(
                path,
                format!(
                    "header declares {} '{}' elements, which need at least {needed} bytes, but only {remaining} bytes follow (truncated file or wrong count)",
                    element.count, element.name
                ),
            ));
        }
        remaining -= needed;
    }
    let Some(vertex) = header.elements.get("vertex") else {
        return Err(MeshError::invalid(
            path,
            "no 'vertex' element in the header",
        ));
    };
    if let Some(axis) = ["x", "y", "z"]
        .into_iter()
        .find(|axis| !vertex.properties.contains_key(*axis))
    {
        return Err(MeshError::invalid(
            path,
            format!("'vertex' element has no '{axis}' property: positions need x, y and z"),
        ));
    }

    if let Some(list) = vertex
        .properties
        .values()
        .find(|p| matches!(p.data_type, PropertyType::List(..)))
    {
        return Err(MeshError::invalid(
            path,
            format!(
                "'vertex' property '{}' is a list; rtmesh keeps scalar vertex properties only",
                list.name
            ),
        ));
    }
    let extra: Vec<String> = vertex
        .properties
        .keys()
        .filter(|k| !["x", "y", "z"].contains(&k.as_str()))
        .cloned()
        .collect();
    let mut mesh = TriMesh::default();
    let mut dropped = 0;
    let mut not_read = Vec::new();
    let mut wedge_texcoords = None;
    for element in header.elements.values() {
        match element.name.as_str() {
            "vertex" => {
                let vertices = Parser::<Vertex>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| parse_error(&reader, e))?;
                let rows: Vec<&Extras<INLINE>> = vertices.iter().map(|v| &v.extras).collect();
                mesh.attributes = attributes_of(element, &extra, &rows);
                mesh.positions = vertices.into_iter().map(|v| v.position).collect();
            }
            "face" => {
                if !element.properties.keys().any(|k| is_index_list(k)) {
                    return Err(MeshError::invalid(
                        path,
                        "'face' element has no 'vertex_indices' list",
                    ));
                }
                let (scalars, lists): (Vec<_>, Vec<_>) = (element.properties.values())
                    .filter(|p| !is_index_list(&p.name))
                    .partition(|p| matches!(p.data_type, PropertyType::Scalar(_)));
                let scalars: Vec<String> = scalars.into_iter().map(|p| p.name.clone()).collect();
                let is_wedge = |p: &PropertyDef| {
                    p.name == WEDGE_TEXCOORD
                        && matches!(
                            p.data_type,
                            PropertyType::List(_, ScalarType::Float | ScalarType::Double)
                        )
                };
                let wedge = lists.iter().any(|p| is_wedge(p));
                not_read.extend(
                    lists
                        .into_iter()
                        .filter(|p| !is_wedge(p))
                        .map(|p| format!("PLY face property '{}' (a list per face)", p.name)),
                );
                if scalars.is_empty() && !wedge {
                    let faces = Parser::<Face<()>>::new()
                        .read_payload_for_element(&mut reader, element, &header)
                        .map_err(|e| parse_error(&reader, e))?;
                    fan(path, &faces, &mut mesh.triangles, |_, _| Ok(()))?;
                    continue;
                }
                let faces = Parser::<Face<FaceRest>>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| parse_error(&reader, e))?;
                // Each triangle of a polygon's fan holds the polygon's properties, and
                // its own three corners' texture coordinates.
                let mut rows: Vec<&Extras<0>> = Vec::new();
                let first = mesh.triangles.len();
                let mut uvs = Vec::new();
                fan(path, &faces, &mut mesh.triangles, |f, i| {
                    let face = &faces[f];
                    if !scalars.is_empty() {
                        rows.push(&face.extras.extras);
                    }
                    if wedge {
                        uvs.push(corner_texcoords(path, f, face, i)?);
                    }
                    Ok(())
                })?;
                if wedge {
                    wedge_texcoords = Some((first, uvs));
                }
                // A polygon's values are repeated on each triangle of its fan: bounded
                // by the file's size, so that a few faces of thousands of corners and
                // properties cannot ask for gigabytes.
                let values = rows.len() as u64 * scalars.len() as u64;
                if values > total_bytes + FACE_VALUE_SLACK {
                    return Err(MeshError::invalid(
                        path,
                        format!(
                            "the faces' {} properties repeated on the {} triangles of their fans make {values} values, more than a file of {total_bytes} bytes can mean (a hostile or corrupt file)",
                            scalars.len(),
                            rows.len()
                        ),
                    ));
                }
                mesh.triangle_attributes = attributes_of(element, &scalars, &rows);
            }
            "tristrips" => {
                if !element.properties.keys().any(|k| is_index_list(k)) {
                    return Err(MeshError::invalid(
                        path,
                        "'tristrips' element has no 'vertex_indices' list",
                    ));
                }
                let strips = Parser::<Strips>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| parse_error(&reader, e))?;
                for (s, strip) in strips.iter().enumerate() {
                    dropped += strip_triangles(&strip.0, &mut mesh.triangles).map_err(|bad| {
                        MeshError::invalid(
                            path,
                            format!("tristrips element {s} has index {bad}, neither a vertex nor the -1 restart"),
                        )
                    })?;
                }
            }
            other => {
                Parser::<DefaultElement>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| parse_error(&reader, e))?;
                not_read.push(format!("PLY element '{other}': {}", element.count));
            }
        }
    }
    if let Some((first, uvs)) = wedge_texcoords {
        split_by_texcoords(&mut mesh, first, &uvs);
    }
    let n = mesh.triangles.len();
    let materials = texture_materials(&header.comments);
    mesh.material_ids = texture_numbers(&mesh, materials.len());
    mesh.alpha_tested = vec![false; n];
    mesh.group_ids = vec![0; n];
    let mut scene = Scene::from_mesh(mesh);
    if !materials.is_empty() {
        scene.materials = materials;
        let plain = scene.meshes[0].material_ids.iter().max();
        if plain.is_some_and(|&m| m as usize >= scene.materials.len()) {
            scene.materials.push(Material::default());
        }
    }
    scene.read_notes.strip_degenerates_dropped = dropped;
    scene.read_notes.not_read = not_read;
    let comments: Vec<String> = (header.comments.iter())
        .filter(|c| !c.trim().starts_with(TEXTURE_FILE) && !c.starts_with(OWN_COMMENT))
        .cloned()
        .collect();
    if !comments.is_empty() || !header.obj_infos.is_empty() {
        scene.document = Some(std::sync::Arc::new(super::Document::Ply {
            comments,
            obj_info: header.obj_infos.clone(),
        }));
    }
    Ok(scene)
}

/// Face `f`'s texture coordinates at its corners 0, `i` and `i + 1` (zeros for a face
/// with none); a face with other than two numbers a corner is an error.
fn corner_texcoords(
    path: &Path,
    f: usize,
    face: &Face<FaceRest>,
    i: usize,
) -> Result<[[f32; 2]; 3], MeshError> {
    let uv = &face.extras.texcoord;
    let corners = face.indices.len();
    if uv.is_empty() {
        return Ok([[0.0; 2]; 3]);
    }
    if uv.len() != 2 * corners {
        return Err(MeshError::invalid(
            path,
            format!(
                "face {f} has {corners} vertices but {} numbers in '{WEDGE_TEXCOORD}' (u and v for each corner)",
                uv.len()
            ),
        ));
    }
    Ok([0, i, i + 1].map(|k| [uv[2 * k], uv[2 * k + 1]]))
}

/// Per-corner texture coordinates (`uvs[t]` for triangle `first + t`) as a vertex
/// attribute: a vertex whose corners differ in them (a seam) is copied, with every
/// attribute, once for each other pair, as OBJ's reader does for `vt`.
fn split_by_texcoords(mesh: &mut TriMesh, first: usize, uvs: &[[[f32; 2]; 3]]) {
    let n = mesh.positions.len();
    let bits = |uv: [f32; 2]| uv.map(f32::to_bits);
    let mut texcoords = vec![[0.0f32; 2]; n];
    let mut taken: Vec<Option<[u32; 2]>> = vec![None; n];
    let mut copies: std::collections::HashMap<(u32, [u32; 2]), u32> = Default::default();
    for (t, corners) in uvs.iter().enumerate() {
        for (k, &uv) in corners.iter().enumerate() {
            let v = mesh.triangles[first + t][k];
            let Some(slot) = taken.get_mut(v as usize) else {
                continue; // out of range: the index check reports it
            };
            match *slot {
                None => {
                    *slot = Some(bits(uv));
                    texcoords[v as usize] = uv;
                }
                Some(held) if held == bits(uv) => {}
                Some(_) => {
                    let copy = *copies.entry((v, bits(uv))).or_insert_with(|| {
                        texcoords.push(uv);
                        mesh.copy_vertex(v as usize)
                    });
                    mesh.triangles[first + t][k] = copy;
                }
            }
        }
    }
    let held: Vec<&str> = mesh.attributes.iter().map(|a| a.name.as_str()).collect();
    let name = (0..)
        .map(|set| format!("TEXCOORD_{set}"))
        .find(|name| !held.contains(&name.as_str()))
        .expect("a free texture coordinate set");
    let mut attribute = VertexAttribute::from_f32(&name, &texcoords);
    attribute.component_names = vec!["texture_u".into(), "texture_v".into()];
    mesh.attributes.push(attribute);
}

/// MeshLab's comment naming a texture: `comment TextureFile NAME`.
const TEXTURE_FILE: &str = "TextureFile";

/// MeshLab's face property naming a face's texture, an index into the
/// [`TEXTURE_FILE`] comments.
pub(super) const TEXNUMBER: &str = "texnumber";

/// The materials of MeshLab's [`TEXTURE_FILE`] comments, in order (the faces'
/// `texnumber` indexes them): each a white material with NAME as its diffuse map.
fn texture_materials(comments: &[String]) -> Vec<Material> {
    let files = (comments.iter())
        .filter_map(|c| c.trim().strip_prefix(TEXTURE_FILE))
        .map(str::trim)
        .filter(|file| !file.is_empty());
    let material = |file: &str| Material {
        name: (Path::new(file).file_stem())
            .map(|s| s.to_string_lossy().replace(char::is_whitespace, "_"))
            .unwrap_or_default(),
        alpha_tested: false,
        mtl: Some(MtlLook::plain_texture(file)),
    };
    files.map(material).collect()
}

/// Each triangle's material: its face's `texnumber` (kept as a triangle attribute too)
/// where it names one of the `textures`; `textures` (an untextured material after them)
/// where it names none; 0 without a `texnumber` property.
fn texture_numbers(mesh: &TriMesh, textures: usize) -> Vec<u32> {
    let n = mesh.triangles.len();
    let numbers =
        (mesh.triangle_attribute(TEXNUMBER)).filter(|a| a.components == 1 && textures > 0);
    let Some(numbers) = numbers else {
        return vec![0; n];
    };
    let material = |number: f64| match number >= 0.0 && number < textures as f64 {
        true => number as u32,
        false => textures as u32,
    };
    (0..n).map(|t| material(numbers.get(t, 0))).collect()
}

/// The PLY names of an attribute's components: the source's, or `nx ny nz`,
/// `red green blue alpha`, `u v` for the known ones, or `name_c` per component.
fn property_names(attribute: &VertexAttribute) -> Vec<String> {
    if attribute.component_names.len() == attribute.components {
        return attribute.component_names.clone();
    }
    let known: &[&str] = match attribute.name.as_str() {
        "NORMAL" => &["nx", "ny", "nz"],
        "COLOR_0" => &["red", "green", "blue", "alpha"],
        "TEXCOORD_0" => &["u", "v"],
        super::obj::TEXCOORD_W => &["texture_w"],
        _ => &[],
    };
    let base = attribute
        .name
        .trim_start_matches('_')
        .to_ascii_lowercase()
        .replace(':', "_");
    (0..attribute.components)
        .map(|c| match known.get(c) {
            Some(name) => name.to_string(),
            None if attribute.components == 1 => base.clone(),
            None => format!("{base}_{c}"),
        })
        .collect()
}

fn scalar_type(attribute: &VertexAttribute) -> ScalarType {
    match &attribute.values {
        AttributeValues::U8(_) => ScalarType::UChar,
        AttributeValues::I8(_) => ScalarType::Char,
        AttributeValues::U16(_) => ScalarType::UShort,
        AttributeValues::I16(_) => ScalarType::Short,
        AttributeValues::U32(_) => ScalarType::UInt,
        AttributeValues::I32(_) => ScalarType::Int,
        AttributeValues::F32(_) => ScalarType::Float,
        AttributeValues::F64(_) => ScalarType::Double,
    }
}

/// The attribute as PLY holds its meaning: PLY has no `normalized` flag, and its
/// readers (rtmesh's among them) take integer colours for [0, 1] and every other
/// integer as the number it is, so other normalized integers are written as the f32
/// numbers they stand for.
fn as_ply_holds(attribute: &VertexAttribute) -> std::borrow::Cow<'_, VertexAttribute> {
    let integer_colour = attribute.name == "COLOR_0"
        && matches!(
            attribute.values,
            AttributeValues::U8(_) | AttributeValues::U16(_)
        );
    match integer_colour {
        true => std::borrow::Cow::Borrowed(attribute),
        false => attribute.dequantized(),
    }
}

/// Binary little-endian PLY: the header through ply-rs-bw's writer (x, y, z, then
/// every attribute's components under their PLY names and types), the payload in bulk
/// in the header's order (per-property callbacks cost several times as much on the
/// dragon).
/// `header` holds the source's comment and obj_info lines, written after rtmesh's own.
pub(super) fn write(
    mesh: &TriMesh,
    materials: &[Material],
    header: Option<(&[String], &[String])>,
    path: &Path,
) -> std::io::Result<()> {
    write_with(
        mesh,
        texture_files(materials).as_deref(),
        header,
        None,
        path,
    )
}

/// The texture files MeshLab's [`TEXTURE_FILE`] comments can give `materials`: each
/// material's diffuse map, in order, where every material has one (past the last, plain
/// materials may follow: those a `texnumber` names no texture for); `None` otherwise.
pub(super) fn texture_files(materials: &[Material]) -> Option<Vec<&str>> {
    fn map(m: &Material) -> Option<&str> {
        m.mtl
            .as_ref()?
            .diffuse_map
            .as_ref()
            .map(|m| m.file.as_str())
    }
    let textured = materials.iter().take_while(|m| map(m).is_some()).count();
    let rest_plain = materials[textured..]
        .iter()
        .all(|m| *m == Material::default());
    (textured > 0 && rest_plain).then(|| materials[..textured].iter().filter_map(map).collect())
}

/// [`write`] with the triangles as one `tristrips` element instead of faces: the
/// rasterization strips `strips`, joined by −1 restarts.
pub(super) fn write_strips(
    mesh: &TriMesh,
    strips: &[Vec<u32>],
    path: &Path,
) -> std::io::Result<()> {
    write_with(mesh, None, None, Some(strips), path)
}

/// The comment rtmesh's PLY files start with (then the version): not kept on reading,
/// so that round trips do not pile them up.
const OWN_COMMENT: &str = "written by rtmesh";

fn write_with(
    mesh: &TriMesh,
    textures: Option<&[&str]>,
    kept: Option<(&[String], &[String])>,
    strips: Option<&[Vec<u32>]>,
    path: &Path,
) -> std::io::Result<()> {
    use ply_rs_bw::ply::{Addable, Header, PropertyDef};
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    let mut header = Header::new();
    header.encoding = Encoding::BinaryLittleEndian;
    header
        .comments
        .push(format!("{OWN_COMMENT} {}", env!("CARGO_PKG_VERSION")));
    if let Some((comments, obj_info)) = kept {
        header.comments.extend_from_slice(comments);
        header.obj_infos.extend_from_slice(obj_info);
    }
    for file in textures.into_iter().flatten() {
        header.comments.push(format!("{TEXTURE_FILE} {file}"));
    }
    let mut vertex = ElementDef::new("vertex".into());
    vertex.count = mesh.positions.len();
    for axis in ["x", "y", "z"] {
        vertex.properties.add(PropertyDef::new(
            axis.into(),
            PropertyType::Scalar(ScalarType::Float),
        ));
    }
    // Morph-target deltas have no PLY meaning without their targets' weights; they
    // are kept like any other attribute, under their own names.
    let attributes: Vec<_> = mesh.attributes.iter().map(as_ply_holds).collect();
    add_properties(&mut vertex, &attributes);
    header.elements.add(vertex);
    let mut face = ElementDef::new(
        if strips.is_some() {
            "tristrips"
        } else {
            "face"
        }
        .into(),
    );
    face.count = if strips.is_some() {
        1
    } else {
        mesh.triangles.len()
    };
    let list = match strips {
        Some(_) => PropertyType::List(ScalarType::Int, ScalarType::Int),
        None => PropertyType::List(ScalarType::UChar, ScalarType::UInt),
    };
    face.properties
        .add(PropertyDef::new("vertex_indices".into(), list));
    // A strip has no place for a triangle's own properties.
    let mut triangle_attributes: Vec<_> = match strips {
        Some(_) => Vec::new(),
        None => mesh.triangle_attributes.iter().map(as_ply_holds).collect(),
    };
    // Several textures: each face names its own by `texnumber`, unless it holds one.
    let numbered = mesh.triangle_attribute(TEXNUMBER).is_some();
    if textures.is_some_and(|t| t.len() > 1) && !numbered && strips.is_none() {
        let numbers: Vec<i32> = mesh.material_ids.iter().map(|&m| m as i32).collect();
        triangle_attributes.push(std::borrow::Cow::Owned(VertexAttribute {
            name: TEXNUMBER.to_owned(),
            components: 1,
            normalized: false,
            values: AttributeValues::I32(numbers),
            component_names: vec![TEXNUMBER.to_owned()],
        }));
    }
    add_properties(&mut face, &triangle_attributes);
    header.elements.add(face);
    ply_rs_bw::writer::Writer::<DefaultElement>::new()
        .write_header(&mut out, &header)
        .map_err(std::io::Error::other)?;
    let mut row = Vec::with_capacity(64);
    for (v, p) in mesh.positions.iter().enumerate() {
        row.clear();
        for c in p.to_array() {
            row.extend_from_slice(&c.to_le_bytes());
        }
        for attribute in &attributes {
            attribute.push_vertex_bytes(v, &mut row);
        }
        out.write_all(&row)?;
    }
    if let Some(strips) = strips {
        let joined: Vec<i32> = strips
            .iter()
            .enumerate()
            .flat_map(|(s, strip)| {
                let restart = (s > 0).then_some(-1);
                restart.into_iter().chain(strip.iter().map(|&v| v as i32))
            })
            .collect();
        out.write_all(&(joined.len() as i32).to_le_bytes())?;
        for v in joined {
            out.write_all(&v.to_le_bytes())?;
        }
        return out.flush();
    }
    for (t, triangle) in mesh.triangles.iter().enumerate() {
        row.clear();
        row.push(3);
        for v in triangle {
            row.extend_from_slice(&v.to_le_bytes());
        }
        for attribute in &triangle_attributes {
            attribute.push_vertex_bytes(t, &mut row);
        }
        out.write_all(&row)?;
    }
    out.flush()
}

/// Each attribute's components as scalar properties of `element`, under their PLY
/// names and in their types.
fn add_properties(element: &mut ElementDef, attributes: &[std::borrow::Cow<'_, VertexAttribute>]) {
    use ply_rs_bw::ply::{Addable, PropertyDef};
    for attribute in attributes {
        for name in property_names(attribute) {
            let scalar = PropertyType::Scalar(scalar_type(attribute));
            element.properties.add(PropertyDef::new(name, scalar));
        }
    }
}

//! Stanford PLY through ply-rs-bw, ascii and binary, with typed element structs (no
//! per-vertex hash maps) so the 871k-triangle dragon reads in well under a second.
//! Before any payload is read, each element count in the header is checked against the
//! bytes left in the file, so an absurd header (4e9 vertices) is an error, not an
//! allocation. Faces are `vertex_indices` (or `vertex_index`) lists of any integer type;
//! polygons are fan-triangulated. Triangle strips (a `tristrips` element, as some
//! scanned models ship: lists of vertex indices with −1 between strips) are decoded
//! with alternating winding, and the strips' degenerate triangles (the swaps and joins
//! that stitch a generalized strip, naming a vertex twice) are dropped and counted in
//! [`crate::mesh::ReadNotes`]. The writer emits binary little-endian PLY directly:
//! the format is a header and two packed arrays, and writing them in bulk is far faster
//! than going through per-property callbacks.

use super::{CountingReader, MeshError};
use crate::mesh::{Scene, TriMesh};
use glam::Vec3;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    BeginList, DefaultElement, ElementDef, Encoding, Property, PropertyAccess,
    PropertyAccessResult, PropertyType, ScalarType,
};
use std::io::{BufRead, Write};
use std::path::Path;

#[derive(Default)]
struct Vertex(Vec3);

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let axis = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return PropertyAccessResult::Ignored,
        };
        match property.to_f32_lossy() {
            Some(value) => {
                self.0[axis] = value;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::UnsupportedType,
        }
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        self.set_property(name, Property::Float(value))
    }
}

#[derive(Default)]
struct Face(Vec<u32>);

fn is_index_list(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if !is_index_list(name) {
            return PropertyAccessResult::Ignored;
        }
        match property.to_u32_list() {
            Some(list) => {
                self.0 = list;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::UnsupportedType,
        }
    }
    fn begin_list_uint(&mut self, name: &str, _len: usize) -> BeginList<'_, u32> {
        if is_index_list(name) {
            BeginList::Fill(&mut self.0)
        } else {
            BeginList::UseSetter
        }
    }
    fn set_list_int(&mut self, name: &str, value: Vec<i32>) -> PropertyAccessResult {
        if !is_index_list(name) {
            return PropertyAccessResult::Ignored;
        }
        // Negative indices become huge ones, caught by the range check.
        self.0 = value.into_iter().map(|i| i as u32).collect();
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

/// Append the triangles of the strips in `indices` (−1 restarts a strip) to
/// `triangles`: triangle `i` of a strip `s` is `(s[i], s[i+1], s[i+2])` for even `i`
/// and `(s[i+1], s[i], s[i+2])` for odd `i`, so all keep one winding. Triangles that
/// name a vertex twice are dropped; returns how many, or the first index that is
/// neither a vertex nor −1.
fn strip_triangles(indices: &[i64], triangles: &mut Vec<[u32; 3]>) -> Result<usize, i64> {
    let mut dropped = 0;
    for strip in indices.split(|&i| i == -1) {
        if let Some(&bad) = strip.iter().find(|&&i| !(0..=u32::MAX as i64).contains(&i)) {
            return Err(bad);
        }
        for (i, w) in strip.windows(3).enumerate() {
            let [a, b, c] = [w[0] as u32, w[1] as u32, w[2] as u32];
            if a == b || b == c || a == c {
                dropped += 1;
            } else if i % 2 == 0 {
                triangles.push([a, b, c]);
            } else {
                triangles.push([b, a, c]);
            }
        }
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

    let mut mesh = TriMesh::default();
    let mut dropped = 0;
    for element in header.elements.values() {
        match element.name.as_str() {
            "vertex" => {
                let vertices = Parser::<Vertex>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| parse_error(&reader, e))?;
                mesh.positions = vertices.into_iter().map(|v| v.0).collect();
            }
            "face" => {
                if !element.properties.keys().any(|k| is_index_list(k)) {
                    return Err(MeshError::invalid(
                        path,
                        "'face' element has no 'vertex_indices' list",
                    ));
                }
                let faces = Parser::<Face>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| parse_error(&reader, e))?;
                mesh.triangles.reserve(faces.len());
                for (f, face) in faces.iter().enumerate() {
                    if face.0.len() < 3 {
                        return Err(MeshError::invalid(
                            path,
                            format!(
                                "face {f} has {} vertices; a face needs at least 3",
                                face.0.len()
                            ),
                        ));
                    }
                    let c = &face.0;
                    for i in 1..c.len() - 1 {
                        mesh.triangles.push([c[0], c[i], c[i + 1]]);
                    }
                }
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
            _ => {
                Parser::<DefaultElement>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| parse_error(&reader, e))?;
            }
        }
    }
    let n = mesh.triangles.len();
    mesh.material_ids = vec![0; n];
    mesh.alpha_tested = vec![false; n];
    let mut scene = Scene::from_mesh(mesh);
    scene.read_notes.strip_degenerates_dropped = dropped;
    Ok(scene)
}

pub(super) fn write(mesh: &TriMesh, path: &Path) -> std::io::Result<()> {
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment written by rtmesh {}\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        env!("CARGO_PKG_VERSION"),
        mesh.positions.len(),
        mesh.triangles.len()
    )?;
    for p in &mesh.positions {
        for c in p.to_array() {
            out.write_all(&c.to_le_bytes())?;
        }
    }
    for t in &mesh.triangles {
        out.write_all(&[3])?;
        for v in t {
            out.write_all(&v.to_le_bytes())?;
        }
    }
    out.flush()
}

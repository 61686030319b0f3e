//! STL, binary and ascii, as CAD tools write it: a triangle soup, each facet its own
//! three corners and a facet normal. The normal is dropped (it is the corners' cross
//! product, or wrong); the corners are welded by exact position (bit patterns, -0.0 =
//! +0.0) to recover the shared vertices, so positions stay bit-exact and `info` counts
//! what it counts for the same mesh in OBJ. Ascii `solid NAME` blocks become one
//! geometry each, named NAME.
//!
//! A file is binary when its size is exactly the 84-byte header plus 50 bytes per
//! triangle its count declares; otherwise it is ascii when it starts with `solid` and
//! is UTF-8 text without NUL bytes (binary files may start with `solid` too, which is
//! why the size decides first); any other file is a binary one whose count the bytes do
//! not hold, an error naming the file. Cost: O(T) to parse, plus the weld (hashing, O(T)); memory: the file's bytes
//! and the corners.
//!
//! A binary facet's 16-bit attribute word, where any facet's is not zero (colour
//! extensions keep a facet colour in it), is kept as the triangle attribute
//! [`ATTRIBUTE_WORD`], in PLY a face property of that name.
//!
//! A binary file's 80-byte header (free bytes: a name, a note, Materialise's `COLOR=`
//! default colour) is kept as the scene's [`super::Document::Stl`].
//!
//! The writer emits binary STL of the flattened scene, with the facet normals computed
//! from the corners, the attribute words kept (zero for a mesh without them) and the
//! source's header where it was a binary STL (else one naming rtmesh).

use super::{CountingReader, MeshError};
use crate::mesh::{weld_exact, Scene, TriMesh};
use glam::{Affine3A, Vec3};
use std::io::{BufRead, Write};
use std::path::Path;

/// Bytes of the binary header: 80 free bytes, then the triangle count.
const HEADER_BYTES: usize = 84;
/// Bytes of one binary facet: normal, three corners (12 f32), attribute word.
const FACET_BYTES: usize = 50;

pub(super) fn read<R: BufRead>(
    path: &Path,
    mut source: CountingReader<'_, R>,
) -> Result<Scene, MeshError> {
    let bytes = source.read_all(path)?;
    let declared = (bytes.len() >= HEADER_BYTES)
        .then(|| u32::from_le_bytes(bytes[80..84].try_into().expect("four bytes")) as usize);
    let binary_size = declared.map(|n| HEADER_BYTES as u64 + FACET_BYTES as u64 * n as u64);
    if binary_size == Some(bytes.len() as u64) {
        return Ok(read_binary(&bytes));
    }
    let text = bytes.trim_ascii_start();
    let looks_ascii = text.starts_with(b"solid")
        && (text.len() == 5 || text[5].is_ascii_whitespace())
        && !bytes.contains(&0)
        && std::str::from_utf8(&bytes).is_ok();
    if looks_ascii {
        return read_ascii(path, &bytes);
    }
    Err(MeshError::invalid(
        path,
        match (declared, binary_size) {
            (Some(n), Some(needed)) => format!(
                "binary STL header declares {n} triangles, which need {needed} bytes, but the file has {} (truncated file or wrong count)",
                bytes.len()
            ),
            _ => format!(
                "{} bytes: too short for a binary STL header (84 bytes) and not ascii STL (`solid ...`)",
                bytes.len()
            ),
        },
    ))
}

/// The triangle attribute holding binary STL's per-facet attribute word.
pub const ATTRIBUTE_WORD: &str = "stl_attribute";

/// A binary STL whose size matches its count.
fn read_binary(bytes: &[u8]) -> Scene {
    let float = |at: &[u8]| f32::from_le_bytes(at[..4].try_into().expect("four bytes"));
    // Each facet: the normal (skipped), three corners, the attribute word.
    let corners: Vec<Vec3> = bytes[HEADER_BYTES..]
        .chunks_exact(FACET_BYTES)
        .flat_map(|facet| {
            facet[12..48]
                .chunks_exact(12)
                .map(|c| Vec3::new(float(&c[0..]), float(&c[4..]), float(&c[8..])))
        })
        .collect();
    let words: Vec<u16> = (bytes[HEADER_BYTES..].chunks_exact(FACET_BYTES))
        .map(|facet| u16::from_le_bytes([facet[48], facet[49]]))
        .collect();
    let mut mesh = welded(String::new(), corners);
    if words.iter().any(|&w| w != 0) {
        mesh.triangle_attributes.push(crate::mesh::VertexAttribute {
            name: ATTRIBUTE_WORD.to_owned(),
            components: 1,
            normalized: false,
            values: crate::mesh::AttributeValues::U16(words),
            component_names: vec![ATTRIBUTE_WORD.to_owned()],
        });
    }
    let mut scene = Scene::default();
    scene.push_mesh(mesh, Affine3A::IDENTITY);
    let header = bytes[..80].try_into().expect("80 bytes");
    scene.document = Some(std::sync::Arc::new(super::Document::Stl { header }));
    finish(scene)
}

/// An ascii STL: `solid`, `facet normal`, `outer loop`, three `vertex`, `endloop`,
/// `endfacet`, `endsolid`, one geometry per solid.
fn read_ascii(path: &Path, bytes: &[u8]) -> Result<Scene, MeshError> {
    let mut scene = Scene::default();
    // The current solid: its name and corners, three per facet.
    let mut solid: Option<(String, Vec<Vec3>)> = None;
    // Corners of the current facet's loop, counted.
    let mut in_loop: Option<usize> = None;
    for (number, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let number = number + 1;
        let error = |message: String| MeshError::at_line(path, number, message);
        let line = std::str::from_utf8(line).map_err(|_| {
            error("not UTF-8 text (and not binary STL: its size does not match its count)".into())
        })?;
        let mut words = line.split_ascii_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        match (keyword, &mut solid) {
            ("solid", None) => {
                let name = line.trim_start()[5..].trim().to_owned();
                solid = Some((name, Vec::new()));
            }
            ("endsolid", Some(_)) => {
                if in_loop.is_some() {
                    return Err(error("endsolid inside a facet".into()));
                }
                let (name, corners) = solid.take().expect("inside a solid");
                scene.push_mesh(welded(name, corners), Affine3A::IDENTITY);
            }
            ("facet", Some(_)) | ("endfacet", Some(_)) => {}
            ("outer", Some(_)) => {
                if in_loop.is_some() {
                    return Err(error("outer loop inside a loop".into()));
                }
                in_loop = Some(0);
            }
            ("vertex", Some((_, corners))) => {
                let Some(count) = in_loop.as_mut() else {
                    return Err(error("vertex outside an outer loop".into()));
                };
                *count += 1;
                if *count > 3 {
                    return Err(error("a facet with more than 3 vertices".into()));
                }
                let mut axis = || -> Result<f32, MeshError> {
                    let word = words
                        .next()
                        .ok_or_else(|| error("vertex needs three coordinates".into()))?;
                    word.parse()
                        .map_err(|_| error(format!("vertex coordinate `{word}` is not a number")))
                };
                corners.push(Vec3::new(axis()?, axis()?, axis()?));
            }
            ("endloop", Some(_)) => match in_loop.take() {
                Some(3) => {}
                Some(n) => {
                    return Err(error(format!(
                        "a facet with {n} vertices; STL facets have 3"
                    )))
                }
                None => return Err(error("endloop outside a loop".into())),
            },
            ("solid", Some(_)) => return Err(error("solid inside a solid".into())),
            (_, None) => {
                return Err(error(format!(
                    "`{keyword}` outside a solid (expected `solid NAME`)"
                )))
            }
            (other, Some(_)) => return Err(error(format!("unknown STL keyword `{other}`"))),
        }
    }
    if solid.is_some() {
        return Err(MeshError::invalid(
            path,
            "the last solid has no endsolid (truncated file?)",
        ));
    }
    Ok(finish(scene))
}

/// One geometry from a soup of corners, three per triangle, welded by exact position.
fn welded(name: String, corners: Vec<Vec3>) -> TriMesh {
    let triangles = (0..corners.len() as u32 / 3)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect();
    let mut mesh = weld_exact(&TriMesh::new(corners, triangles)).mesh;
    mesh.name = name;
    mesh
}

/// The scene with one default material and the file's vertex records counted.
fn finish(mut scene: Scene) -> Scene {
    scene.materials = vec![Default::default()];
    scene.source_vertex_count = Some(
        3 * scene
            .meshes
            .iter()
            .map(TriMesh::triangle_count)
            .sum::<usize>(),
    );
    scene
}

/// How the header of a binary STL that rtmesh wrote from another format starts (then
/// the version).
pub(super) const OWN_HEADER: &str = "binary STL written by rtmesh";

/// A binary STL header as text: bytes that are not printable ASCII as `\xNN`, trailing
/// spaces and NULs left out (empty for a blank header).
pub fn header_text(header: &[u8; 80]) -> String {
    let end = header.iter().rposition(|&b| b != b' ' && b != 0);
    header[..end.map_or(0, |e| e + 1)]
        .escape_ascii()
        .to_string()
}

/// Write `mesh` as binary STL, with `header` (a binary source's) or one naming rtmesh.
pub(super) fn write(mesh: &TriMesh, header: Option<&[u8; 80]>, path: &Path) -> std::io::Result<()> {
    let count = u32::try_from(mesh.triangle_count()).map_err(|_| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "binary STL holds at most 2³² − 1 triangles",
        )
    })?;
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    let header = header.copied().unwrap_or_else(|| {
        let mut header = [b' '; 80];
        let title = format!("{OWN_HEADER} {}", env!("CARGO_PKG_VERSION"));
        header[..title.len()].copy_from_slice(title.as_bytes());
        header
    });
    out.write_all(&header)?;
    out.write_all(&count.to_le_bytes())?;
    let words = mesh
        .triangle_attribute(ATTRIBUTE_WORD)
        .filter(|a| a.components == 1);
    for t in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.corners(t);
        let normal = (b - a).cross(c - a).normalize_or_zero();
        for v in [normal, a, b, c] {
            for x in v.to_array() {
                out.write_all(&x.to_le_bytes())?;
            }
        }
        let word = words.map_or(0, |w| w.get(t, 0) as u16);
        out.write_all(&word.to_le_bytes())?;
    }
    out.flush()
}

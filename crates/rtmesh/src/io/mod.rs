//! Reading and writing meshes: OBJ (tobj), PLY (ply-rs-bw), glTF/GLB (gltf) and STL.
//!
//! Every reader returns a [`MeshError`] on bad input, never panics, and names the file
//! and, where the format has lines, the line (OBJ, ascii PLY) or else the byte offset or
//! element. Writers keep triangle order exactly, so optimizers can rely on it (glTF
//! within each primitive: one per group and material, see `gltf/write.rs`).
//!
//! Repairs done while reading, and documented here: polygons are fan-triangulated
//! (`v0, vi, vi+1`); OBJ vertices are renumbered in order of first use per geometry
//! (tobj's behaviour), unused vertices dropped. NaN and infinite positions are kept
//! (DXR treats NaN triangles as inactive); [`crate::mesh::validate`] reports them.

pub(crate) mod gltf;
mod obj;
mod ply;
mod reference;
mod side_files;
mod stl;

pub use gltf::GltfDocument;
pub use obj::MAX_MATERIAL_LIBRARY_BYTES;
pub use reference::MAX_REFERENCED_BYTES;
pub use side_files::{check_side_files, copy_side_files, SideFileCheck, SideFiles};
pub(crate) use stl::header_text as stl_header_text;

use crate::mesh::{Material, Scene, TriMesh};
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

/// Errors from reading or writing a mesh file. Each names the file.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The file could not be opened, read or written.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        error: std::io::Error,
    },
    /// A syntax or content error at a known line (1-based).
    #[error("{}:{line}: {message}", path.display())]
    AtLine {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// An error in a binary file, or one without a line to point at.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong, with the byte offset or element where known.
        message: String,
    },
    /// The extension is not one rtmesh reads or writes.
    #[error("{}: unknown mesh format (expected .obj, .ply, .gltf, .glb or .stl)", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
}

impl MeshError {
    pub(crate) fn invalid(path: &Path, message: impl Into<String>) -> Self {
        Self::Invalid {
            path: path.to_owned(),
            message: message.into(),
        }
    }

    pub(crate) fn at_line(path: &Path, line: usize, message: impl Into<String>) -> Self {
        Self::AtLine {
            path: path.to_owned(),
            line,
            message: message.into(),
        }
    }

    pub(crate) fn io(path: &Path, error: std::io::Error) -> Self {
        Self::Io {
            path: path.to_owned(),
            error,
        }
    }
}

/// The mesh file formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Wavefront OBJ (text).
    Obj,
    /// Stanford PLY (ascii or binary; written as binary little-endian).
    Ply,
    /// glTF 2.0 JSON with a `.bin` beside it.
    Gltf,
    /// glTF 2.0 binary.
    Glb,
    /// STL, binary or ascii (written as binary).
    Stl,
}

impl Format {
    /// The format named by `path`'s extension.
    pub fn from_path(path: &Path) -> Result<Self, MeshError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("obj") => Ok(Self::Obj),
            Some("ply") => Ok(Self::Ply),
            Some("gltf") => Ok(Self::Gltf),
            Some("glb") => Ok(Self::Glb),
            Some("stl") => Ok(Self::Stl),
            _ => Err(MeshError::UnknownFormat {
                path: path.to_owned(),
            }),
        }
    }
}

/// Called with (bytes read so far, total bytes) while a file is read.
pub type Progress<'a> = &'a mut dyn FnMut(u64, u64);

/// How to read a mesh file.
#[derive(Clone, Debug, Default)]
pub struct ReadOptions {
    /// The folder the files a mesh refers to (OBJ `mtllib`, glTF buffers) must stay in;
    /// `None`: the mesh's own folder. References still resolve relative to the mesh's
    /// folder; a root above it lets them climb (`../shared/wood.mtl`) as far as it.
    pub asset_root: Option<PathBuf>,
}

/// Read a mesh file into a [`Scene`].
pub fn read(path: &Path) -> Result<Scene, MeshError> {
    read_with_progress(path, &mut |_, _| {})
}

/// Read a mesh file, reporting progress in bytes.
pub fn read_with_progress(path: &Path, progress: Progress) -> Result<Scene, MeshError> {
    read_with(path, &ReadOptions::default(), progress)
}

/// Read a mesh file with `options`, reporting progress in bytes.
pub fn read_with(
    path: &Path,
    options: &ReadOptions,
    progress: Progress,
) -> Result<Scene, MeshError> {
    let format = Format::from_path(path)?;
    let file = std::fs::File::open(path).map_err(|e| MeshError::io(path, e))?;
    let total = file.metadata().map(|m| m.len()).unwrap_or(0);
    let reader = std::io::BufReader::with_capacity(1 << 16, file);
    let root = options
        .asset_root
        .clone()
        .unwrap_or_else(|| reference::asset_folder(path));
    read_counted(
        path,
        format,
        CountingReader::new(reader, total, progress),
        total,
        &root,
    )
}

/// Read a mesh from bytes in memory, as if from a file called `name` (the extension
/// picks the format). glTF files that refer to external buffers cannot be read this way.
pub fn read_bytes(name: &Path, bytes: &[u8]) -> Result<Scene, MeshError> {
    let format = Format::from_path(name)?;
    let total = bytes.len() as u64;
    let mut ignore = |_: u64, _: u64| {};
    read_counted(
        name,
        format,
        CountingReader::new(bytes, total, &mut ignore),
        total,
        &reference::asset_folder(name),
    )
}

/// The reader of `format` over `reader` (`total` bytes; references stay in `root`),
/// then the index check every reader ends with.
fn read_counted<R: BufRead>(
    path: &Path,
    format: Format,
    reader: CountingReader<'_, R>,
    total: u64,
    root: &Path,
) -> Result<Scene, MeshError> {
    let scene = match format {
        Format::Obj => obj::read(path, reader, root)?,
        Format::Ply => ply::read(path, reader, total)?,
        Format::Gltf | Format::Glb => gltf::read(path, reader, root)?,
        Format::Stl => stl::read(path, reader)?,
    };
    check_indices(path, &scene)?;
    Ok(scene)
}

/// What a file held beyond the mesh model, kept with the scene so that a writer of the
/// same format writes it back unchanged.
#[derive(Clone, Debug)]
pub enum Document {
    /// OBJ: the `mtllib` references, as written ([`copy_side_files`] copies the files).
    Obj {
        /// Each `mtllib` statement's argument, in file order.
        material_libraries: Vec<String>,
    },
    /// glTF/GLB: the whole document and its buffers.
    Gltf(Box<GltfDocument>),
    /// PLY: the header's `comment` and `obj_info` lines (MeshLab's `TextureFile`
    /// comments, which the materials hold, and rtmesh's own left out), written back by
    /// the PLY writer.
    Ply {
        /// Each `comment` line's text, in header order.
        comments: Vec<String>,
        /// Each `obj_info` line's text, in header order.
        obj_info: Vec<String>,
    },
    /// Binary STL: its 80-byte header, free bytes that tools fill with a name, a note
    /// or a default colour (Materialise's `COLOR=`), written back by the STL writer.
    Stl {
        /// The header, as read.
        header: [u8; 80],
    },
}

impl PartialEq for Document {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (
                Self::Obj { material_libraries },
                Self::Obj {
                    material_libraries: theirs,
                },
            ) => material_libraries == theirs,
            (Self::Stl { header }, Self::Stl { header: theirs }) => header == theirs,
            (
                Self::Ply { comments, obj_info },
                Self::Ply {
                    comments: their_comments,
                    obj_info: their_obj_info,
                },
            ) => comments == their_comments && obj_info == their_obj_info,
            (Self::Gltf(a), Self::Gltf(b)) => {
                a.buffers == b.buffers
                    && serde_json::to_value(&a.root).ok() == serde_json::to_value(&b.root).ok()
            }
            _ => false,
        }
    }
}

/// What a writer changed because the format could not hold it.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct WriteNotes {
    /// Inactive triangles (with a NaN or infinite corner) written as degenerate
    /// triangles collapsed onto one of their finite corners: glTF forbids non-finite
    /// positions. They keep their place in the triangle order and cover nothing.
    pub inactive_collapsed: usize,
    /// Normals and tangents that were not unit length (or not finite) written
    /// renormalized: glTF asks for unit vectors.
    pub normals_renormalized: usize,
    /// Vertices whose float skin weights did not sum to one, written scaled so that
    /// they do: glTF asks for normalized weights.
    pub weights_renormalized: usize,
    /// What the format cannot hold and the output goes without, in words (vertex or
    /// triangle attributes by name, a glTF's skins and animations, material terms MTL
    /// has no place for). Empty for glTF/GLB, and for a format written from itself.
    pub not_held: Vec<String>,
    /// What the input holds that its reader did not read, so that no output has it, in
    /// words: an OBJ's lines and points, a PLY's elements other than vertices, faces
    /// and strips, and its faces' list properties.
    pub not_read: Vec<String>,
    /// The files written beside the output for it: an OBJ's material library
    /// translated from a glTF's materials (`STEM.mtl`), and the images the glTF stored
    /// itself, extracted for the library to name.
    pub written_beside: Vec<PathBuf>,
}

/// Write `scene` to `path` in the format its extension names. OBJ, PLY and STL hold
/// one level: instances are flattened into world space (OBJ keeps one group per
/// instance). glTF/GLB keep meshes, materials and instance transforms; they cannot hold
/// NaN, so inactive triangles are collapsed ([`WriteNotes::inactive_collapsed`]).
pub fn write(scene: &Scene, path: &Path) -> Result<WriteNotes, MeshError> {
    write_with(scene, path, WriteOptions::default())
}

/// What [`write_with`] is given beyond the scene.
#[derive(Clone, Copy, Debug, Default)]
pub struct WriteOptions<'a> {
    /// Image files as the scene names them, with their bytes ([`SideFiles::images`]),
    /// stored in the binary chunk when the output is a GLB, so that the GLB is one file;
    /// elsewhere not used.
    pub images: &'a [(String, Vec<u8>)],
    /// The stem of the material library an OBJ gets beside it when it is written from a
    /// glTF's materials or a PLY's textures: `STEM.mtl`, with the images the glTF
    /// stores extracted as `STEM_imageN.EXT`. By default the output's own stem; files
    /// given the same one in one folder share one library (`animate`'s frames), since
    /// a side file already there with the same bytes is left alone.
    pub library: Option<&'a str>,
    /// The library and its images are beside the output already, written for an
    /// earlier file with the same `library` stem: the OBJ names them, and they are not
    /// read back for comparison or written again.
    pub library_in_place: bool,
}

/// [`write`], with [`WriteOptions`].
pub fn write_with(
    scene: &Scene,
    path: &Path,
    options: WriteOptions,
) -> Result<WriteNotes, MeshError> {
    let format = Format::from_path(path)?;
    let io_error = |e| MeshError::io(path, e);
    let too_large = |e: crate::mesh::TooManyToFlatten| {
        MeshError::invalid(
            path,
            format!("cannot flatten the scene for a one-level format: {e}"),
        )
    };
    let mut notes = WriteNotes::default();
    match format {
        Format::Obj => {
            scene.check_flattenable().map_err(too_large)?;
            let mut names = None;
            if let Some((file, library)) = obj_material_library(scene, path, options.library) {
                let beside = |file: &str| path.with_file_name(file);
                let mut files = vec![(beside(&file), library.text.into_bytes())];
                let images = library.images.into_iter();
                files.extend(images.map(|(image, bytes)| (beside(&image), bytes)));
                if !options.library_in_place {
                    side_files::write_beside(&files, path)?;
                    notes.written_beside = files.into_iter().map(|(file, _)| file).collect();
                }
                notes.not_held = library.not_held;
                names = Some((file, library.names));
            }
            let names = names.as_ref().map(|(file, n)| (file.as_str(), &n[..]));
            obj::write(scene, path, names).map_err(io_error)?
        }
        Format::Ply => {
            let flat = scene.flatten().map_err(too_large)?;
            let header = match scene.document.as_deref() {
                Some(Document::Ply { comments, obj_info }) => Some((&comments[..], &obj_info[..])),
                _ => None,
            };
            ply::write(&flat, &scene.materials, header, path).map_err(io_error)?
        }
        Format::Stl => {
            let header = match scene.document.as_deref() {
                Some(Document::Stl { header }) => Some(header),
                _ => None,
            };
            let flat = scene.flatten().map_err(too_large)?;
            stl::write(&flat, header, path).map_err(io_error)?
        }
        Format::Gltf | Format::Glb => {
            notes = gltf::write(scene, path, format == Format::Glb, options.images)
                .map_err(io_error)?;
        }
    }
    notes.not_held.splice(0..0, not_held(scene, format));
    notes.not_read = not_read(&scene.read_notes);
    Ok(notes)
}

/// For an OBJ written from a glTF with materials: the material library translated from
/// them ([`gltf::mtl_library`]) and its file name, `STEM.mtl` beside the output, STEM
/// being `library` or else the output's stem.
fn obj_material_library(
    scene: &Scene,
    path: &Path,
    library: Option<&str>,
) -> Option<(String, gltf::MtlLibrary)> {
    let stem = match library {
        Some(stem) => stem.into(),
        None => path.file_stem()?.to_string_lossy(),
    };
    // One word, so that `mtllib` and the maps name it whole.
    let stem = stem.replace(char::is_whitespace, "_");
    let library = match scene.document.as_deref() {
        Some(Document::Gltf(document)) if !document.root().materials.is_empty() => {
            gltf::mtl_library(document, scene.materials.len(), &stem)
        }
        // A PLY's textures: the looks written as MTL.
        None | Some(Document::Ply { .. }) if scene.materials.iter().any(|m| m.mtl.is_some()) => {
            obj::looks_library(&scene.materials)
        }
        _ => return None,
    };
    Some((format!("{stem}.mtl"), library))
}

/// What `format` cannot hold of `scene`, in words: vertex attributes past what it
/// stores, triangle attributes, materials, several geometries in a format of one, and
/// a glTF document's nodes, skins, animations, cameras and primitives of lines or
/// points.
fn not_held(scene: &Scene, format: Format) -> Vec<String> {
    let mut lost = Vec::new();
    if let (Some(Document::Ply { comments, obj_info }), false) =
        (scene.document.as_deref(), format == Format::Ply)
    {
        let lines: Vec<String> = comments
            .iter()
            .chain(obj_info)
            .map(|l| format!("\"{l}\""))
            .collect();
        if !lines.is_empty() {
            let shown = lines.len().min(3);
            let more = if lines.len() > shown { ", …" } else { "" };
            lost.push(format!(
                "the PLY header's comment and obj_info lines: {} ({}{more}), which a PLY output alone keeps",
                lines.len(),
                lines[..shown].join(", ")
            ));
        }
    }
    if let (Some(Document::Stl { header }), false) =
        (scene.document.as_deref(), format == Format::Stl)
    {
        let text = stl::header_text(header);
        if !text.is_empty() && !text.starts_with(stl::OWN_HEADER) {
            lost.push(format!(
                "the binary STL header (\"{text}\"), which an STL output alone keeps"
            ));
        }
    }
    let ply_textures = ply::texture_files(&scene.materials).is_some();
    if format != Format::Ply {
        let mut names = scene.triangle_attribute_names();
        // STL keeps its own attribute word.
        if format == Format::Stl {
            names.retain(|&name| name != stl::ATTRIBUTE_WORD);
        }
        // MeshLab's texture numbers are the triangles' materials, which every format holds.
        if ply_textures {
            names.retain(|&name| name != ply::TEXNUMBER);
        }
        if !names.is_empty() {
            let names = names.join(", ");
            lost.push(format!(
                "triangle attributes {names} (of the formats, PLY alone holds values per triangle)"
            ));
        }
    }
    // The vertex attributes the format holds; `None`: every one (PLY, glTF).
    let held: Option<&[&str]> = match format {
        Format::Gltf | Format::Glb => return lost,
        Format::Obj => Some(&["NORMAL", "TEXCOORD_0", obj::TEXCOORD_W, "COLOR_0"]),
        Format::Ply => None,
        Format::Stl => Some(&[]),
    };
    if let Some(held) = held {
        let mut attributes: Vec<&str> = Vec::new();
        let mut morph_targets = false;
        for attribute in scene.meshes.iter().flat_map(|m| &m.attributes) {
            let name = attribute.name.as_str();
            if name.starts_with(crate::mesh::MORPH_PREFIX) {
                morph_targets = true;
            } else if !held.contains(&name) && !attributes.contains(&name) {
                attributes.push(name);
            }
        }
        if !attributes.is_empty() {
            lost.push(format!("vertex attributes {}", attributes.join(", ")));
        }
        if morph_targets {
            lost.push("morph targets".to_owned());
        }
    }
    if format == Format::Obj
        && (scene.meshes.iter())
            .filter_map(|m| m.attribute("COLOR_0"))
            .any(|c| c.components == 4)
    {
        lost.push("COLOR_0's alpha".to_owned());
    }
    // PLY and STL hold one mesh, and no materials.
    let one_mesh = matches!(format, Format::Ply | Format::Stl);
    let placed = scene.instances.len();
    if one_mesh && placed > 1 {
        lost.push(format!(
            "geometries: {placed} (merged into one mesh, their names with them)"
        ));
    }
    // PLY holds a texture file per material (MeshLab's comments), and no more.
    let ply_textures = format == Format::Ply && ply_textures;
    if ply_textures
        && scene
            .materials
            .iter()
            .any(|m| m.mtl.as_ref().is_some_and(|l| !l.is_plain_texture()))
    {
        lost.push("materials' colours and maps other than the diffuse texture (PLY holds a texture file per material)".to_owned());
    }
    lost.extend(document_not_held(scene, one_mesh && !ply_textures));
    lost
}

/// What a reader left unread of a file, in words.
fn not_read(notes: &crate::mesh::ReadNotes) -> Vec<String> {
    let mut lost = Vec::new();
    let statements = [
        (notes.ignored_lines, "OBJ line (`l`) statements"),
        (notes.ignored_points, "OBJ point (`p`) statements"),
    ];
    for (count, what) in statements.into_iter().filter(|(count, _)| *count > 0) {
        lost.push(format!("{what}: {count} (not triangles)"));
    }
    lost.extend(notes.not_read.iter().cloned());
    lost
}

/// Whether a glTF node holds nothing a flattened output loses: no name, children,
/// extras or transform other than the identity.
fn node_is_plain(node: &::gltf::json::Node) -> bool {
    const IDENTITY: [f32; 16] = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ];
    node.name.is_none()
        && node.extras.is_none()
        && node.children.as_ref().is_none_or(Vec::is_empty)
        && node.matrix.is_none_or(|m| m == IDENTITY)
        && node.translation.is_none_or(|t| t == [0.0; 3])
        && node.rotation.is_none_or(|r| r.0 == [0.0, 0.0, 0.0, 1.0])
        && node.scale.is_none_or(|s| s == [1.0; 3])
}

/// What a one-level format cannot hold of the document `scene` was read with:
/// materials (where `materials` says it holds none) and a glTF's nodes, skins,
/// animations and cameras, counted.
fn document_not_held(scene: &Scene, materials: bool) -> Vec<String> {
    let mut lost = Vec::new();
    let used = |m: &Material| !m.name.is_empty() || m.mtl.is_some();
    let from_gltf = match scene.document.as_deref() {
        Some(Document::Gltf(document)) => Some(document.root()),
        _ => None,
    };
    let material_count = match from_gltf {
        Some(root) => root.materials.len(),
        None => scene.materials.iter().filter(|m| used(m)).count(),
    };
    if materials && material_count > 0 {
        lost.push(format!(
            "materials: {material_count} (the format holds none)"
        ));
    }
    if let Some(root) = from_gltf {
        if !root.nodes.iter().all(node_is_plain) {
            let nodes = root.nodes.len();
            lost.push(format!(
                "nodes: {nodes} (their tree, names and transforms; the geometry is written in world space)"
            ));
        }
        let not_triangles = (root.meshes.iter())
            .flat_map(|m| &m.primitives)
            .filter(|p| !gltf::is_triangles(p))
            .count();
        if root.scenes.len() > 1 {
            lost.push(format!(
                "scenes: {} (the default one is written; the others' geometry is not)",
                root.scenes.len()
            ));
        }
        let counted = [
            (root.skins.len(), "skins"),
            (root.animations.len(), "animations"),
            (root.cameras.len(), "cameras"),
            (not_triangles, "primitives of lines or points"),
        ];
        for (count, what) in counted.into_iter().filter(|(count, _)| *count > 0) {
            lost.push(format!("{what}: {count}"));
        }
    }
    lost
}

/// Write `mesh` as a binary PLY whose triangles are one `tristrips` element: the
/// rasterization strips `strips` (vertex indices, as [`crate::strip::Strips::to_standard`]
/// gives), joined by −1 restarts. Vertex attributes are written as [`write`] does.
pub fn write_ply_strips(mesh: &TriMesh, strips: &[Vec<u32>], path: &Path) -> Result<(), MeshError> {
    ply::write_strips(mesh, strips, path).map_err(|e| MeshError::io(path, e))
}

/// Write `scene` as glTF or GLB (by `path`'s extension) with each geometry's triangles
/// as `TRIANGLE_STRIP` primitives: `strips[m]` holds all the strips of mesh `m` (see
/// [`crate::strip`]); everything else is written as [`write`] writes it.
pub fn write_gltf_strips(
    scene: &Scene,
    strips: &[crate::strip::Strips],
    path: &Path,
    images: &[(String, Vec<u8>)],
) -> Result<WriteNotes, MeshError> {
    let format = Format::from_path(path)?;
    if !matches!(format, Format::Gltf | Format::Glb) {
        return Err(MeshError::invalid(
            path,
            "strips as primitives are written to .gltf or .glb".to_owned(),
        ));
    }
    gltf::write_strips(scene, strips, path, format == Format::Glb, images)
        .map_err(|e| MeshError::io(path, e))
}

/// Every reader ends here: no index may point past its mesh's vertices, no instance past
/// the meshes.
fn check_indices(path: &Path, scene: &Scene) -> Result<(), MeshError> {
    for (m, mesh) in scene.meshes.iter().enumerate() {
        let n = mesh.positions.len() as u64;
        if let Some(t) = mesh
            .triangles
            .iter()
            .position(|t| t.iter().any(|&v| v as u64 >= n))
        {
            return Err(MeshError::invalid(
                path,
                format!(
                    "geometry {m} ('{}'): triangle {t} has vertex index {:?} but there are only {n} vertices",
                    mesh.name, mesh.triangles[t]
                ),
            ));
        }
    }
    if let Some(i) = scene
        .instances
        .iter()
        .find(|i| i.mesh >= scene.meshes.len())
    {
        return Err(MeshError::invalid(
            path,
            format!("instance of missing mesh {}", i.mesh),
        ));
    }
    Ok(())
}

/// A buffered reader that counts bytes and lines as they are consumed, and reports
/// progress. Readers use it to name the line or byte offset of an error.
pub(crate) struct CountingReader<'p, R> {
    inner: R,
    total: u64,
    consumed: u64,
    lines: usize,
    in_line: bool,
    count_lines: bool,
    last_report: u64,
    progress: Progress<'p>,
}

impl<'p, R: BufRead> CountingReader<'p, R> {
    fn new(inner: R, total: u64, progress: Progress<'p>) -> Self {
        Self {
            inner,
            total,
            consumed: 0,
            lines: 0,
            in_line: false,
            count_lines: true,
            last_report: 0,
            progress,
        }
    }

    /// 1-based number of the line being read (or last read).
    pub(crate) fn line(&self) -> usize {
        self.lines + usize::from(self.in_line)
    }

    /// Everything left, read into memory; an I/O error names `path`.
    pub(crate) fn read_all(&mut self, path: &Path) -> Result<Vec<u8>, MeshError> {
        let mut bytes = Vec::new();
        self.read_to_end(&mut bytes)
            .map_err(|e| MeshError::io(path, e))?;
        Ok(bytes)
    }

    /// Stop counting lines (a binary payload has none): consuming gets cheaper.
    pub(crate) fn stop_counting_lines(&mut self) {
        self.count_lines = false;
    }

    /// Bytes consumed so far.
    pub(crate) fn offset(&self) -> u64 {
        self.consumed
    }
}

impl<R: BufRead> Read for CountingReader<'_, R> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        let available = self.fill_buf()?;
        let n = available.len().min(out.len());
        out[..n].copy_from_slice(&available[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl<R: BufRead> BufRead for CountingReader<'_, R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        self.inner.fill_buf()
    }

    fn consume(&mut self, amount: usize) {
        if self.count_lines {
            if let Ok(buffer) = self.inner.fill_buf() {
                let taken = &buffer[..amount.min(buffer.len())];
                self.lines += taken.iter().filter(|&&b| b == b'\n').count();
                if let Some(&last) = taken.last() {
                    self.in_line = last != b'\n';
                }
            }
        }
        self.inner.consume(amount);
        self.consumed += amount as u64;
        if self.consumed - self.last_report >= 1 << 20 {
            self.last_report = self.consumed;
            (self.progress)(self.consumed, self.total);
        }
    }
}

#[cfg(test)]
mod tests;

//! The files a written mesh refers to that the writer does not write: an OBJ's material
//! libraries (`mtllib`) and the texture maps they name, a glTF's images stored as files
//! (for a glTF written from an OBJ, the MTL textures its materials took).
//! Writers keep those references as the input wrote them (relative paths), so an
//! output in another folder would point at nothing and lose its materials' textures;
//! [`copy_side_files`] copies each one to the same relative place beside the output.
//!
//! Every file is read by the rule for references (`reference.rs`: inside the asset's
//! folder or the asset root, regular files, size-limited), so a crafted reference
//! cannot make a copy of a file from elsewhere. A reference that resolves outside the
//! input's own folder (allowed by an asset root) is not copied, since its copy would
//! land outside the output's folder; one that names no file is not copied either (the
//! input's reference dangles too), nor one the rule refuses (an image URI the reader
//! never opened may name anything). All three are reported, and the output keeps the
//! reference as written. A file already at the
//! destination is left alone when it holds the same bytes and is an error otherwise,
//! so that no file of the user's is replaced.

use super::reference::{asset_folder, lexical, read_referenced, resolve};
use super::{Document, Format, MeshError, ReadOptions};
use crate::mesh::Scene;
use std::path::{Path, PathBuf};

/// What [`check_side_files`] found.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SideFileCheck {
    /// The files that are there (their real paths).
    pub present: Vec<PathBuf>,
    /// References that name no file, as written.
    pub missing: Vec<String>,
    /// References the rule for references refuses, each with why.
    pub refused: Vec<String>,
}

/// What [`copy_side_files`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SideFiles {
    /// The files written beside the output (already there with the same bytes included).
    pub copied: Vec<PathBuf>,
    /// References that name no file beside the input, as written.
    pub missing: Vec<String>,
    /// References that resolve outside the input's folder, as written: not copied.
    pub outside: Vec<String>,
    /// References the rule for references refuses (absolute, climbing out of the asset
    /// root, not a regular file, too large), each with why: not copied.
    pub refused: Vec<String>,
    /// The image files read to be stored in a GLB (PNG and JPEG, the image types glTF's
    /// core holds in a buffer), not copied.
    pub embedded: Vec<PathBuf>,
    /// Their bytes, by the name the materials give them, for [`super::write_with`].
    #[serde(skip)]
    pub images: Vec<(String, Vec<u8>)>,
}

/// The MIME type of an image glTF's core can store in a buffer (PNG, JPEG), by its
/// first bytes; `None` for any other.
pub(super) fn embeddable_image_type(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(&[0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a]) {
        Some("image/png")
    } else if bytes.starts_with(&[0xff, 0xd8, 0xff]) {
        Some("image/jpeg")
    } else {
        None
    }
}

/// One file a written mesh refers to.
struct Reference {
    /// The file the reference is relative to.
    asset: PathBuf,
    /// The reference, as written (percent-decoded).
    name: String,
    /// Its bytes, where they were read already (a material library, read for its
    /// textures' names).
    bytes: Option<Vec<u8>>,
}

impl Reference {
    fn new(asset: &Path, name: String) -> Self {
        Self {
            asset: asset.to_owned(),
            name,
            bytes: None,
        }
    }

    /// Its bytes by the rule for references; `Ok(None)` when there is no such file.
    fn read(&mut self, root: &Path) -> Result<Option<Vec<u8>>, MeshError> {
        match self.bytes.take() {
            Some(bytes) => Ok(Some(bytes)),
            None => read_referenced(&self.asset, &self.name, root),
        }
    }
}

/// The files a copy of `scene`, read from `input`, refers to when written as `format`
/// and does not write itself.
fn references(input: &Path, scene: &Scene, format: Format, root: &Path) -> Vec<Reference> {
    let mut references: Vec<Reference> = Vec::new();
    match (scene.document.as_deref(), format) {
        (Some(Document::Obj { material_libraries }), Format::Obj) => {
            for library in material_libraries {
                if references.iter().any(|r| &r.name == library) {
                    continue;
                }
                let mut reference = Reference::new(input, library.clone());
                // Texture names are relative to the library's folder.
                let path = resolve(input, library, root);
                if let (Ok(path), Ok(Some(bytes))) = (path, reference.read(root)) {
                    let textures = super::obj::mtl_textures(&bytes);
                    reference.bytes = Some(bytes);
                    references.push(reference);
                    references.extend(textures.into_iter().map(|t| Reference::new(&path, t)));
                } else {
                    references.push(reference);
                }
            }
        }
        // An OBJ from a glTF names the image files in the library translated for it.
        (Some(Document::Gltf(document)), Format::Gltf | Format::Glb | Format::Obj)
            if format != Format::Obj || !document.root().materials.is_empty() =>
        {
            let uris = document
                .root()
                .images
                .iter()
                .filter_map(|i| i.uri.as_deref());
            for uri in uris.filter(|uri| !uri.starts_with("data:")) {
                // A malformed %-escape stands as written (and names no file).
                let reference = super::reference::percent_decode(uri).unwrap_or_else(|| uri.into());
                references.push(Reference::new(input, reference));
            }
        }
        (_, Format::Ply) => {
            // MeshLab's comments name the materials' diffuse maps.
            let files = super::ply::texture_files(&scene.materials).unwrap_or_default();
            references.extend(
                files
                    .into_iter()
                    .map(|f| Reference::new(input, f.to_owned())),
            );
        }
        (None | Some(Document::Ply { .. } | Document::Stl { .. }), Format::Obj)
        | (_, Format::Gltf | Format::Glb) => {
            // A fresh document, or an MTL library written from the looks (a PLY's
            // textures): the images are the MTL textures the materials name.
            for look in scene.materials.iter().filter_map(|m| m.mtl.as_ref()) {
                let maps = look.texture_files().cloned();
                references.extend(maps.map(|map| Reference::new(input, map)));
            }
        }
        _ => {}
    }
    references
}

/// The files `scene`, read from `input` with `options`, refers to besides what it read
/// (an OBJ's material libraries and textures, a glTF's image files), each checked by
/// the rule for references without reading it: whether it is there.
pub fn check_side_files(input: &Path, scene: &Scene, options: &ReadOptions) -> SideFileCheck {
    let mut report = SideFileCheck::default();
    let Ok(format) = Format::from_path(input) else {
        return report;
    };
    let root = options
        .asset_root
        .clone()
        .unwrap_or_else(|| asset_folder(input));
    for Reference { asset, name, .. } in references(input, scene, format, &root) {
        match super::reference::check_referenced(&asset, &name, &root) {
            Ok(Some((real, _))) if report.present.contains(&real) => {}
            Ok(Some((real, _))) => report.present.push(real),
            Ok(None) => report.missing.push(name),
            Err(why) => report.refused.push(why.to_string()),
        }
    }
    report
}

/// Copy the files that `scene`, read from `input` with `options`, and written to
/// `output`, refers to but does not write, to the same relative paths beside `output`.
/// Nothing is copied when the output is in the input's folder or its format keeps no
/// such reference (PLY, STL). A GLB is one file, as obj2gltf and gltf-pipeline write
/// it: the PNG and JPEG images it refers to (an OBJ's MTL textures, a `.gltf`'s image
/// files) are read to be stored in it ([`SideFiles::images`]) instead of copied,
/// wherever the output is.
pub fn copy_side_files(
    input: &Path,
    scene: &Scene,
    output: &Path,
    options: &ReadOptions,
) -> Result<SideFiles, MeshError> {
    let mut report = SideFiles::default();
    let (from, to) = (asset_folder(input), asset_folder(output));
    let format = Format::from_path(output)?;
    let from_lexical = lexical(&from);
    let same_folder = from_lexical == lexical(&to);
    let embedding = format == Format::Glb;
    if same_folder && !embedding {
        return Ok(report);
    }
    let root = options.asset_root.clone().unwrap_or_else(|| from.clone());
    let mut seen = Vec::<PathBuf>::new();
    for mut reference in references(input, scene, format, &root) {
        let source = match resolve(&reference.asset, &reference.name, &root) {
            Ok(source) => source,
            Err(why) => {
                report.refused.push(why.to_string());
                continue;
            }
        };
        if embedding {
            if report
                .images
                .iter()
                .any(|(name, _)| *name == reference.name)
            {
                continue;
            }
            if let Ok(Some(bytes)) = reference.read(&root) {
                if embeddable_image_type(&bytes).is_some() {
                    report.embedded.push(source);
                    report.images.push((reference.name, bytes));
                    continue;
                }
                reference.bytes = Some(bytes);
            }
            if same_folder {
                continue;
            }
        }
        let relative = lexical(&source)
            .zip(from_lexical.as_ref())
            .and_then(|(source, from)| source.strip_prefix(from).ok().map(Path::to_owned));
        let Some(relative) = relative else {
            report.outside.push(reference.name);
            continue;
        };
        if seen.contains(&relative) {
            continue;
        }
        seen.push(relative.clone());
        let bytes = match reference.read(&root) {
            Ok(Some(bytes)) => bytes,
            Ok(None) => {
                report.missing.push(reference.name);
                continue;
            }
            Err(why) => {
                report.refused.push(why.to_string());
                continue;
            }
        };
        let destination = to.join(&relative);
        match std::fs::read(&destination) {
            Ok(there) if there == bytes => {}
            Ok(_) => {
                return Err(MeshError::invalid(
                    &destination,
                    format!(
                        "exists and differs from {}, which the output refers to as '{}': remove it or write the output to another folder",
                        source.display(),
                        reference.name
                    ),
                ))
            }
            Err(_) => {
                if let Some(parent) = destination.parent() {
                    std::fs::create_dir_all(parent).map_err(|e| MeshError::io(parent, e))?;
                }
                write_whole(&destination, &bytes)?;
            }
        }
        report.copied.push(destination);
    }
    Ok(report)
}

/// Write the files a writer makes beside its output (an OBJ's material library
/// translated from a glTF, the images it extracts), each path with its bytes, by the
/// side files' rule: a file already there with the same bytes is left alone, a
/// different one is an error and left alone, and nothing is written unless all can be.
pub(super) fn write_beside(files: &[(PathBuf, Vec<u8>)], output: &Path) -> Result<(), MeshError> {
    let mut fresh = Vec::new();
    for (path, bytes) in files {
        match std::fs::read(path) {
            Ok(there) if &there == bytes => {}
            Ok(_) => {
                return Err(MeshError::invalid(
                    path,
                    format!(
                        "exists and differs from what {} needs beside it: remove it or write the output elsewhere",
                        output.display()
                    ),
                ))
            }
            Err(_) => fresh.push((path, bytes)),
        }
    }
    for (path, bytes) in fresh {
        write_whole(path, bytes)?;
    }
    Ok(())
}

/// Write `bytes` to `destination` through a temporary file beside it, renamed into
/// place: batch jobs that share a texture copy it at the same time, and none may see
/// another's half-written copy (it would read as a different file in the way).
fn write_whole(destination: &Path, bytes: &[u8]) -> Result<(), MeshError> {
    static COPIES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let copy = COPIES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let mut name = destination.as_os_str().to_owned();
    name.push(format!(".rtmesh-{}-{copy}.tmp", std::process::id()));
    let temporary = PathBuf::from(name);
    std::fs::write(&temporary, bytes)
        .and_then(|()| std::fs::rename(&temporary, destination))
        .map_err(|e| {
            let _ = std::fs::remove_file(&temporary);
            MeshError::io(destination, e)
        })
}

//! What goes out: JSON reports stamped with the version and schema, and progress bars
//! on standard error.

use anyhow::{bail, Result};
use indicatif::{ProgressBar, ProgressStyle};
use rtmesh::io::{SideFiles, WriteNotes};
use serde::Serialize;
use std::path::Path;

/// The version of the JSON reports' layout: raised when a key changes meaning or goes.
pub const SCHEMA: u32 = 1;

/// A report as JSON prints it: the report's own keys, plus `rtmesh_version` and
/// `schema`.
#[derive(Serialize)]
struct Stamped<'a, R: Serialize> {
    rtmesh_version: &'static str,
    schema: u32,
    #[serde(flatten)]
    report: &'a R,
}

fn stamped<R: Serialize>(report: &R) -> Stamped<'_, R> {
    Stamped {
        rtmesh_version: env!("CARGO_PKG_VERSION"),
        schema: SCHEMA,
        report,
    }
}

/// Print `report` as one pretty JSON object with `--json`, else as `text` prints it.
pub fn emit<R: Serialize>(report: &R, json: bool, text: impl FnOnce(&R)) -> Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(&stamped(report))?);
    } else {
        text(report);
    }
    Ok(())
}

/// One stamped JSON line (the rows of `rtmesh bench`).
pub fn json_line<R: Serialize>(row: &R) -> String {
    serde_json::to_string(&stamped(row)).expect("reports are plain data")
}

/// A progress bar on standard error over `steps` steps of long work, with a message
/// saying which; drawn only when standard error is a terminal, never into the output.
pub fn steps_bar(steps: usize) -> Bar {
    Bar(ProgressBar::new(steps as u64).with_style(
        ProgressStyle::with_template("{msg} {bar:30} {pos}/{len} ({elapsed}, {eta} left)")
            .expect("valid template"),
    ))
}

/// A progress bar that the library's long work reports to.
pub struct Bar(pub ProgressBar);

impl rtmesh::progress::Progress for Bar {
    fn message(&self, text: &str) {
        self.0.set_message(text.to_owned());
    }
    fn add_steps(&self, steps: u64) {
        self.0.inc_length(steps);
    }
    fn advance(&self, steps: u64) {
        self.0.inc(steps);
    }
}

/// Refuse an output that would replace a file the input was read from: the input file
/// itself, or a buffer file that a .gltf input names (a .gltf output writes its buffer
/// beside it, with the extension `.bin`). Like `cp a a`, since a mistake in the output
/// would then have lost the original. Built-in scenes have no file.
pub fn refuse_overwriting_input(input: &str, scene: &rtmesh::Scene, output: &Path) -> Result<()> {
    if input.starts_with("builtin:") {
        return Ok(());
    }
    let input = Path::new(input);
    let mut read = vec![input.to_owned()];
    if let Some(rtmesh::io::Document::Gltf(document)) = scene.document.as_deref() {
        let folder = input.parent().unwrap_or(Path::new(""));
        let uris = document
            .root()
            .buffers
            .iter()
            .filter_map(|b| b.uri.as_deref());
        read.extend(
            uris.filter(|uri| !uri.contains(':'))
                .map(|uri| folder.join(uri)),
        );
    }
    let mut written = vec![output.to_owned()];
    if output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf"))
    {
        written.push(output.with_extension("bin"));
    }
    let canonical = |path: &Path| std::fs::canonicalize(path).ok();
    for path in &written {
        let Some(target) = canonical(path) else {
            continue; // not there yet: nothing to replace
        };
        if let Some(source) = read.iter().find(|r| canonical(r) == Some(target.clone())) {
            let what = if source == input {
                "the input file".to_owned()
            } else {
                format!("the buffer {} that the input reads", source.display())
            };
            bail!(
                "{}: this is {what}, which the output would replace: write the output to another name or folder",
                path.display()
            );
        }
    }
    Ok(())
}

/// Write `scene`, read from `input`, to `path`; say on standard error what the format
/// could not hold. The files the output refers to are copied beside it first
/// ([`copy_side_files`]).
pub fn write_mesh(
    input: &str,
    scene: &rtmesh::Scene,
    path: &Path,
) -> Result<(SideFiles, WriteNotes)> {
    // First, so that a side file in the way stops the write before anything is written.
    let copies = copy_side_files(input, scene, path)?;
    let options = rtmesh::io::WriteOptions {
        images: &copies.images,
        ..Default::default()
    };
    let notes = write_noting(input, scene, path, options)?;
    Ok((copies, notes))
}

/// Write `scene`, read from `input`, to `path` with `options` (the images a GLB
/// stores, the name of an OBJ's material library), and say on standard error what the
/// writer repaired or the format could not hold.
pub fn write_noting(
    input: &str,
    scene: &rtmesh::Scene,
    path: &Path,
    options: rtmesh::io::WriteOptions,
) -> Result<WriteNotes> {
    let notes = rtmesh::io::write_with(scene, path, options)?;
    if notes.inactive_collapsed > 0 {
        eprintln!(
            "note: {}: glTF cannot hold NaN, so {} inactive triangles were written as degenerate triangles collapsed onto a corner (same place in the order, no area)",
            path.display(),
            notes.inactive_collapsed
        );
    }
    if notes.normals_renormalized > 0 {
        eprintln!(
            "note: {}: glTF asks for unit normals and tangents, so {} vertices' normals or tangents were written renormalized",
            path.display(),
            notes.normals_renormalized
        );
    }
    if notes.weights_renormalized > 0 {
        eprintln!(
            "note: {}: glTF asks for skin weights that sum to 1, so {} vertices' weights were written scaled to sum to 1",
            path.display(),
            notes.weights_renormalized
        );
    }
    if !notes.not_read.is_empty() {
        eprintln!(
            "note: {input} holds what rtmesh does not read, so {} goes without: {}",
            path.display(),
            notes.not_read.join("; ")
        );
    }
    if !notes.not_held.is_empty() {
        let gltf = matches!(
            rtmesh::io::Format::from_path(path),
            Ok(rtmesh::io::Format::Gltf | rtmesh::io::Format::Glb)
        );
        eprintln!(
            "note: {} cannot hold, so goes without: {}{}",
            path.display(),
            notes.not_held.join("; "),
            if gltf {
                ""
            } else {
                " (write .gltf or .glb to keep them)"
            }
        );
    }
    Ok(notes)
}

/// Copy the files that `output`, written from `scene` read from `input`, refers to and
/// does not hold (an OBJ's material libraries and textures, a glTF's image files) to
/// the same relative paths beside it, and say on standard error what could not be.
pub fn copy_side_files(input: &str, scene: &rtmesh::Scene, output: &Path) -> Result<SideFiles> {
    if input.starts_with("builtin:") {
        return Ok(SideFiles::default());
    }
    let copies =
        rtmesh::io::copy_side_files(Path::new(input), scene, output, crate::args::read_options())?;
    let output = output.display();
    if !copies.missing.is_empty() {
        eprintln!(
            "note: {output} refers to {}, which {input} names but which is not there: not copied",
            copies.missing.join(", ")
        );
    }
    if !copies.outside.is_empty() {
        eprintln!(
            "note: {output} refers to {}, outside the folder of {input}: not copied, so copy them to the same place relative to the output",
            copies.outside.join(", ")
        );
    }
    for why in &copies.refused {
        eprintln!("note: {output} keeps a reference that was not copied: {why}");
    }
    Ok(copies)
}

//! `rtmesh convert`: between formats, keeping triangle order.

use crate::args::load;
use crate::output::{emit, refuse_overwriting_input, write_mesh};
use anyhow::{Context, Result};
use serde::Serialize;
use std::path::PathBuf;

/// Convert between formats, keeping triangle order (format from the extension).
///
/// OBJ and PLY hold one level, so instances are flattened; glTF/GLB keep them. An OBJ
/// written from a glTF gets its materials as an MTL library beside it (STEM.mtl, with
/// the images the glTF stored itself as STEM_imageN files), and a GLB written from
/// another format stores its PNG and JPEG textures, as one file; what the output format
/// cannot hold (skins, animations, extra attributes) is named on standard error and in
/// `--json`'s `not_held`.
#[derive(clap::Args)]
pub struct Args {
    /// Input mesh file, or builtin:NAME.
    input: String,
    /// Output file: .obj, .ply (binary), .gltf (with .bin beside it) or .glb.
    output: PathBuf,
    /// Merge vertices closer than this distance (0 = identical positions only); vertices
    /// whose attributes (UVs, normals, ...) differ are never merged, so seams stay.
    #[arg(long, value_name = "DISTANCE")]
    weld: Option<f32>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// What `convert` wrote.
#[derive(Serialize)]
pub struct Report {
    input: String,
    output: PathBuf,
    /// Triangles written, instances counted.
    triangles: usize,
    /// Vertices written, instances counted.
    vertices: usize,
    /// Vertices merged by `--weld`.
    merged_vertices: usize,
    /// The files the output refers to (material libraries, textures), copied beside it.
    side_files: Vec<PathBuf>,
    /// The files written beside it for it: an OBJ's material library translated from a
    /// glTF's materials, and the images the glTF stored itself.
    written_beside: Vec<PathBuf>,
    /// The image files stored in it (a GLB from another format is one file).
    embedded_images: Vec<PathBuf>,
    /// What the output's format cannot hold and the output goes without, in words.
    not_held: Vec<String>,
    /// What the input holds that rtmesh does not read (an OBJ's lines and points, a
    /// PLY's other elements), so that the output goes without it, in words.
    not_read: Vec<String>,
}

/// Read, weld if asked, write.
pub fn run(args: Args) -> Result<()> {
    let mut scene = load(&args.input)?;
    refuse_overwriting_input(&args.input, &scene, &args.output)?;
    let mut merged_vertices = 0;
    if let Some(tolerance) = args.weld {
        for mesh in &mut scene.meshes {
            let result = rtmesh::mesh::weld(mesh, tolerance);
            merged_vertices += result.merged;
            *mesh = result.mesh;
        }
    }
    let (copies, notes) = write_mesh(&args.input, &scene, &args.output)
        .with_context(|| format!("converting {}", args.input))?;
    let report = Report {
        input: args.input,
        output: args.output,
        triangles: scene.instanced_triangle_count(),
        vertices: scene.instanced_vertex_count(),
        merged_vertices,
        side_files: copies.copied,
        embedded_images: copies.embedded,
        written_beside: notes.written_beside,
        not_held: notes.not_held,
        not_read: notes.not_read,
    };
    emit(&report, args.json, |r| {
        println!(
            "wrote {} ({} triangles, {} vertices, {} merged by welding)",
            r.output.display(),
            r.triangles,
            r.vertices,
            r.merged_vertices
        );
        if !r.embedded_images.is_empty() {
            println!("stored {} images in it", r.embedded_images.len());
        }
        for file in &r.written_beside {
            println!("wrote {} beside it", file.display());
        }
        if !r.side_files.is_empty() {
            println!(
                "copied {} files it refers to beside it (material libraries, textures)",
                r.side_files.len()
            );
        }
    })
}

//! `rtmesh animate`: write the frames of a procedural motion as mesh files.

use crate::args::load;
use crate::output::{emit, steps_bar, write_noting};
use anyhow::{bail, Context, Result};
use rtmesh::animate::{Animation, Motion};
use rtmesh::io::{Document, WriteOptions};
use rtmesh::progress::Progress;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Write the frames that `rtmesh dynamic` traces, frame f of N at phase f / (N − 1),
/// each as DIR/frame-FFFF.EXT.
///
/// A procedural motion moves the first geometry; the rest of the scene (other
/// geometries, nodes, materials, every vertex attribute) is written as it was, but for
/// the geometry's normals and tangents, which turn with the motion (by its Jacobian at
/// each vertex, so authored normals and hard edges stay as they were made rather than
/// being re-derived). --motion gltf plays the file's animation (skins, node
/// channels, morph targets) and writes each frame baked: one world-space geometry with
/// its normals and tangents skinned and morphed, its materials with their textures
/// (a GLB frame stores the images; OBJ frames share one MTL library named after the
/// input, with one copy of each image), and every other vertex attribute, but without the node tree, skin, morph targets or animations, which a
/// baked frame has no use for (the source file keeps them).
///
/// Examples:
///   rtmesh animate dragon.ply --motion twist --frames 8 -o frames/ --format ply
///   rtmesh animate Fox.glb --motion gltf:Run --frames 24 -o run/
#[derive(clap::Args)]
pub struct Args {
    /// The mesh file, or builtin:NAME.
    mesh: String,
    /// twist, bend, wave, explode, or gltf / gltf:NAME (the file's first animation, or
    /// the one called or numbered NAME).
    #[arg(long)]
    motion: Motion,
    /// Frames, from the rest pose to the strongest motion.
    #[arg(long, default_value_t = 8)]
    frames: usize,
    /// The folder to write the frames into (made if missing).
    #[arg(short, long)]
    output: PathBuf,
    /// Format of the frames: glb, gltf, ply, obj or stl.
    #[arg(long, default_value = "glb")]
    format: String,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// What `animate` wrote.
#[derive(Serialize)]
pub struct Report {
    mesh: String,
    motion: String,
    frames: usize,
    files: Vec<PathBuf>,
    seconds: f64,
}

/// Animate and write each frame.
pub fn run(args: Args) -> Result<()> {
    let format = args.format.to_ascii_lowercase();
    if !["glb", "gltf", "ply", "obj", "stl"].contains(&format.as_str()) {
        bail!(
            "--format is glb, gltf, ply, obj or stl, not `{}`",
            args.format
        );
    }
    let scene = load(&args.mesh)?;
    let start = std::time::Instant::now();
    let (mesh, animation) = Animation::of(&scene, &args.motion)
        .with_context(|| format!("{}: --motion {}", args.mesh, args.motion))?;
    // A procedural frame is the scene with its first geometry moved; a glTF frame is
    // the animated scene baked into one geometry.
    let mut frame = match args.motion {
        Motion::Procedural(_) => scene,
        Motion::Gltf(_) => rtmesh::Scene {
            materials: scene.materials.clone(),
            document: scene.document.as_deref().and_then(|d| match d {
                Document::Gltf(gltf) => Some(Arc::new(Document::Gltf(Box::new(gltf.looks())))),
                Document::Obj { .. } | Document::Ply { .. } | Document::Stl { .. } => None,
            }),
            ..rtmesh::Scene::from_mesh(mesh)
        },
    };
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("{}: cannot make the folder", args.output.display()))?;
    // An OBJ frame of a glTF (or of a textured PLY) gets the materials as an MTL
    // library with the images extracted: one, named after the input, for all frames.
    let library = Path::new(&args.mesh)
        .file_stem()
        .map(|stem| stem.to_string_lossy().into_owned());
    let bar = steps_bar(args.frames);
    let mut files = Vec::with_capacity(args.frames);
    let mut images = Vec::new();
    for f in 0..args.frames {
        bar.message(&format!("frame {f}"));
        animation.pose(
            f as f32 / (args.frames.max(2) - 1) as f32,
            &mut frame.meshes[0],
        );
        let path = args.output.join(format!("frame-{f:04}.{format}"));
        if f == 0 {
            // Every frame refers to the same material libraries and textures (or, as
            // GLBs from another format, stores the same images), and holds what the
            // first holds: its notes stand for all.
            images = crate::output::copy_side_files(&args.mesh, &frame, &path)?.images;
        }
        let options = WriteOptions {
            images: &images,
            library: library.as_deref(),
            library_in_place: f > 0,
        };
        if f == 0 {
            write_noting(&args.mesh, &frame, &path, options)?;
        } else {
            rtmesh::io::write_with(&frame, &path, options)?;
        }
        files.push(path);
        bar.advance(1);
    }
    bar.0.finish_and_clear();
    let report = Report {
        mesh: args.mesh,
        motion: args.motion.to_string(),
        frames: args.frames,
        files,
        seconds: start.elapsed().as_secs_f64(),
    };
    emit(&report, args.json, |r| {
        println!(
            "{}: {} frames of {} in {:.2} s",
            r.mesh, r.frames, r.motion, r.seconds
        );
        if let (Some(first), Some(last)) = (r.files.first(), r.files.last()) {
            println!("  wrote        {} … {}", first.display(), last.display());
        }
    })
}

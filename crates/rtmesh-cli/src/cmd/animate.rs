//! `rtmesh animate`: write the frames of a procedural motion as mesh files.

use crate::args::load;
use crate::output::{emit, steps_bar};
use anyhow::{bail, Context, Result};
use rtmesh::animate::{Animation, Motion};
use rtmesh::progress::Progress;
use serde::Serialize;
use std::path::PathBuf;

/// Write the frames that `rtmesh dynamic` traces: the mesh's first geometry moved by
/// --motion, frame f of N at phase f / (N − 1), each as DIR/frame-FFFF.EXT.
///
/// The rest of the scene (other geometries, nodes, materials, every vertex attribute)
/// is written as it was; normals and tangents are not re-derived for the moved
/// positions. glTF animation (skins, channels, morph targets) is not built yet.
///
/// Example:
///   rtmesh animate dragon.ply --motion twist --frames 8 -o frames/ --format ply
#[derive(clap::Args)]
pub struct Args {
    /// The mesh file, or builtin:NAME.
    mesh: String,
    /// twist, bend, wave or explode.
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
    let Some(mesh) = scene.meshes.first() else {
        bail!("{}: no geometry to animate", args.mesh);
    };
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("{}: cannot make the folder", args.output.display()))?;
    let start = std::time::Instant::now();
    let animation = Animation::new(mesh, args.motion);
    let bar = steps_bar(args.frames);
    let mut files = Vec::with_capacity(args.frames);
    for f in 0..args.frames {
        bar.message(&format!("frame {f}"));
        let mut frame = scene.clone();
        frame.meshes[0].positions = animation.positions(f as f32 / (args.frames.max(2) - 1) as f32);
        let path = args.output.join(format!("frame-{f:04}.{format}"));
        rtmesh::io::write(&frame, &path)?;
        files.push(path);
        bar.advance(1);
    }
    bar.0.finish_and_clear();
    let report = Report {
        mesh: args.mesh,
        motion: format!("{:?}", args.motion).to_lowercase(),
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

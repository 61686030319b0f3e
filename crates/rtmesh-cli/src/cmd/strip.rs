//! `rtmesh strip`: triangle strips for ray tracing (Strip-RT) or for rasterization
//! (meshoptimizer), with their figures and, with -o, the stripped mesh.

use crate::args::load;
use crate::output::{copy_side_files, emit, refuse_overwriting_input};
use anyhow::{bail, Context, Result};
use rtmesh::mesh::{names_a_vertex_twice, weld_exact};
use rtmesh::strip::{meshopt, sah, StripReport, Strips};
use rtmesh::TriMesh;
use serde::Serialize;
use std::path::PathBuf;

/// Turn a mesh's triangles into strips: sequences in which each triangle shares an edge
/// with the one before, so that each costs one vertex index instead of three.
///
/// `sah` (Strip-RT, Lauterbach's ReduceM stripification) merges sequences along an SAH
/// partition of the mesh, balanced in length, so that every strip and every half of
/// one is compact: strips a ray tracer can trace directly. `meshopt` is meshoptimizer's
/// rasterization stripifier, the baseline. Vertices are welded exactly (equal
/// positions and attributes) first; the scene is flattened to world space except for
/// glTF output, which keeps it. rtmesh's strip format, bit
/// by bit, is in crates/rtmesh/src/strip/mod.rs.
///
/// Examples:
///   rtmesh strip dragon.ply
///   rtmesh strip dragon.ply -o dragon-strips.ply    # a PLY tristrips element
///   rtmesh strip scene.glb -o scene-strips.glb      # TRIANGLE_STRIP primitives
///   rtmesh strip dragon.ply -o dragon.rts           # rtmesh's compact format
///   rtmesh strip bunny.obj --method meshopt --json
#[derive(clap::Args)]
pub struct Args {
    /// The mesh file, or builtin:NAME.
    mesh: String,
    /// Write the stripped mesh: .ply (a `tristrips` element with −1 restarts), .gltf or
    /// .glb (`TRIANGLE_STRIP` primitives joined by degenerate triangles, the scene's
    /// nodes, materials and every attribute kept), or .rts (rtmesh's strip format with
    /// positions).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// sah (Strip-RT) or meshopt (meshoptimizer's stripifier, cut at --max-length).
    #[arg(long, default_value = "sah")]
    method: String,
    /// Most triangles in one strip.
    #[arg(long, default_value_t = sah::StripSettings::default().max_length as u32, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    max_length: u32,
    /// Most cuts a tunnelling move may make after Strip-RT's ordering (sah only): a
    /// strip end facing another strip's inside reroutes it, when that leaves fewer
    /// strips. 0 keeps the published ordering's strips (longer strips pack smaller and
    /// trace slower: docs/measurements/strips.md).
    #[arg(long, default_value_t = sah::StripSettings::default().tunnel_cuts as u32, value_parser = clap::value_parser!(u32).range(0..=rtmesh::strip::tunnel::MAX_CUTS as i64))]
    tunnel_cuts: u32,
    /// The hierarchy Strip-RT's ordering measures tree distances in (sah only): sah, an
    /// SAH BVH down to single triangles, as published; or morton, the octree of the
    /// triangles' Morton codes, a sort instead of a build (the whole 2.4–2.9× as fast,
    /// strips that trace 2–7% slower: docs/measurements/strips.md).
    #[arg(long, default_value = "sah")]
    partition: sah::PartitionMethod,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// What `strip` made.
#[derive(Serialize)]
pub struct Report {
    mesh: String,
    method: String,
    max_length: u32,
    /// Most cuts of a tunnelling move (sah only).
    #[serde(skip_serializing_if = "Option::is_none")]
    tunnel_cuts: Option<u32>,
    /// The partition of the ordering (sah only).
    #[serde(skip_serializing_if = "Option::is_none")]
    partition: Option<sah::PartitionMethod>,
    #[serde(flatten)]
    strips: StripReport,
    /// meshoptimizer's own output, restart indices included (meshopt only).
    #[serde(skip_serializing_if = "Option::is_none")]
    native_indices_per_triangle: Option<f64>,
    /// Triangles that name a vertex twice: a rasterization strip cannot tell them from
    /// its joins, so the .ply and glTF files leave them out (readers drop such
    /// triangles of a strip). They cover no surface; .rts keeps them.
    #[serde(skip_serializing_if = "Option::is_none")]
    degenerate_not_written: Option<usize>,
    /// Where the strips were written.
    #[serde(skip_serializing_if = "Option::is_none")]
    output: Option<PathBuf>,
}

/// Strip the mesh by `method` (for meshopt, `settings.max_length` is all that counts):
/// the strips and, for meshopt, its own index count.
pub fn strips_by(
    mesh: &TriMesh,
    method: &str,
    settings: &sah::StripSettings,
) -> Result<(Strips, Option<usize>)> {
    match method {
        "sah" => Ok((sah::stripify(mesh, settings), None)),
        "meshopt" => {
            let m = meshopt::stripify(mesh, settings.max_length);
            Ok((m.strips, Some(m.native_indices)))
        }
        other => bail!("unknown strip method `{other}` (have: sah, meshopt)"),
    }
}

/// Strip, write, report.
pub fn run(args: Args) -> Result<()> {
    let scene = load(&args.mesh)?;
    if let Some(output) = &args.output {
        refuse_overwriting_input(&args.mesh, &scene, output)?;
    }
    let ext = args
        .output
        .as_ref()
        .and_then(|p| p.extension())
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let settings = sah::StripSettings {
        max_length: args.max_length as usize,
        tunnel_cuts: args.tunnel_cuts as usize,
        partition: args.partition,
    };
    if let Some(path) = args.output.as_ref() {
        let names = scene.triangle_attribute_names();
        if !names.is_empty() {
            eprintln!(
                "note: a strip holds no values per triangle, so {} goes without the triangle attributes {} (`rtmesh convert` to .ply keeps them)",
                path.display(),
                names.join(", ")
            );
        }
    }
    let (strips, native, seconds) = if matches!(ext.as_str(), "gltf" | "glb") {
        // glTF keeps the scene: each geometry is stripped on its own.
        let mut scene = scene.clone();
        let start = std::time::Instant::now();
        let mut all = Vec::new();
        let mut native = None;
        for mesh in &mut scene.meshes {
            *mesh = weld_exact(mesh).mesh;
            let (strips, n) = strips_by(mesh, &args.method, &settings)?;
            native = n.map(|n| n + native.unwrap_or(0));
            all.push(strips);
        }
        let seconds = start.elapsed().as_secs_f64();
        let path = args.output.as_ref().expect("an output has an extension");
        let copies = copy_side_files(&args.mesh, &scene, path)?;
        rtmesh::io::write_gltf_strips(&scene, &all, path, &copies.images)?;
        (all, native, seconds)
    } else {
        let flat = (scene.flatten())
            .with_context(|| format!("{}: cannot flatten the scene", args.mesh))?;
        let mesh = weld_exact(&flat).mesh;
        let start = std::time::Instant::now();
        let (strips, native) = strips_by(&mesh, &args.method, &settings)?;
        let seconds = start.elapsed().as_secs_f64();
        if let Some(path) = &args.output {
            match ext.as_str() {
                "ply" => rtmesh::io::write_ply_strips(&mesh, &strips.to_standard(), path)?,
                "rts" => std::fs::write(path, strips.to_rts(&mesh.positions))
                    .with_context(|| format!("{}: cannot write", path.display()))?,
                _ => bail!(
                    "{}: strips are written as .ply (a tristrips element), .gltf or .glb (TRIANGLE_STRIP primitives) or .rts",
                    path.display()
                ),
            }
        }
        (vec![strips], native, seconds)
    };
    let figures = StripReport::of_all(&strips, seconds);
    let degenerate_not_written = matches!(ext.as_str(), "ply" | "gltf" | "glb").then(|| {
        strips
            .iter()
            .flat_map(Strips::decode)
            .filter(|&t| names_a_vertex_twice(t))
            .count()
    });
    let report = Report {
        mesh: args.mesh,
        tunnel_cuts: (args.method == "sah").then_some(args.tunnel_cuts),
        partition: (args.method == "sah").then_some(args.partition),
        method: args.method,
        max_length: args.max_length,
        native_indices_per_triangle: native.map(|n| n as f64 / figures.triangles.max(1) as f64),
        strips: figures,
        degenerate_not_written,
        output: args.output,
    };
    emit(&report, args.json, |r| {
        let s = &r.strips;
        println!(
            "{}: {} triangles in {} strips by {} (max length {}{}{}) in {:.3} s ({:.2} M triangles/s)",
            r.mesh,
            s.triangles,
            s.strips,
            r.method,
            r.max_length,
            r.tunnel_cuts
                .map_or(String::new(), |c| format!(", tunnels of up to {c} cuts")),
            r.partition
                .filter(|&p| p != sah::PartitionMethod::Sah)
                .map_or(String::new(), |p| format!(", {} partition", p.name())),
            s.seconds,
            s.triangles as f64 / s.seconds.max(1e-9) / 1e6
        );
        println!(
            "  indices      {} ({:.3} per triangle), mean length {:.1}, {} restarts",
            s.indices, s.indices_per_triangle, s.mean_length, s.restarts
        );
        println!(
            "  topology     {:.2} bytes per triangle (indices, turn bits, strip table)",
            s.bytes_per_triangle
        );
        if let Some(n) = r.native_indices_per_triangle {
            println!("  meshopt's own strips: {n:.3} indices per triangle, restarts included");
        }
        if let Some(path) = &r.output {
            println!("  wrote        {}", path.display());
        }
        if let Some(n) = r.degenerate_not_written.filter(|&n| n > 0) {
            println!("  left out     {n} triangles that name a vertex twice (a strip cannot hold them apart from its joins; they cover no surface)");
        }
    })
}

//! `rtmesh bench strips`: strips against triangles, pairs and Embree on the same rays.

use crate::args::{file_name, load, parse_size, ray_kinds, Rays};
use crate::output::{json_line, steps_bar};
use anyhow::{Context, Result};
use rtmesh::trace::measure::with_threads;
use rtmesh::trace::strip::{Inside, MAX_TRACED_LENGTH};
use rtmesh_lab::tables::strips::{strip_rows, StripTable};

/// Strips traced directly, against the same mesh as triangles, pairs and Embree.
///
/// Per mesh (flattened, welded exactly) and method: indices per triangle, bytes per
/// triangle (hierarchy + topology; and in all, with the f32 positions), box and
/// triangle tests per ray, Mrays/s and the share of same first hits as triangle leaves,
/// on the same rays in alternating rounds. Methods: triangles, pairs, sah (Strip-RT),
/// meshopt (meshoptimizer's strips on the same hierarchy), and in builds with the
/// `embree` feature, embree and embree-compact (RTC_SCENE_FLAG_COMPACT).
#[derive(clap::Args)]
pub struct Args {
    /// Mesh files or builtin:NAME.
    #[arg(required = true)]
    meshes: Vec<String>,
    /// Most triangles per strip (at most 64 for tracing).
    #[arg(long, default_value_t = rtmesh::strip::sah::StripSettings::default().max_length as u32, value_parser = clap::value_parser!(u32).range(1..=MAX_TRACED_LENGTH as i64))]
    max_length: u32,
    /// Most cuts of Strip-RT's tunnelling moves after its ordering (0: the published
    /// ordering alone).
    #[arg(long, default_value_t = rtmesh::strip::sah::StripSettings::default().tunnel_cuts as u32, value_parser = clap::value_parser!(u32).range(0..=rtmesh::strip::tunnel::MAX_CUTS as i64))]
    tunnel_cuts: u32,
    /// The hierarchy Strip-RT's ordering measures tree distances in: sah (as
    /// published) or morton (the octree of the centroids' Morton codes).
    #[arg(long, default_value = "sah")]
    partition: rtmesh::strip::sah::PartitionMethod,
    /// Strips per BVH leaf (1..=15).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=15))]
    strips_per_leaf: u32,
    /// quantized (a stored 4-bit box per four triangles, within the strip's leaf box:
    /// 3 bytes a block and 8 a strip), flat (test every triangle of a strip, four at a
    /// time, nothing stored) or implicit (split at the middle, boxes computed on the
    /// fly). Quantized is the default: 1.4–1.6× flat on the default strips
    /// (docs/measurements/strips.md).
    #[arg(long, default_value = "quantized")]
    inside: String,
    /// Workloads, comma separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "primary,diffuse"
    )]
    rays: Vec<Rays>,
    /// Threads (0 = all cores).
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "512x512", value_parser = parse_size)]
    size: (usize, usize),
    /// Timed rounds (medians are reported).
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// Print one JSON object per line instead of a table.
    #[arg(long)]
    json: bool,
}

/// Measure each mesh and print its rows.
pub fn run(args: Args) -> Result<()> {
    let inside = match args.inside.as_str() {
        "flat" => Inside::Flat,
        "implicit" => Inside::Implicit,
        "quantized" => Inside::Quantized,
        other => anyhow::bail!("--inside is flat, implicit or quantized, not `{other}`"),
    };
    let table = StripTable {
        max_length: args.max_length as usize,
        tunnel_cuts: args.tunnel_cuts as usize,
        partition: args.partition,
        strips_per_leaf: args.strips_per_leaf as usize,
        inside,
        kinds: ray_kinds(&args.rays),
        size: args.size,
        runs: args.runs,
    };
    if !args.json {
        println!(
            "{:<22} {:<15} {:<8} {:>7} {:>8} {:>8} {:>8} {:>8} {:>8} {:>7}",
            "mesh",
            "method",
            "workload",
            "idx/tri",
            "B/tri",
            "all B/tri",
            "Mrays/s",
            "box/ray",
            "tri/ray",
            "same"
        );
    }
    with_threads(args.threads, || -> Result<()> {
        for mesh in &args.meshes {
            let scene = load(mesh)?;
            let bar = steps_bar(0);
            let rows = strip_rows(file_name(mesh), &scene, &table, &bar)
                .with_context(|| format!("{mesh}: cannot flatten the scene"))?;
            bar.0.finish_and_clear();
            for row in rows {
                if args.json {
                    println!("{}", json_line(&row));
                } else {
                    println!(
                        "{:<22} {:<15} {:<8} {:>7.3} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>6.2}%",
                        row.mesh, row.method, row.workload, row.indices_per_triangle, row.bytes_per_triangle,
                        row.total_bytes_per_triangle, row.mrays_per_s, row.box_tests_per_ray, row.tri_tests_per_ray,
                        100.0 * row.same_hits
                    );
                }
            }
        }
        Ok(())
    })
}

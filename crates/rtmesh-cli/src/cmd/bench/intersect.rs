//! `rtmesh bench intersect`: the packet paper's experiment, with no BVH.

use crate::args::{file_name, load, parse_size, Intersector, PacketShape};
use crate::output::json_line;
use anyhow::{Context, Result};
use rtmesh::trace::intersect::IntersectorKind;
use rtmesh::trace::measure::with_threads;
use rtmesh_lab::tables::intersect::intersect_rows;

/// The packet paper's experiment: every intersector, no acceleration structure.
///
/// Per mesh: --size primary rays from the default camera in --packet packets (rays of a
/// packet share the camera origin), each ray tested against every triangle, with each
/// intersector (moller, moller-pre, moller-packet, pluecker, watertight) in scalar form
/// and 4- and 8-wide SIMD (8-wide when the CPU has AVX). Reports the median Mrays/s,
/// millions of ray-triangle tests per second, the speedup over scalar moller-pre and
/// the share of rays hitting the same triangle as scalar moller-pre.
#[derive(clap::Args)]
pub struct Args {
    /// Mesh files or builtin:NAME (keep them small: the work is rays × triangles).
    #[arg(required = true)]
    meshes: Vec<String>,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "256x256", value_parser = parse_size)]
    size: (usize, usize),
    /// Packet shape.
    #[arg(long, value_enum, default_value = "2x2")]
    packet: PacketShape,
    /// Intersectors, comma separated (default: all).
    #[arg(long, value_enum, value_delimiter = ',')]
    intersectors: Vec<Intersector>,
    /// Threads (0 = all cores; the paper measured one).
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Timed runs per configuration (medians are reported).
    #[arg(long, default_value_t = 3)]
    runs: usize,
    /// Print one JSON object per line instead of a table.
    #[arg(long)]
    json: bool,
}

/// Measure each mesh on `--threads` threads and print its rows.
pub fn run(args: Args) -> Result<()> {
    if !args.json {
        println!(
            "{:<22} {:>9} {:<14} {:<6} {:>9} {:>9} {:>10} {:>8} {:>8}",
            "mesh",
            "triangles",
            "intersector",
            "simd",
            "seconds",
            "Mrays/s",
            "Mtests/s",
            "speedup",
            "same"
        );
    }
    let kinds: Vec<IntersectorKind> = args.intersectors.iter().map(|&k| k.into()).collect();
    with_threads(args.threads, || -> Result<()> {
        for mesh in &args.meshes {
            let scene = load(mesh)?;
            let name = file_name(mesh);
            for row in intersect_rows(
                name,
                &scene,
                args.size,
                args.packet.side(),
                &kinds,
                args.runs,
            )
            .with_context(|| format!("{mesh}: cannot flatten the scene"))?
            {
                if args.json {
                    println!("{}", json_line(&row));
                } else {
                    println!(
                        "{:<22} {:>9} {:<14} {:<6} {:>9.4} {:>9.3} {:>10.1} {:>7.2}x {:>7.3}%",
                        row.mesh,
                        row.triangles,
                        row.intersector,
                        row.simd,
                        row.seconds,
                        row.mrays_per_s,
                        row.mtests_per_s,
                        row.speedup_over_scalar_moller_pre,
                        100.0 * row.same_hits
                    );
                }
            }
        }
        Ok(())
    })
}

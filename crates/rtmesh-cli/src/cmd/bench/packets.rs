//! `rtmesh bench packets`: packet traversal against single rays.

use crate::args::{file_name, load, parse_size, ray_kinds, Intersector, PacketShape, Rays};
use crate::output::json_line;
use anyhow::Result;
use rtmesh::trace::measure::with_threads;
use rtmesh_lab::tables::packets::packet_rows;

/// Packet traversal against single rays, side by side on the same rays.
///
/// Per mesh and workload: the default single-ray tracer, then packets of each
/// --packets shape with --intersector, timed in alternating rounds (medians), with box
/// and triangle tests per ray from a counted run, the speedup over single rays, and
/// whether every pixel hit the same triangle.
#[derive(clap::Args)]
pub struct Args {
    /// Mesh files or builtin:NAME.
    #[arg(required = true)]
    meshes: Vec<String>,
    /// Workloads, comma separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "primary,diffuse,shadow"
    )]
    rays: Vec<Rays>,
    /// Packet shapes, comma separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "2x2,4x4,8x8")]
    packets: Vec<PacketShape>,
    /// Ray-triangle test in the packets' leaves.
    #[arg(long, value_enum, default_value = "moller-packet")]
    intersector: Intersector,
    /// Threads (0 = all cores).
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x1024", value_parser = parse_size)]
    size: (usize, usize),
    /// Timed rounds (medians are reported).
    #[arg(long, default_value_t = 7)]
    runs: usize,
    /// Print one JSON object per line instead of a table.
    #[arg(long)]
    json: bool,
}

/// Measure each mesh on `--threads` threads and print its rows.
pub fn run(args: Args) -> Result<()> {
    if !args.json {
        println!(
            "{:<22} {:<8} {:<22} {:>9} {:>8} {:>8} {:>9} {:>8} {:>5}",
            "mesh",
            "workload",
            "traversal",
            "Mrays/s",
            "box/ray",
            "tri/ray",
            "seconds",
            "speedup",
            "same"
        );
    }
    let kinds = ray_kinds(&args.rays);
    let sides: Vec<usize> = args.packets.iter().map(|p| p.side()).collect();
    with_threads(args.threads, || -> Result<()> {
        for mesh in &args.meshes {
            let scene = load(mesh)?;
            let name = file_name(mesh);
            let rows = packet_rows(
                name,
                &scene,
                &kinds,
                &sides,
                args.intersector.into(),
                args.size,
                args.runs,
            );
            for row in rows {
                if args.json {
                    println!("{}", json_line(&row));
                } else {
                    println!(
                        "{:<22} {:<8} {:<22} {:>9.2} {:>8.2} {:>8.2} {:>9.4} {:>7.2}x {:>5}",
                        row.mesh,
                        row.workload,
                        row.traversal,
                        row.mrays_per_s,
                        row.box_tests_per_ray,
                        row.tri_tests_per_ray,
                        row.seconds,
                        row.speedup,
                        if row.same_hits_checksum {
                            "yes"
                        } else {
                            "ties"
                        }
                    );
                }
            }
        }
        Ok(())
    })
}

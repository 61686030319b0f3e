//! `rtmesh bench pairing`: the pairing paper's table for rtmesh's tracer.

use crate::args::{file_name, load, parse_size, ray_kinds, Rays};
use crate::output::{json_line, steps_bar};
use anyhow::Result;
use rtmesh::pair::PairMethod;
use rtmesh::trace::measure::with_threads;
use rtmesh_lab::tables::pairing::pairing_rows;

/// The pairing paper's table for rtmesh's tracer: pair counts, time and tracing.
///
/// Per mesh (welded): each method's pairing time (median of --runs) and paired ratio,
/// then the same rays (primary and diffuse) traced through triangle leaves and through
/// each method's pair leaves, alternating configurations each round: box tests,
/// triangle+pair tests and Mrays/s, with Δ against window:2.
#[derive(clap::Args)]
pub struct Args {
    /// Mesh files or builtin:NAME.
    #[arg(required = true)]
    meshes: Vec<String>,
    /// Methods, comma separated: sah, sah-compressed, window:N, sah-max, max (window:2
    /// is always measured as the baseline).
    #[arg(long, value_delimiter = ',', default_value = "sah,sah-max")]
    methods: Vec<PairMethod>,
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
    #[arg(long, default_value = "1024x1024", value_parser = parse_size)]
    size: (usize, usize),
    /// Timed rounds (medians are reported).
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// Print one JSON object per line instead of a table.
    #[arg(long)]
    json: bool,
}

/// Measure each mesh on `--threads` threads and print its rows.
pub fn run(args: Args) -> Result<()> {
    if !args.json {
        println!(
            "{:<20} {:<14} {:<8} {:>9} {:>8} {:>8} {:>8} {:>9} {:>9} {:>8} {:>7} {:>7} {:>7} {:>7}",
            "mesh",
            "method",
            "workload",
            "pair s",
            "paired",
            "rays",
            "box/ray",
            "tri/ray",
            "pair/ray",
            "Mrays/s",
            "Δbox",
            "Δtests",
            "ΔMr/s",
            "same"
        );
    }
    let kinds = ray_kinds(&args.rays);
    with_threads(args.threads, || -> Result<()> {
        for mesh in &args.meshes {
            let scene = load(mesh)?;
            let name = file_name(mesh);
            let bar = steps_bar(0);
            let rows = pairing_rows(
                name,
                &scene,
                &args.methods,
                &kinds,
                args.size,
                args.runs,
                &bar,
            );
            bar.0.finish_and_clear();
            for row in rows {
                if args.json {
                    println!("{}", json_line(&row));
                } else {
                    println!(
                        "{:<20} {:<14} {:<8} {:>9.4} {:>7.2}% {:>8} {:>8.2} {:>9.3} {:>9.3} {:>8.2} {:>6.1}% {:>6.1}% {:>6.1}% {:>6.2}%",
                        row.mesh, row.method, row.workload, row.pair_seconds, 100.0 * row.pair_ratio,
                        row.rays, row.box_tests_per_ray, row.tri_tests_per_ray, row.pair_tests_per_ray,
                        row.mrays_per_s, row.delta_box_percent, row.delta_tests_percent,
                        row.delta_mrays_percent, 100.0 * row.same_hits
                    );
                }
            }
        }
        Ok(())
    })
}

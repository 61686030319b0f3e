//! `rtmesh bench trace`: rtmesh alone, or side by side with Embree or obvhs.

use crate::args::{file_name, load, parse_size, ray_kinds, Rays};
use crate::output::{json_line, steps_bar};
use anyhow::Result;
use clap::ValueEnum;
use rtmesh::optimize::OptimizeOptions;
use rtmesh::progress::Progress;
use rtmesh_lab::reference::CompareSettings;
use rtmesh_lab::tables::quads::{embree_quads, QuadRow, QuadSettings};
use rtmesh_lab::tables::trace::{compare_with, trace_rows, Other};

/// A tracer to compare with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Vs {
    /// Embree 3 (a build with `--features embree`, and libembree-dev).
    Embree,
    /// The obvhs crate's CWBVH (a build with `--features obvhs`).
    Obvhs,
    /// Embree given the input as triangles and `optimize`'s output as quads (its pairs
    /// as one QUAD geometry, unpaired triangles as degenerate quads): BVH bytes, build
    /// time and Mrays/s (a build with `--features embree`).
    EmbreeQuads,
}

/// Trace the same rays through rtmesh and (with --vs) another tracer, side by side.
///
/// For every mesh, thread count and workload: builds each structure --builds times and
/// traces the workload --runs times, alternating tracers, and reports medians, the
/// Mrays/s ratio and the share of rays that hit the same triangle.
#[derive(clap::Args)]
pub struct Args {
    /// Mesh files or builtin:NAME.
    #[arg(required = true)]
    meshes: Vec<String>,
    /// Tracers to compare with, comma separated.
    #[arg(long, value_enum, value_delimiter = ',')]
    vs: Vec<Vs>,
    /// Workloads, comma separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "primary,diffuse"
    )]
    rays: Vec<Rays>,
    /// Thread counts, comma separated (0 = all cores).
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    threads: Vec<usize>,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x1024", value_parser = parse_size)]
    size: (usize, usize),
    /// Timed runs per tracer (medians are reported).
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// Builds per structure (median build time is reported).
    #[arg(long, default_value_t = 3)]
    builds: usize,
    /// Print one JSON object per line (mesh × workload × threads) instead of a table.
    #[arg(long)]
    json: bool,
    /// With --vs embree-quads: the pairing method (default: optimize's, the best of the
    /// input order, sah-max and window:2).
    #[arg(long)]
    pair_method: Option<rtmesh::pair::PairMethod>,
}

/// Measure each mesh and print its rows as they come.
pub fn run(args: Args) -> Result<()> {
    if !args.json {
        if args.vs.is_empty() {
            println!(
                "{:<24} {:>8} {:>3} {:>8} {:>11} {:>8} {:>8} {:>9}",
                "mesh", "rays", "thr", "workload", "Mrays/s", "box/ray", "tri/ray", "build s"
            );
        } else if args.vs.iter().any(|&vs| vs != Vs::EmbreeQuads) {
            println!(
                "{:<24} {:>8} {:>3} {:>8} {:>7} {:>11} {:>10} {:>7} {:>9} {:>9} {:>8}",
                "mesh",
                "rays",
                "thr",
                "workload",
                "vs",
                "rtmesh Mr/s",
                "other Mr/s",
                "ratio",
                "build rt",
                "build ref",
                "same"
            );
        }
    }
    let settings = CompareSettings {
        kinds: ray_kinds(&args.rays),
        size: args.size,
        thread_counts: args.threads.clone(),
        runs: args.runs,
        builds: args.builds,
    };
    // One step per mesh and tracer compared (ticking on while one runs).
    let bar = steps_bar(args.meshes.len() * args.vs.len().max(1));
    bar.0
        .enable_steady_tick(std::time::Duration::from_millis(250));
    for mesh in &args.meshes {
        let scene = bar.0.suspend(|| load(mesh))?;
        let name = file_name(mesh);
        if args.vs.is_empty() {
            bar.message(&format!("{name}: rtmesh"));
            for row in trace_rows(name, &scene, &settings) {
                let line = if args.json {
                    json_line(&row)
                } else {
                    let run = &row.run;
                    format!(
                        "{name:<24} {:>8} {:>3} {:>8} {:>11.2} {:>8.2} {:>8.2} {:>9.3}",
                        run.rays,
                        row.threads,
                        row.workload,
                        run.mrays_per_s,
                        run.box_tests_per_ray,
                        run.tri_tests_per_ray,
                        row.build_seconds
                    )
                };
                bar.0.suspend(|| println!("{line}"));
            }
            bar.advance(1);
            continue;
        }
        for &vs in &args.vs {
            let other = match vs {
                Vs::Embree => Other::Embree,
                Vs::Obvhs => Other::Obvhs,
                Vs::EmbreeQuads => {
                    bar.message(&format!("{name}: Embree on triangles and on quads"));
                    let quads = QuadSettings {
                        kinds: settings.kinds.clone(),
                        size: settings.size,
                        thread_counts: settings.thread_counts.clone(),
                        runs: settings.runs,
                        builds: settings.builds,
                        optimize: OptimizeOptions {
                            pair_method: args.pair_method,
                            ..OptimizeOptions::default()
                        },
                    };
                    let rows = embree_quads(name, &scene, &quads)?;
                    bar.0.suspend(|| print_quads(&rows, args.json));
                    bar.advance(1);
                    continue;
                }
            };
            bar.message(&format!("{name}: rtmesh and {}", other.name()));
            for row in compare_with(other, name, &scene, &settings)? {
                let line = if args.json {
                    json_line(&row)
                } else {
                    format!(
                        "{:<24} {:>8} {:>3} {:>8} {:>7} {:>11.2} {:>10.2} {:>6.2}x {:>9.3} {:>9.3} {:>7.3}%",
                        row.mesh, row.rays, row.threads, row.workload, row.other, row.rtmesh_mrays_per_s,
                        row.other_mrays_per_s, row.ratio, row.rtmesh_build_seconds,
                        row.other_build_seconds, 100.0 * row.same_hits
                    )
                };
                bar.0.suspend(|| println!("{line}"));
            }
            bar.advance(1);
        }
    }
    bar.0.finish_and_clear();
    Ok(())
}

/// The rows of `--vs embree-quads`, under their own header.
fn print_quads(rows: &[QuadRow], json: bool) {
    if json {
        rows.iter().for_each(|row| println!("{}", json_line(row)));
        return;
    }
    println!(
        "{:<24} {:>11} {:>7} {:>8} {:>3} {:>8} {:>9} {:>9} {:>7} {:>10} {:>10} {:>8} {:>8} {:>8}",
        "mesh",
        "pairing",
        "paired",
        "workload",
        "thr",
        "rays",
        "tri Mr/s",
        "quad Mr/s",
        "speed",
        "tri bytes",
        "quad bytes",
        "tri bld",
        "quad bld",
        "same"
    );
    for r in rows {
        println!(
            "{:<24} {:>11} {:>6.2}% {:>8} {:>3} {:>8} {:>9.2} {:>9.2} {:>6.2}x {:>10} {:>10} {:>8.4} {:>8.4} {:>7.3}%",
            r.mesh, r.pairing, 100.0 * r.pair_ratio, r.workload, r.threads, r.rays,
            r.triangles_mrays_per_s, r.quads_mrays_per_s, r.speedup, r.triangles_bvh_bytes,
            r.quads_bvh_bytes, r.triangles_build_seconds, r.quads_build_seconds,
            100.0 * r.same_hits
        );
    }
}

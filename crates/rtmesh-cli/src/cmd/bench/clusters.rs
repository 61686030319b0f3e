//! `rtmesh bench clusters`: cluster quality against meshoptimizer's, at equal count.

use crate::args::{file_name, load};
use crate::output::{json_line, steps_bar};
use anyhow::{Context, Result};
use rtmesh::animate::{Animation, Motion};
use rtmesh::trace::measure::with_threads;
use rtmesh_lab::tables::clusters::{cluster_rows, ClusterTable};

/// Cluster quality as meshoptimizer evaluates it, at equal cluster count.
///
/// Per mesh: clusters by grow and contract (Acc(k)) at --max-count, and for each,
/// meshoptimizer's spatial clusters with the MaxCount (a multiple of 4) whose cluster
/// count is nearest theirs. All are found on the rest pose and kept through the motion;
/// at each phase the table gives the SAH cost of the tree the tracer walks over them
/// (the BVH each frame builds over the cluster boxes, as `dynamic --groups frame`, plus
/// the node inside each cluster: a measure of the clusters, not of groups fixed at
/// rest) beside a full per-triangle rebuild's, and the clusters' vertices per
/// triangle, precompute time and disconnected clusters.
///
/// Example:
///   rtmesh bench clusters dragon_vrip.ply --motion twist
#[derive(clap::Args)]
pub struct Args {
    /// Mesh files or builtin:NAME.
    #[arg(required = true)]
    meshes: Vec<String>,
    /// The motion: twist, bend, wave, explode, or gltf / gltf:NAME.
    #[arg(long, default_value = "twist")]
    motion: Motion,
    /// MaxCount of grow and contract (1..=256).
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=256))]
    max_count: u32,
    /// MaxSize of grow and contract.
    #[arg(long, default_value_t = rtmesh::cluster::DEFAULT_MAX_SIZE)]
    max_size: f32,
    #[command(flatten)]
    refinement: crate::cmd::cluster::Refinement,
    /// Phases of the motion, comma separated (0 is the rest pose).
    #[arg(long, value_delimiter = ',', default_value = "0,0.5,1")]
    phases: Vec<f32>,
    /// Threads (0 = all cores).
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Print one JSON object per line instead of a table.
    #[arg(long)]
    json: bool,
}

/// Measure each mesh and print its rows.
pub fn run(args: Args) -> Result<()> {
    let table = ClusterTable {
        settings: crate::cmd::cluster::settings(args.max_count, args.max_size, &args.refinement),
        phases: args.phases.clone(),
    };
    if !args.json {
        let phases: Vec<String> = args
            .phases
            .iter()
            .map(|p| format!("{:>7}", format!("SAH@{p}")))
            .collect();
        println!(
            "{:<22} {:<22} {:>4} {:>8} {:>6} {:>6} {:>6} {:>5} {:>7}  {}",
            "mesh",
            "method",
            "max",
            "clusters",
            "tri/c",
            "v/tri",
            "floor",
            "disc",
            "µs/tri",
            phases.join(" ")
        );
    }
    with_threads(args.threads, || -> Result<()> {
        for name in &args.meshes {
            let scene = load(name)?;
            let (mesh, animation) = Animation::of(&scene, &args.motion)
                .with_context(|| format!("{name}: --motion {}", args.motion))?;
            let bar = steps_bar(0);
            let rows = cluster_rows(file_name(name), &mesh, &animation, &table, &bar);
            bar.0.finish_and_clear();
            if !args.json {
                let sah: Vec<String> = rows[0]
                    .rebuild_sah
                    .iter()
                    .map(|s| format!("{s:>7.2}"))
                    .collect();
                println!(
                    "{:<22} {:<22} {:>48}  {}",
                    file_name(name),
                    "rebuild",
                    "",
                    sah.join(" ")
                );
            }
            for row in rows {
                if args.json {
                    println!("{}", json_line(&row));
                } else {
                    let method = match row.matched_to {
                        Some(m) => format!("{} ({m}'s n)", row.method),
                        None => row.method.to_owned(),
                    };
                    let sah: Vec<String> = row.sah.iter().map(|s| format!("{s:>7.2}")).collect();
                    println!(
                        "{:<22} {:<22} {:>4} {:>8} {:>6.1} {:>6.3} {:>6.3} {:>5} {:>7.3}  {}",
                        row.mesh,
                        method,
                        row.max_triangles,
                        row.clusters,
                        row.mean_triangles,
                        row.mean_vertices_per_triangle,
                        row.floor_vertices_per_triangle,
                        row.disconnected,
                        row.precompute_us_per_triangle,
                        sah.join(" ")
                    );
                }
            }
        }
        Ok(())
    })
}

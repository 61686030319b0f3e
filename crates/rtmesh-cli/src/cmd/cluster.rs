//! `rtmesh cluster`: precomputed triangle clusters (Garanzha 2009) of a mesh.

use crate::args::load;
use crate::output::emit;
use anyhow::Result;
use rtmesh::cluster::{disconnected, ClusterMethod, ClusterReport, ClusterSettings};
use serde::Serialize;

/// Group a mesh's triangles into clusters for animated meshes: connected, disk-like,
/// compact sets of at most --max-count triangles on at most 256 vertices, grown one
/// neighbour at a time (or contracted from single triangles) by the acceptance
/// heuristic Acc(k) (the formula is in crates/rtmesh/src/cluster/mod.rs), stored as u8
/// indices into each cluster's vertex list. Every frame, `rtmesh dynamic --build
/// clusters` then recomputes only the clusters' boxes and builds a BVH over them.
#[derive(clap::Args)]
pub struct Args {
    /// The mesh file, or builtin:NAME.
    mesh: String,
    /// grow (iterative growing by Acc(k)), contract (iterative contraction of the
    /// dual graph's best edge by Acc(k₁ ∪ k₂): more memory and time, see
    /// docs/measurements/clusters.md) or meshopt (meshoptimizer's spatial
    /// clusterizer, min = max / 4, fill weight 0.5: the baseline).
    #[arg(long, default_value = "grow")]
    method: ClusterMethod,
    /// MaxCount: most triangles per cluster (1..=256).
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=256))]
    max_count: u32,
    /// MaxSize: the cluster's bounding radius may reach this times the radius of a disk
    /// of its expected area.
    #[arg(long, default_value_t = rtmesh::cluster::DEFAULT_MAX_SIZE)]
    max_size: f32,
    #[command(flatten)]
    refinement: Refinement,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// Boundary refinement of the clusters, an option of `cluster`, `dynamic` and `bench
/// clusters`.
#[derive(clap::Args)]
pub struct Refinement {
    /// Passes of boundary refinement after grow or contract (not in the slides): border
    /// triangles move to the neighbouring cluster where that lowers the clusters'
    /// SAH-like cost (5% lower SAH on the dragon at 8, for 1.9× the precompute;
    /// docs/measurements/clusters.md). 0 keeps the published clusters.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=64))]
    pub refine_passes: u32,
}

/// The settings `cluster`, `dynamic` and `bench clusters` share.
pub fn settings(max_count: u32, max_size: f32, refinement: &Refinement) -> ClusterSettings {
    ClusterSettings {
        max_triangles: max_count as usize,
        max_size,
        refine_passes: refinement.refine_passes as usize,
        ..ClusterSettings::default()
    }
}

/// What `cluster` made.
#[derive(Serialize)]
pub struct Report {
    mesh: String,
    method: ClusterMethod,
    /// Passes of boundary refinement (grow and contract; absent when none).
    #[serde(skip_serializing_if = "Option::is_none")]
    refine_passes: Option<u32>,
    #[serde(flatten)]
    clusters: ClusterReport,
}

/// Cluster every geometry (their figures summed) and report.
pub fn run(args: Args) -> Result<()> {
    let settings = settings(args.max_count, args.max_size, &args.refinement);
    let scene = load(&args.mesh)?;
    let start = std::time::Instant::now();
    let all: Vec<_> = scene
        .meshes
        .iter()
        .map(|m| args.method.cluster(m, &settings))
        .collect();
    let seconds = start.elapsed().as_secs_f64();
    let disconnected: usize = scene
        .meshes
        .iter()
        .zip(&all)
        .map(|(m, c)| disconnected(m, c))
        .sum();
    let total = ClusterReport {
        disconnected,
        ..ClusterReport::of_all(&all, seconds)
    };
    let report = Report {
        mesh: args.mesh,
        refine_passes: (args.refinement.refine_passes > 0 && args.method != ClusterMethod::Meshopt)
            .then_some(args.refinement.refine_passes),
        method: args.method,
        clusters: total,
    };
    emit(&report, args.json, |r| {
        let c = &r.clusters;
        println!(
            "{}: {} triangles in {} clusters by {}{} in {:.3} s ({:.3} µs per triangle)",
            r.mesh,
            c.triangles,
            c.clusters,
            r.method,
            r.refine_passes
                .map_or(String::new(), |p| format!(", refined in up to {p} passes")),
            c.seconds,
            1e6 * c.seconds / c.triangles.max(1) as f64
        );
        println!(
            "  per cluster  {:.1} triangles, {:.3} vertices per triangle (at least {:.3} for disks of these sizes on a regular mesh)",
            c.mean_triangles, c.mean_vertices_per_triangle, c.floor_vertices_per_triangle
        );
        println!(
            "  storage      {} bytes ({:.2} per triangle) against {} as u32 triangles",
            c.bytes,
            c.bytes as f64 / c.triangles.max(1) as f64,
            c.indexed_bytes
        );
    })
}

//! `rtmesh bench clusters`: cluster quality as meshoptimizer evaluates its spatial
//! clusters, at equal cluster count. Per mesh and method, the clusters are found once
//! on the rest pose and kept through the motion; at each phase the SAH cost of the
//! two-level tree the tracer walks (the BVH over the cluster boxes plus the 8-wide node
//! over each cluster's 4-triangle blocks, `Inside::Node`) is set beside a full
//! per-triangle rebuild's. Methods: `grow` and `contract` (Acc(k)) at the given
//! MaxCount, and for each of them `meshopt`, meshoptimizer's spatial clusterizer with
//! its MaxCount searched (multiples of 4, as it takes them) for the cluster count
//! nearest theirs.

use crate::harness::seconds;
use rtmesh::animate::Animation;
use rtmesh::bvh::BuildSettings;
use rtmesh::cluster::{
    disconnected, ClusterFrames, ClusterMethod, ClusterReport, ClusterSettings, Clusters, Inside,
    MAX_CLUSTER_TRIANGLES,
};
use rtmesh::progress::Progress;
use rtmesh::trace::SceneAccel;
use rtmesh::{Scene, TriMesh};
use serde::Serialize;
use std::collections::BTreeMap;

/// What the table measures.
pub struct ClusterTable {
    /// The clusters' limits for grow and contract.
    pub settings: ClusterSettings,
    /// Phases of the motion at which the SAH is taken (0 is the rest pose).
    pub phases: Vec<f32>,
}

/// One clustering of one mesh.
#[derive(Clone, Debug, Serialize)]
pub struct ClusterRow {
    /// Mesh name.
    pub mesh: String,
    /// grow, contract or meshopt.
    pub method: &'static str,
    /// For meshopt, the method whose cluster count it was matched to.
    pub matched_to: Option<&'static str>,
    /// MaxCount used.
    pub max_triangles: usize,
    /// Clusters found.
    pub clusters: usize,
    /// Mean triangles per cluster.
    pub mean_triangles: f64,
    /// Cluster vertices over triangles.
    pub mean_vertices_per_triangle: f64,
    /// The least of it for clusters of the same sizes on a regular mesh
    /// (`rtmesh::cluster::disk_vertex_floor`).
    pub floor_vertices_per_triangle: f64,
    /// Clusters not connected through shared edges.
    pub disconnected: usize,
    /// Seconds to find the clusters.
    pub precompute_seconds: f64,
    /// The same, in microseconds per triangle.
    pub precompute_us_per_triangle: f64,
    /// The phases measured.
    pub phases: Vec<f32>,
    /// SAH cost of the tree over these clusters at each phase.
    pub sah: Vec<f32>,
    /// SAH cost of a full per-triangle rebuild at each phase.
    pub rebuild_sah: Vec<f32>,
}

/// The rows of one mesh under `animation` (whose rest mesh is `mesh`).
pub fn cluster_rows(
    name: &str,
    mesh: &TriMesh,
    animation: &Animation,
    table: &ClusterTable,
    progress: &dyn Progress,
) -> Vec<ClusterRow> {
    let frames: Vec<TriMesh> = table
        .phases
        .iter()
        .map(|&phase| {
            let mut frame = mesh.clone();
            frame.positions = animation.positions(phase);
            frame
        })
        .collect();
    progress.message(&format!("{name}: rebuilds"));
    let rebuild_sah: Vec<f32> = frames
        .iter()
        .map(|f| {
            let scene = Scene::from_mesh(f.clone());
            SceneAccel::build(&scene, &BuildSettings::default())
                .stats()
                .sah_cost
        })
        .collect();
    let row = |method: ClusterMethod, matched_to, max_triangles, clusters: &Clusters, s: f64| {
        let report = ClusterReport::of(clusters, s);
        let mut cluster_frames = ClusterFrames::new(clusters, Inside::Node, mesh);
        let sah = frames
            .iter()
            .map(|f| {
                let accel = cluster_frames.build(f);
                let sah = accel.stats().sah_cost;
                cluster_frames.recycle(accel);
                sah
            })
            .collect();
        ClusterRow {
            mesh: name.to_owned(),
            method: method.name(),
            matched_to,
            max_triangles,
            clusters: report.clusters,
            mean_triangles: report.mean_triangles,
            mean_vertices_per_triangle: report.mean_vertices_per_triangle,
            floor_vertices_per_triangle: report.floor_vertices_per_triangle,
            disconnected: disconnected(mesh, clusters),
            precompute_seconds: s,
            precompute_us_per_triangle: 1e6 * s / mesh.triangle_count().max(1) as f64,
            phases: table.phases.clone(),
            sah,
            rebuild_sah: rebuild_sah.clone(),
        }
    };
    let mut rows = Vec::new();
    // meshoptimizer's clusters by MaxCount / 4, found once each.
    let mut theirs: BTreeMap<usize, (Clusters, f64)> = BTreeMap::new();
    let meshopt = |theirs: &mut BTreeMap<usize, (Clusters, f64)>, quarter: usize| {
        let entry = theirs.entry(quarter).or_insert_with(|| {
            let settings = ClusterSettings {
                max_triangles: 4 * quarter,
                ..table.settings.clone()
            };
            let mut clusters = Clusters::default();
            let s = seconds(|| clusters = ClusterMethod::Meshopt.cluster(mesh, &settings));
            (clusters, s)
        });
        entry.0.len()
    };
    for method in [ClusterMethod::Grow, ClusterMethod::Contract] {
        progress.message(&format!("{name}: {method}"));
        let mut clusters = Clusters::default();
        let s = seconds(|| clusters = method.cluster(mesh, &table.settings));
        rows.push(row(
            method,
            None,
            table.settings.max_triangles,
            &clusters,
            s,
        ));
        // The smallest MaxCount / 4 whose count is at most ours (counts fall as MaxCount
        // grows), or the one below it if that is nearer.
        progress.message(&format!("{name}: meshopt at {method}'s count"));
        let target = clusters.len();
        let (mut lo, mut hi) = (1usize, MAX_CLUSTER_TRIANGLES / 4);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if meshopt(&mut theirs, mid) <= target {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        let nearest = if lo > 1
            && meshopt(&mut theirs, lo - 1).abs_diff(target)
                < meshopt(&mut theirs, lo).abs_diff(target)
        {
            lo - 1
        } else {
            lo
        };
        let (clusters, s) = &theirs[&nearest];
        let matched = Some(method.name());
        rows.push(row(
            ClusterMethod::Meshopt,
            matched,
            4 * nearest,
            clusters,
            *s,
        ));
    }
    rows
}

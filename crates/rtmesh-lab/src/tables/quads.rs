//! `rtmesh bench trace --vs embree-quads`: does a production tracer confirm what
//! `optimize` claims? The same rays through Embree given the input as triangles and
//! given `optimize`'s output as quads (its pairs, one QUAD geometry per instance with the
//! unpaired triangles as degenerate quads), alternating rounds, medians; BVH bytes from
//! Embree's memory monitor, build time, and the share of rays that hit the same input
//! triangle through `optimize`'s map.

use crate::LabError;
use rtmesh::optimize::{OptimizeOptions, Optimized};
use rtmesh::trace::run::trace_closest;
use rtmesh::trace::{NoCounters, RayKind, Workload};
use rtmesh::Scene;
use serde::Serialize;

/// One mesh, workload and thread count: Embree on triangles against Embree on quads.
#[derive(Clone, Debug, Serialize)]
pub struct QuadRow {
    /// Mesh name.
    pub mesh: String,
    /// The pairing `optimize` kept.
    pub pairing: String,
    /// Paired triangles over all triangles of the output.
    pub pair_ratio: f64,
    /// Workload kind.
    pub workload: &'static str,
    /// Threads traced and built on.
    pub threads: usize,
    /// Rays traced.
    pub rays: usize,
    /// Embree's median Mrays/s on the input's triangles.
    pub triangles_mrays_per_s: f64,
    /// Embree's median Mrays/s on the output's quads.
    pub quads_mrays_per_s: f64,
    /// Quads over triangles.
    pub speedup: f64,
    /// Embree's BVH bytes for the triangles.
    pub triangles_bvh_bytes: usize,
    /// Embree's BVH bytes for the quads.
    pub quads_bvh_bytes: usize,
    /// Median build seconds, triangles.
    pub triangles_build_seconds: f64,
    /// Median build seconds, quads.
    pub quads_build_seconds: f64,
    /// Share of primary rays that hit the same input triangle (or miss in both).
    pub same_hits: f64,
}

/// Settings of [`embree_quads`].
#[derive(Clone, Debug)]
pub struct QuadSettings {
    /// Workloads.
    pub kinds: Vec<RayKind>,
    /// Image size of the primary rays.
    pub size: (usize, usize),
    /// Thread counts (0 = all cores).
    pub thread_counts: Vec<usize>,
    /// Alternating timed rounds.
    pub runs: usize,
    /// Builds of each scene (median build time).
    pub builds: usize,
    /// What `optimize` does (its measurement is not needed).
    pub optimize: OptimizeOptions,
}

/// Embree on `scene`'s triangles and on its optimized quads.
#[cfg(feature = "embree")]
pub fn embree_quads(
    mesh: &str,
    scene: &Scene,
    settings: &QuadSettings,
) -> Result<Vec<QuadRow>, LabError> {
    let options = OptimizeOptions {
        measure: None,
        ..settings.optimize.clone()
    };
    let optimized = rtmesh::optimize::optimize_mapped(scene, &options, &())
        .map_err(|e| LabError::Embree(format!("{mesh}: {e}")))?;
    embree_quads_of(mesh, scene, &optimized, settings)
}

/// [`embree_quads`] of `scene` optimized already (`settings.optimize` unused).
#[cfg(feature = "embree")]
pub fn embree_quads_of(
    mesh: &str,
    scene: &Scene,
    optimized: &Optimized,
    settings: &QuadSettings,
) -> Result<Vec<QuadRow>, LabError> {
    use crate::embree::EmbreeScene;
    use rtmesh::trace::measure::{median, with_threads, Traced};
    use rtmesh::trace::View;
    let pairings = optimized.pairings();
    let mut rows = Vec::new();
    for &threads in &settings.thread_counts {
        let built = with_threads(threads, || -> Result<Vec<QuadRow>, LabError> {
            let mut triangle_builds = Vec::new();
            let mut quad_builds = Vec::new();
            let (mut triangles, mut quads) = (None, None);
            for _ in 0..settings.builds.max(1) {
                let t = EmbreeScene::build(scene, threads)?;
                triangle_builds.push(t.build_seconds);
                triangles = Some(t);
                let q = EmbreeScene::build_quads(&optimized.scene, &pairings, threads)?;
                quad_builds.push(q.build_seconds);
                quads = Some(q);
            }
            let (triangles, quads) = (triangles.expect("built"), quads.expect("built"));
            let traced = Traced {
                scene,
                before: &triangles,
                after: &quads,
                view: View::Iso,
            };
            let same = same_hits(scene, optimized, &triangles, &quads, settings.size);
            let choice = optimized.report.pairing.as_ref();
            Ok(traced
                .compare(&settings.kinds, settings.size, settings.runs, &())
                .into_iter()
                .map(|row| QuadRow {
                    mesh: mesh.to_owned(),
                    pairing: choice.map_or(String::new(), |c| c.method.clone()),
                    pair_ratio: optimized.report.pair_ratio,
                    workload: row.workload,
                    threads: rayon::current_num_threads(),
                    rays: row.rays,
                    triangles_mrays_per_s: row.mrays_before,
                    quads_mrays_per_s: row.mrays_after,
                    speedup: row.mrays_after / row.mrays_before.max(1e-12),
                    triangles_bvh_bytes: triangles.bvh_bytes,
                    quads_bvh_bytes: quads.bvh_bytes,
                    triangles_build_seconds: median(&triangle_builds),
                    quads_build_seconds: median(&quad_builds),
                    same_hits: same,
                })
                .collect())
        })?;
        rows.extend(built);
    }
    Ok(rows)
}

/// Without the `embree` feature: an error that says how to build it.
#[cfg(not(feature = "embree"))]
pub fn embree_quads(mesh: &str, scene: &Scene, _: &QuadSettings) -> Result<Vec<QuadRow>, LabError> {
    Err(LabError::MissingFeature {
        tracer: "embree",
        mesh: format!("{mesh} ({} triangles)", scene.instanced_triangle_count()),
    })
}

/// Share of primary rays whose hit through `before` (the input) and through `after`
/// (the optimized output) is the same input triangle, a tie, or a miss in both
/// ([`rtmesh::optimize::same_hits`]).
pub fn same_hits(
    input: &Scene,
    optimized: &Optimized,
    before: &impl rtmesh::trace::Tracer,
    after: &impl rtmesh::trace::Tracer,
    size: (usize, usize),
) -> f64 {
    let work = Workload::generate(RayKind::Primary, input, before, size.0, size.1, 1);
    let a = trace_closest::<NoCounters>(before, &work.rays).0;
    let b = trace_closest::<NoCounters>(after, &work.rays).0;
    rtmesh::optimize::same_hits(input, optimized, &a, &b).share
}

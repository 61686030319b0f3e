//! `rtmesh bench packets`: packet traversal against single rays on the same rays, in
//! alternating rounds (medians), with work per ray from a counted run and whether
//! every pixel hit the same triangle.

use crate::harness::median;
use rtmesh::bvh::BuildSettings;
use rtmesh::trace::intersect::IntersectorKind;
use rtmesh::trace::measure::{measure, measure_packets_by_kind};
use rtmesh::trace::{RayKind, SceneAccel, TraceRun, Workload};
use rtmesh::Scene;
use serde::Serialize;

/// One traversal on one workload.
#[derive(Clone, Debug, Serialize)]
pub struct PacketRow {
    /// Mesh name.
    pub mesh: String,
    /// Workload kind.
    pub workload: &'static str,
    /// `single (builtin)` or `NxN INTERSECTOR`.
    pub traversal: String,
    /// Rays traced.
    pub rays: usize,
    /// Threads.
    pub threads: usize,
    /// Median seconds.
    pub seconds: f64,
    /// Mrays/s at the median.
    pub mrays_per_s: f64,
    /// Box tests per ray.
    pub box_tests_per_ray: f64,
    /// Triangle tests per ray.
    pub tri_tests_per_ray: f64,
    /// Single rays' median seconds over this one's.
    pub speedup: f64,
    /// Whether the hit checksum equals single rays' (every pixel, same triangle).
    pub same_hits_checksum: bool,
}

/// Single rays, then packets of each side in `sides` with `intersector`, for each
/// workload of `kinds` at `size`, `runs` rounds.
pub fn packet_rows(
    mesh: &str,
    scene: &Scene,
    kinds: &[RayKind],
    sides: &[usize],
    intersector: IntersectorKind,
    (width, height): (usize, usize),
    runs: usize,
) -> Vec<PacketRow> {
    let accel = SceneAccel::build(scene, &BuildSettings::default());
    let mut rows = Vec::new();
    for &kind in kinds {
        let work = Workload::generate(kind, scene, &accel, width, height, 1);
        let grouped: Vec<(usize, Workload, Vec<u32>)> = sides
            .iter()
            .map(|&side| {
                let (w, starts) = work.grouped(side);
                (side, w, starts)
            })
            .collect();
        // Alternate configurations each round; runs = 1 per call, so every call also
        // counts once (untimed).
        let mut results: Vec<Vec<TraceRun>> = vec![Vec::new(); sides.len() + 1];
        for _ in 0..runs.max(1) {
            results[0].push(measure(&accel, &work, 1));
            for (k, (_, w, starts)) in grouped.iter().enumerate() {
                results[k + 1].push(measure_packets_by_kind(intersector, &accel, w, starts, 1));
            }
        }
        let median_of =
            |runs: &[TraceRun]| median(&runs.iter().map(|r| r.seconds).collect::<Vec<_>>());
        let base = median_of(&results[0]);
        let reference = results[0][0].hit_checksum;
        for (k, runs) in results.iter().enumerate() {
            let traversal = if k == 0 {
                "single (builtin)".to_owned()
            } else {
                let side = grouped[k - 1].0;
                format!("{side}x{side} {}", intersector.name())
            };
            let seconds = median_of(runs);
            let run = &runs[0];
            rows.push(PacketRow {
                mesh: mesh.to_owned(),
                workload: kind.name(),
                traversal,
                rays: run.rays,
                threads: rayon::current_num_threads(),
                seconds,
                mrays_per_s: run.rays as f64 / seconds / 1e6,
                box_tests_per_ray: run.box_tests_per_ray,
                tri_tests_per_ray: run.tri_tests_per_ray,
                speedup: base / seconds,
                same_hits_checksum: run.hit_checksum == reference,
            });
        }
    }
    rows
}

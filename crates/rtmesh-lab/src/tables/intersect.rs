//! `rtmesh bench intersect`: the packet paper's experiment (Komatsu et al.), with no
//! acceleration structure. Primary rays in packets that share the camera origin, each
//! ray tested against every triangle, with every intersector in scalar form and 4- and
//! 8-wide SIMD; speed in Mrays/s and millions of ray-triangle tests per second, against
//! scalar `moller-pre`. Cost: rays × triangles per run.

use crate::harness::{median, seconds};
use rayon::prelude::*;
use rtmesh::mesh::TooManyToFlatten;
use rtmesh::trace::intersect::{closest_without_bvh_by_kind, IntersectorKind, Simd, TriangleSoa};
use rtmesh::trace::{Camera, Hit, Workload};
use rtmesh::{Ray, Scene};
use serde::Serialize;

/// One intersector at one SIMD width.
#[derive(Clone, Debug, Serialize)]
pub struct IntersectRow {
    /// Mesh name.
    pub mesh: String,
    /// Triangles tested per ray.
    pub triangles: usize,
    /// Rays traced.
    pub rays: usize,
    /// Packet shape, `NxN`.
    pub packet: String,
    /// Intersector name.
    pub intersector: &'static str,
    /// SIMD width name.
    pub simd: &'static str,
    /// Threads.
    pub threads: usize,
    /// Median seconds.
    pub seconds: f64,
    /// Mrays/s at the median.
    pub mrays_per_s: f64,
    /// Millions of ray-triangle tests per second.
    pub mtests_per_s: f64,
    /// Scalar moller-pre's seconds over these.
    pub speedup_over_scalar_moller_pre: f64,
    /// Share of rays hitting the same triangle as scalar moller-pre.
    pub same_hits: f64,
}

/// One configuration: `rays` (packets are consecutive runs of `packet` rays sharing an
/// origin) against every triangle of `soa`, `runs` times on the current rayon pool (a
/// work item is 64 packets); the median seconds and the hits.
pub fn measure_without_bvh(
    kind: IntersectorKind,
    simd: Simd,
    soa: &TriangleSoa,
    rays: &[Ray],
    packet: usize,
    runs: usize,
) -> (f64, Vec<Hit>) {
    let mut hits = vec![Hit::MISS; rays.len()];
    let chunk = packet * 64;
    let times: Vec<f64> = (0..runs.max(1))
        .map(|_| {
            seconds(|| {
                rays.par_chunks(chunk)
                    .zip(hits.par_chunks_mut(chunk))
                    .for_each(|(rays, hits)| {
                        closest_without_bvh_by_kind(kind, simd, soa, rays, hits, packet)
                    })
            })
        })
        .collect();
    (median(&times), hits)
}

/// Every intersector of `kinds` (all when empty) at every SIMD width this CPU runs, on
/// `size` primary rays of `scene` in `side`×`side` packets.
pub fn intersect_rows(
    mesh: &str,
    scene: &Scene,
    (width, height): (usize, usize),
    side: usize,
    kinds: &[IntersectorKind],
    runs: usize,
) -> Result<Vec<IntersectRow>, TooManyToFlatten> {
    let kinds = if kinds.is_empty() {
        IntersectorKind::ALL.to_vec()
    } else {
        kinds.to_vec()
    };
    let flat = scene.flatten()?;
    let soa = TriangleSoa::from_mesh(&flat);
    let camera = Camera::default_for(&scene.bounds(), width, height);
    let (work, _) = Workload::primary_packets(&camera, width, height, side);
    let packet = side * side;
    let (base_seconds, base_hits) = measure_without_bvh(
        IntersectorKind::MollerPre,
        Simd::Scalar,
        &soa,
        &work.rays,
        packet,
        runs,
    );
    let triangles = flat.triangle_count();
    let mut rows = Vec::new();
    for &kind in &kinds {
        for simd in Simd::available() {
            let (seconds, hits) = if kind == IntersectorKind::MollerPre && simd == Simd::Scalar {
                (base_seconds, base_hits.clone())
            } else {
                measure_without_bvh(kind, simd, &soa, &work.rays, packet, runs)
            };
            let same = crate::harness::same_triangle_share(&hits, &base_hits);
            let mrays = work.rays.len() as f64 / seconds / 1e6;
            rows.push(IntersectRow {
                mesh: mesh.to_owned(),
                triangles,
                rays: work.rays.len(),
                packet: format!("{side}x{side}"),
                intersector: kind.name(),
                simd: simd.name(),
                threads: rayon::current_num_threads(),
                seconds,
                mrays_per_s: mrays,
                mtests_per_s: mrays * triangles as f64,
                speedup_over_scalar_moller_pre: base_seconds / seconds,
                same_hits: same,
            });
        }
    }
    Ok(rows)
}

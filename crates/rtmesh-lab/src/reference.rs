//! Side-by-side comparisons: the very same rays through rtmesh and through another
//! tracer (Embree with the `embree` feature), timed alternately in one process, with
//! medians, build times and the share of rays that hit the same input triangle.

use crate::LabError;
use rtmesh::bvh::BuildSettings;
use rtmesh::trace::measure::{median, with_threads};
use rtmesh::trace::run::{trace_closest, trace_occluded};
use rtmesh::trace::{Hit, NoCounters, RayKind, SceneAccel, Tracer, Workload};
use rtmesh::Scene;
use serde::ser::{Serialize, SerializeMap, Serializer};

/// One mesh, one workload, one thread count: rtmesh against another tracer. In JSON
/// the other tracer's figures are named after it (`embree_mrays_per_s`,
/// `embree_build_seconds`).
#[derive(Clone, Debug)]
pub struct Comparison {
    /// Mesh name.
    pub mesh: String,
    /// Workload kind (primary, diffuse, shadow).
    pub workload: String,
    /// Rays traced per run.
    pub rays: usize,
    /// Threads used for tracing and building.
    pub threads: usize,
    /// The other tracer's name.
    pub other: String,
    /// rtmesh's median Mrays/s.
    pub rtmesh_mrays_per_s: f64,
    /// The other tracer's median Mrays/s (`embree_mrays_per_s` in JSON when it is Embree).
    pub other_mrays_per_s: f64,
    /// rtmesh Mrays/s over the other's.
    pub ratio: f64,
    /// rtmesh's median build seconds.
    pub rtmesh_build_seconds: f64,
    /// The other's median build seconds.
    pub other_build_seconds: f64,
    /// Share of rays with the same outcome (same instance and input triangle, or both
    /// miss; for shadow rays the same occlusion).
    pub same_hits: f64,
    /// rtmesh's BVH SAH cost.
    pub rtmesh_sah_cost: f32,
}

impl Serialize for Comparison {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let other = self.other.to_lowercase();
        let mut map = serializer.serialize_map(Some(12))?;
        map.serialize_entry("mesh", &self.mesh)?;
        map.serialize_entry("workload", &self.workload)?;
        map.serialize_entry("rays", &self.rays)?;
        map.serialize_entry("threads", &self.threads)?;
        map.serialize_entry("other", &self.other)?;
        map.serialize_entry("rtmesh_mrays_per_s", &self.rtmesh_mrays_per_s)?;
        map.serialize_entry(&format!("{other}_mrays_per_s"), &self.other_mrays_per_s)?;
        map.serialize_entry("ratio", &self.ratio)?;
        map.serialize_entry("rtmesh_build_seconds", &self.rtmesh_build_seconds)?;
        map.serialize_entry(&format!("{other}_build_seconds"), &self.other_build_seconds)?;
        map.serialize_entry("same_hits", &self.same_hits)?;
        map.serialize_entry("rtmesh_sah_cost", &self.rtmesh_sah_cost)?;
        map.end()
    }
}

/// Outcome of one timed run.
enum Outcome {
    Hits(Vec<Hit>),
    Occluded(Vec<bool>),
}

fn timed_run(tracer: &impl Tracer, workload: &Workload) -> (f64, Outcome) {
    let start = std::time::Instant::now();
    let outcome = if workload.kind == RayKind::Shadow {
        Outcome::Occluded(trace_occluded::<NoCounters>(tracer, &workload.rays).0)
    } else {
        Outcome::Hits(trace_closest::<NoCounters>(tracer, &workload.rays).0)
    };
    (start.elapsed().as_secs_f64(), outcome)
}

fn same_share(a: &Outcome, b: &Outcome) -> f64 {
    let (same, n) = match (a, b) {
        (Outcome::Hits(a), Outcome::Hits(b)) => (
            a.iter()
                .zip(b)
                .filter(|(x, y)| {
                    x.is_hit() == y.is_hit()
                        && (!x.is_hit() || (x.instance, x.triangle) == (y.instance, y.triangle))
                })
                .count(),
            a.len(),
        ),
        (Outcome::Occluded(a), Outcome::Occluded(b)) => {
            (a.iter().zip(b).filter(|(x, y)| x == y).count(), a.len())
        }
        _ => (0, 1),
    };
    same as f64 / n.max(1) as f64
}

/// A tracer to compare against, built per thread count.
pub trait Reference: Tracer + Sized {
    /// Name used in tables and JSON keys.
    const NAME: &'static str;
    /// Build for `scene` with `threads` build threads; returns it and its build seconds.
    fn build(scene: &Scene, threads: usize) -> Result<(Self, f64), LabError>;
}

/// What a comparison traces and how often.
#[derive(Clone, Debug)]
pub struct CompareSettings {
    /// Workloads.
    pub kinds: Vec<RayKind>,
    /// Image size (width, height) of the primary rays.
    pub size: (usize, usize),
    /// Thread counts (0 = all cores).
    pub thread_counts: Vec<usize>,
    /// Timed runs per tracer; medians are reported.
    pub runs: usize,
    /// Builds per structure; the median build time is reported.
    pub builds: usize,
}

/// Compare rtmesh with `R` on `scene` for each workload kind and thread count: builds
/// `builds` times each (median), traces `runs` times each, alternating (medians).
pub fn compare<R: Reference>(
    mesh: &str,
    scene: &Scene,
    settings: &CompareSettings,
) -> Result<Vec<Comparison>, LabError> {
    let CompareSettings {
        kinds,
        size: (width, height),
        thread_counts,
        runs,
        builds,
    } = settings;
    let (width, height, runs, builds) = (*width, *height, *runs, *builds);
    let mut rows = Vec::new();
    for &threads in thread_counts {
        let result = with_threads(threads, || -> Result<Vec<Comparison>, LabError> {
            let settings = BuildSettings::default();
            let mut ours_build = Vec::new();
            let mut accel = SceneAccel::build(scene, &settings);
            ours_build.push(accel.build_seconds);
            for _ in 1..builds.max(1) {
                accel = SceneAccel::build(scene, &settings);
                ours_build.push(accel.build_seconds);
            }
            let mut other_build = Vec::new();
            let mut reference = None;
            for _ in 0..builds.max(1) {
                let (built, seconds) = R::build(scene, threads)?;
                other_build.push(seconds);
                reference = Some(built);
            }
            let reference = reference.expect("built at least once");
            let sah = accel.stats().sah_cost;
            let mut rows = Vec::new();
            for &kind in kinds {
                let workload = Workload::generate(kind, scene, &accel, width, height, 1);
                let (mut ours, mut theirs) = (Vec::new(), Vec::new());
                let mut same = 1.0;
                for run in 0..runs.max(1) {
                    let (a, outcome_a) = timed_run(&accel, &workload);
                    let (b, outcome_b) = timed_run(&reference, &workload);
                    if run == 0 {
                        same = same_share(&outcome_a, &outcome_b);
                    }
                    ours.push(a);
                    theirs.push(b);
                }
                let rays = workload.rays.len();
                let mrays = |s: f64| rays as f64 / s.max(1e-12) / 1e6;
                let (ours, theirs) = (mrays(median(&ours)), mrays(median(&theirs)));
                rows.push(Comparison {
                    mesh: mesh.to_owned(),
                    workload: kind.name().to_owned(),
                    rays,
                    threads: rayon::current_num_threads(),
                    other: R::NAME.to_owned(),
                    rtmesh_mrays_per_s: ours,
                    other_mrays_per_s: theirs,
                    ratio: ours / theirs.max(1e-12),
                    rtmesh_build_seconds: median(&ours_build),
                    other_build_seconds: median(&other_build),
                    same_hits: same,
                    rtmesh_sah_cost: sah,
                });
            }
            Ok(rows)
        })?;
        rows.extend(result);
    }
    Ok(rows)
}

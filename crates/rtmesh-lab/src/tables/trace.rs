//! `rtmesh bench trace`: rtmesh alone per thread count and workload, or side by side
//! with another tracer ([`crate::reference::compare`]).

use crate::reference::{CompareSettings, Comparison};
use crate::LabError;
use rtmesh::bvh::BuildSettings;
use rtmesh::trace::measure::{measure, median, with_threads};
use rtmesh::trace::{SceneAccel, TraceRun, Workload};
use rtmesh::Scene;
use serde::Serialize;

/// rtmesh's speed and work per ray on one mesh, workload and thread count.
#[derive(Clone, Debug, Serialize)]
pub struct TraceRow {
    /// Mesh name.
    pub mesh: String,
    /// Workload kind.
    pub workload: &'static str,
    /// Threads traced (and built) on.
    pub threads: usize,
    /// Median seconds of the builds.
    pub build_seconds: f64,
    /// The traced run.
    #[serde(flatten)]
    pub run: TraceRun,
}

/// rtmesh alone on `scene`: per thread count, `builds` builds (median) and each
/// workload traced `runs` times.
pub fn trace_rows(mesh: &str, scene: &Scene, settings: &CompareSettings) -> Vec<TraceRow> {
    let (width, height) = settings.size;
    let mut rows = Vec::new();
    for &threads in &settings.thread_counts {
        with_threads(threads, || {
            let build_times: Vec<f64> = (0..settings.builds.max(1))
                .map(|_| SceneAccel::build(scene, &BuildSettings::default()).build_seconds)
                .collect();
            let build_seconds = median(&build_times);
            let accel = SceneAccel::build(scene, &BuildSettings::default());
            for &kind in &settings.kinds {
                let work = Workload::generate(kind, scene, &accel, width, height, 1);
                rows.push(TraceRow {
                    mesh: mesh.to_owned(),
                    workload: kind.name(),
                    threads: rayon::current_num_threads(),
                    build_seconds,
                    run: measure(&accel, &work, settings.runs),
                });
            }
        });
    }
    rows
}

/// A tracer to compare rtmesh with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Other {
    /// Embree 3 (the `embree` feature).
    Embree,
    /// The obvhs crate (the `obvhs` feature).
    Obvhs,
}

impl Other {
    /// The name, as the cargo feature spells it.
    pub fn name(self) -> &'static str {
        match self {
            Other::Embree => "embree",
            Other::Obvhs => "obvhs",
        }
    }
}

/// rtmesh and `other` side by side on `scene`; an error when this build lacks
/// `other`'s feature.
#[cfg_attr(
    not(all(feature = "embree", feature = "obvhs")),
    allow(unused_variables)
)]
pub fn compare_with(
    other: Other,
    mesh: &str,
    scene: &Scene,
    settings: &CompareSettings,
) -> Result<Vec<Comparison>, LabError> {
    let missing = || LabError::MissingFeature {
        tracer: other.name(),
        mesh: format!("{mesh} ({} triangles)", scene.instanced_triangle_count()),
    };
    match other {
        #[cfg(feature = "embree")]
        Other::Embree => {
            crate::reference::compare::<crate::embree::EmbreeScene>(mesh, scene, settings)
        }
        #[cfg(feature = "obvhs")]
        Other::Obvhs => {
            crate::reference::compare::<crate::obvhs::ObvhsScene>(mesh, scene, settings)
        }
        #[allow(unreachable_patterns)]
        _ => Err(missing()),
    }
}

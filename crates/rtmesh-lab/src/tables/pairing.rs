//! `rtmesh bench pairing`: the pairing paper's table for rtmesh's tracer. Per mesh
//! (welded): each method's pairing time (median) and paired share, then the same rays
//! traced through triangle leaves and through each method's pair leaves in alternating
//! rounds, with differences against `window:2`.

use crate::harness::{alternate, median, same_triangle_share, seconds};
use rtmesh::bvh::BuildSettings;
use rtmesh::pair::{PairMethod, PairSettings, Pairing};
use rtmesh::progress::Progress;
use rtmesh::trace::measure::measure;
use rtmesh::trace::run::trace_closest;
use rtmesh::trace::{Hit, NoCounters, RayKind, SceneAccel, TraceRun, Workload};
use rtmesh::{Ray, Scene};
use serde::Serialize;

/// One method on one workload.
#[derive(Clone, Debug, Serialize)]
pub struct PairingRow {
    /// Mesh name.
    pub mesh: String,
    /// `unpaired` (triangle leaves) or the pairing method.
    pub method: String,
    /// Workload kind.
    pub workload: &'static str,
    /// Rays traced.
    pub rays: usize,
    /// Threads.
    pub threads: usize,
    /// Median seconds of the pairing.
    pub pair_seconds: f64,
    /// Share of triangles paired.
    pub pair_ratio: f64,
    /// Box tests per ray.
    pub box_tests_per_ray: f64,
    /// Triangle tests per ray.
    pub tri_tests_per_ray: f64,
    /// Pair tests per ray.
    pub pair_tests_per_ray: f64,
    /// Median Mrays/s.
    pub mrays_per_s: f64,
    /// Box tests against window:2, in percent.
    pub delta_box_percent: f64,
    /// Triangle plus pair tests against window:2, in percent.
    pub delta_tests_percent: f64,
    /// Mrays/s against window:2, in percent.
    pub delta_mrays_percent: f64,
    /// Share of rays that hit the same triangle as triangle leaves.
    pub same_hits: f64,
}

/// A structure to trace: triangle leaves or one method's pair leaves.
enum Leaves {
    Triangles(SceneAccel),
    Pairs(SceneAccel<rtmesh::trace::Pair4>),
}

impl Leaves {
    fn closest(&self, rays: &[Ray]) -> Vec<Hit> {
        match self {
            Leaves::Triangles(accel) => trace_closest::<NoCounters>(accel, rays).0,
            Leaves::Pairs(accel) => trace_closest::<NoCounters>(accel, rays).0,
        }
    }

    fn counted(&self, work: &Workload) -> TraceRun {
        match self {
            Leaves::Triangles(accel) => measure(accel, work, 1),
            Leaves::Pairs(accel) => measure(accel, work, 1),
        }
    }
}

/// One configuration: its label, pairing figures and structure.
struct Config {
    method: String,
    pair_seconds: f64,
    pair_ratio: f64,
    leaves: Leaves,
}

/// The table for `scene` (welded here): `window:2` and `methods`, each workload of
/// `kinds` at `size`, `runs` rounds.
pub fn pairing_rows(
    mesh: &str,
    scene: &Scene,
    methods: &[PairMethod],
    kinds: &[RayKind],
    (width, height): (usize, usize),
    runs: usize,
    progress: &dyn Progress,
) -> Vec<PairingRow> {
    let mut scene = scene.clone();
    for mesh in &mut scene.meshes {
        *mesh = mesh.topology();
    }
    let mut all_methods = vec![PairMethod::Window(2)];
    all_methods.extend(methods.iter().filter(|&&m| m != PairMethod::Window(2)));
    let rounds = runs.max(1);
    let configs_count = all_methods.len() + 1;
    progress.add_steps(
        (all_methods.len() * rounds + kinds.len() * configs_count * (rounds + 2)) as u64,
    );
    let triangles = SceneAccel::build(&scene, &BuildSettings::default());
    let mut configs = Vec::new();
    for &method in &all_methods {
        let settings = PairSettings {
            method,
            prescan_threshold: None,
            ..PairSettings::default()
        };
        progress.message(&format!("{mesh}: pairing {method}"));
        let mut pairings: Vec<Pairing> = Vec::new();
        let times: Vec<f64> = (0..rounds)
            .map(|_| {
                let time = seconds(|| {
                    pairings = scene
                        .meshes
                        .iter()
                        .map(|m| rtmesh::pair::pair(m, &settings).0)
                        .collect()
                });
                progress.advance(1);
                time
            })
            .collect();
        let paired: usize = pairings.iter().map(Pairing::paired_triangles).sum();
        configs.push(Config {
            method: method.to_string(),
            pair_seconds: median(&times),
            pair_ratio: paired as f64 / scene.instanced_triangle_count().max(1) as f64,
            leaves: Leaves::Pairs(SceneAccel::build_paired(
                &scene,
                &pairings,
                &BuildSettings::default(),
            )),
        });
    }
    configs.insert(
        0,
        Config {
            method: "unpaired".into(),
            pair_seconds: 0.0,
            pair_ratio: 0.0,
            leaves: Leaves::Triangles(triangles),
        },
    );
    let mut rows = Vec::new();
    for &kind in kinds {
        progress.message(&format!("{mesh}: tracing {} rays", kind.name()));
        let Leaves::Triangles(triangles) = &configs[0].leaves else {
            unreachable!("triangle leaves come first")
        };
        let work = Workload::generate(kind, &scene, triangles, width, height, 1);
        let reference = configs[0].leaves.closest(&work.rays);
        let times = alternate(rounds, &configs, |config| {
            let time = seconds(|| {
                std::hint::black_box(config.leaves.closest(&work.rays));
            });
            progress.advance(1);
            time
        });
        let results: Vec<(TraceRun, f64, f64)> = configs
            .iter()
            .zip(&times)
            .map(|(config, times)| {
                let hits = config.leaves.closest(&work.rays);
                let same = same_triangle_share(&hits, &reference);
                let counted = config.leaves.counted(&work);
                progress.advance(2);
                (counted, work.rays.len() as f64 / median(times) / 1e6, same)
            })
            .collect();
        let base = &results[1]; // window:2
        let tests = |r: &TraceRun| r.tri_tests_per_ray + r.pair_tests_per_ray;
        let delta = |x: f64, y: f64| 100.0 * (x / y.max(1e-12) - 1.0);
        for (config, (run, mrays, same)) in configs.iter().zip(&results) {
            rows.push(PairingRow {
                mesh: mesh.to_owned(),
                method: config.method.clone(),
                workload: kind.name(),
                rays: run.rays,
                threads: rayon::current_num_threads(),
                pair_seconds: config.pair_seconds,
                pair_ratio: config.pair_ratio,
                box_tests_per_ray: run.box_tests_per_ray,
                tri_tests_per_ray: run.tri_tests_per_ray,
                pair_tests_per_ray: run.pair_tests_per_ray,
                mrays_per_s: *mrays,
                delta_box_percent: delta(run.box_tests_per_ray, base.0.box_tests_per_ray),
                delta_tests_percent: delta(tests(run), tests(&base.0)),
                delta_mrays_percent: delta(*mrays, base.1),
                same_hits: *same,
            });
        }
    }
    rows
}

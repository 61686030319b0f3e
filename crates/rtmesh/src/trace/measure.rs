//! Measurement: a workload traced `runs` times with counters off (timed, medians) and
//! once with counters on (box, triangle and pair tests per ray), with a checksum of
//! which triangle each pixel hit so that two runs can be compared exactly.

use super::intersect::{Intersector, IntersectorKind, WithIntersector};
use super::run::{
    trace_closest, trace_closest_by, trace_each, trace_occluded, trace_packets_closest,
    trace_packets_occluded,
};
use super::workload::{RayKind, View, Workload};
use super::{Counters, Hit, NoCounters, RayCounters, SceneAccel, Tracer};
use crate::bvh::BuildSettings;
use crate::geom::Ray;
use crate::mesh::Scene;
use crate::progress::Progress;
use serde::Serialize;

/// Trace `workload` in packets (`starts` as from [`Workload::grouped`]) `runs` times
/// with counters off (timed) and once with counters on, with packet traversal and
/// intersector `I` (any hit for shadow rays, closest hit otherwise).
pub fn measure_packets<I: Intersector>(
    accel: &SceneAccel,
    workload: &Workload,
    starts: &[u32],
    runs: usize,
) -> TraceRun {
    let rays = &workload.rays;
    if workload.kind == RayKind::Shadow {
        return measure_occluded(
            rays,
            &workload.pixels,
            runs,
            || trace_packets_occluded::<I, NoCounters>(accel, rays, starts).0,
            || trace_packets_occluded::<I, RayCounters>(accel, rays, starts).1,
        );
    }
    measure_closest(
        rays,
        &workload.pixels,
        runs,
        || trace_packets_closest::<I, NoCounters>(accel, rays, starts).0,
        || trace_packets_closest::<I, RayCounters>(accel, rays, starts).1,
    )
}

/// Trace `workload` one ray at a time with intersector `I` in the leaves, `runs` times
/// with counters off (timed) and once with counters on.
pub fn measure_by<I: Intersector>(
    accel: &SceneAccel,
    workload: &Workload,
    runs: usize,
) -> TraceRun {
    let rays = &workload.rays;
    if workload.kind == RayKind::Shadow {
        return measure_occluded(
            rays,
            &workload.pixels,
            runs,
            || {
                trace_each(rays, false, |r, c: &mut NoCounters| {
                    accel.occluded_by::<I, _>(r, c)
                })
                .0
            },
            || {
                trace_each(rays, false, |r, c: &mut RayCounters| {
                    accel.occluded_by::<I, _>(r, c)
                })
                .1
            },
        );
    }
    measure_closest(
        rays,
        &workload.pixels,
        runs,
        || trace_closest_by::<I, NoCounters>(accel, rays).0,
        || trace_closest_by::<I, RayCounters>(accel, rays).1,
    )
}

/// Run `timed` `runs` times (at least once): the seconds of every run and the last
/// run's result.
fn timed_runs<R>(runs: usize, timed: impl Fn() -> R) -> (Vec<f64>, R) {
    let mut all_seconds = Vec::with_capacity(runs.max(1));
    let mut last = None;
    for _ in 0..runs.max(1) {
        let start = std::time::Instant::now();
        last = Some(timed());
        all_seconds.push(start.elapsed().as_secs_f64());
    }
    (all_seconds, last.expect("at least one run"))
}

/// Time `timed` `runs` times, then count once with `counted`.
fn measure_closest(
    rays: &[Ray],
    pixels: &[u32],
    runs: usize,
    timed: impl Fn() -> Vec<Hit>,
    counted: impl Fn() -> Vec<RayCounters>,
) -> TraceRun {
    let (all_seconds, hits) = timed_runs(runs, timed);
    let found = hits.iter().filter(|h| h.is_hit()).count();
    summarize(
        rays,
        all_seconds,
        found,
        hit_checksum(&hits, pixels),
        &counted(),
    )
}

/// Time `timed` (occlusion) `runs` times, then count once with `counted`.
fn measure_occluded(
    rays: &[Ray],
    pixels: &[u32],
    runs: usize,
    timed: impl Fn() -> Vec<bool>,
    counted: impl Fn() -> Vec<RayCounters>,
) -> TraceRun {
    let (all_seconds, occluded) = timed_runs(runs, timed);
    let blocked = occluded.iter().filter(|&&o| o).count();
    let checksum = occlusion_checksum(&occluded, pixels);
    summarize(rays, all_seconds, blocked, checksum, &counted())
}

/// A [`TraceRun`] from timings, the hit count and checksum, and per-ray counters.
fn summarize(
    rays: &[Ray],
    all_seconds: Vec<f64>,
    hits: usize,
    hit_checksum: u64,
    counters: &[RayCounters],
) -> TraceRun {
    let mut total = RayCounters::default();
    counters.iter().for_each(|c| total.merge(c));
    let n = rays.len().max(1) as f64;
    let seconds = median(&all_seconds);
    TraceRun {
        rays: rays.len(),
        seconds,
        mrays_per_s: rays.len() as f64 / seconds.max(1e-12) / 1e6,
        box_tests_per_ray: total.box_tests as f64 / n,
        tri_tests_per_ray: total.triangle_tests as f64 / n,
        pair_tests_per_ray: total.pair_tests as f64 / n,
        nodes_per_ray: total.nodes_visited as f64 / n,
        hits,
        hit_checksum,
        all_seconds,
    }
}

fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Checksum of which input triangle each pixel's ray hit (`pixels[i]` is ray `i`'s
/// pixel): equal for two tracers, leaf types or ray orders (tiles or packets) exactly
/// when they hit the same (instance, triangle) per pixel.
pub fn hit_checksum(hits: &[Hit], pixels: &[u32]) -> u64 {
    hits.iter()
        .zip(pixels)
        .filter(|(h, _)| h.is_hit())
        .fold(0u64, |sum, (h, &p)| {
            sum.wrapping_add(mix((p as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
                ^ ((h.instance as u64) << 32 | h.triangle as u64)))
        })
}

/// Checksum of which pixels' rays are occluded.
pub fn occlusion_checksum(occluded: &[bool], pixels: &[u32]) -> u64 {
    occluded
        .iter()
        .zip(pixels)
        .filter(|(&o, _)| o)
        .fold(0u64, |sum, (_, &p)| {
            sum.wrapping_add(mix((p as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5))
        })
}

/// The result of tracing a workload once, timed, and once more, counted.
#[derive(Clone, Debug, Serialize)]
pub struct TraceRun {
    /// Rays traced.
    pub rays: usize,
    /// Median wall-clock seconds of the timed runs (counters off).
    pub seconds: f64,
    /// Millions of rays per second at the median.
    pub mrays_per_s: f64,
    /// Mean box tests per ray (from the counted run).
    pub box_tests_per_ray: f64,
    /// Mean triangle tests per ray.
    pub tri_tests_per_ray: f64,
    /// Mean pair tests per ray (pair leaves: one test covers two triangles).
    pub pair_tests_per_ray: f64,
    /// Mean inner nodes visited per ray.
    pub nodes_per_ray: f64,
    /// Rays that hit (or are occluded).
    pub hits: usize,
    /// [`hit_checksum`] or [`occlusion_checksum`].
    pub hit_checksum: u64,
    /// Seconds of every timed run.
    pub all_seconds: Vec<f64>,
}

/// Median of a non-empty list.
pub fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return 0.0;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Trace `workload` `runs` times with counters off (timed) and once with counters on,
/// on the current rayon pool.
pub fn measure(tracer: &impl Tracer, workload: &Workload, runs: usize) -> TraceRun {
    let rays = &workload.rays;
    if workload.kind == RayKind::Shadow {
        return measure_occluded(
            rays,
            &workload.pixels,
            runs,
            || trace_occluded::<NoCounters>(tracer, rays).0,
            || trace_occluded::<RayCounters>(tracer, rays).1,
        );
    }
    measure_closest(
        rays,
        &workload.pixels,
        runs,
        || trace_closest::<NoCounters>(tracer, rays).0,
        || trace_closest::<RayCounters>(tracer, rays).1,
    )
}

/// Run `f` on a rayon pool of `threads` threads (0 = all cores).
pub fn with_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
        .install(f)
}

/// [`measure_packets`] with the intersector named by `kind`.
pub fn measure_packets_by_kind(
    kind: IntersectorKind,
    accel: &SceneAccel,
    workload: &Workload,
    starts: &[u32],
    runs: usize,
) -> TraceRun {
    struct Packets<'a>(&'a SceneAccel, &'a Workload, &'a [u32], usize);
    impl WithIntersector for Packets<'_> {
        type Output = TraceRun;
        fn run<I: Intersector>(self) -> TraceRun {
            measure_packets::<I>(self.0, self.1, self.2, self.3)
        }
    }
    kind.dispatch(Packets(accel, workload, starts, runs))
}

/// [`measure_by`] with the intersector named by `kind`.
pub fn measure_by_kind(
    kind: IntersectorKind,
    accel: &SceneAccel,
    workload: &Workload,
    runs: usize,
) -> TraceRun {
    struct Single<'a>(&'a SceneAccel, &'a Workload, usize);
    impl WithIntersector for Single<'_> {
        type Output = TraceRun;
        fn run<I: Intersector>(self) -> TraceRun {
            measure_by::<I>(self.0, self.1, self.2)
        }
    }
    kind.dispatch(Single(accel, workload, runs))
}

/// One workload traced through a scene before and after a change.
#[derive(Clone, Debug, Serialize)]
pub struct BeforeAfter {
    /// Workload kind.
    pub workload: &'static str,
    /// Image width traced (below the asked one when the time budget said so).
    pub width: usize,
    /// Image height traced.
    pub height: usize,
    /// Rays traced.
    pub rays: usize,
    /// Box tests per ray before.
    pub box_before: f64,
    /// Box tests per ray after.
    pub box_after: f64,
    /// Triangle tests per ray before.
    pub tri_before: f64,
    /// Triangle tests per ray after.
    pub tri_after: f64,
    /// Pair tests per ray before (pair leaves: one test covers two triangles).
    pub pair_before: f64,
    /// Pair tests per ray after.
    pub pair_after: f64,
    /// Median Mrays/s before.
    pub mrays_before: f64,
    /// Median Mrays/s after.
    pub mrays_after: f64,
}

/// Seconds that [`before_after`] aims to spend tracing, all rounds of both scenes and
/// both workloads together. A scene whose rays cost little (any real mesh at 512²)
/// stays far below it; one that costs much (a million copies of one triangle, a book of
/// 100,000 pages on one edge) is traced with fewer rays instead of for minutes.
pub const MEASURE_BUDGET_SECONDS: f64 = 2.0;

/// Least seconds a measured round spends on each tracer.
const MIN_ROUND_SECONDS: f64 = 0.01;

/// The image size, at most `width` × `height` and of the same aspect, whose rays of
/// `kind` through `before` and `after` fit `seconds` over `traces` traces of each. The
/// cost per pixel comes from pilots that start 16 pixels wide and double their width
/// while a pilot takes under 20 ms (a tiny pilot measures the thread pool's start more
/// than the rays).
fn budgeted_size(
    view: View,
    kind: RayKind,
    scenes: (&Scene, &impl Tracer, &impl Tracer),
    (width, height): (usize, usize),
    traces: usize,
    seconds: f64,
) -> (usize, usize) {
    let (before, accel_before, accel_after) = scenes;
    let mut pilot_width = width.min(16);
    let per_pixel = loop {
        let pilot_height = (height * pilot_width / width).max(1);
        let pilot = Workload::generate_from(
            view,
            kind,
            before,
            accel_before,
            (pilot_width, pilot_height),
            1,
        );
        let start = std::time::Instant::now();
        std::hint::black_box(trace_closest::<NoCounters>(accel_before, &pilot.rays));
        std::hint::black_box(trace_closest::<NoCounters>(accel_after, &pilot.rays));
        let spent = start.elapsed().as_secs_f64();
        if spent >= 0.02 || pilot_width == width {
            break spent / (pilot_width * pilot_height) as f64;
        }
        pilot_width = (2 * pilot_width).min(width);
    };
    let planned = per_pixel * (width * height) as f64 * traces as f64;
    if planned <= seconds {
        return (width, height);
    }
    let scale = (seconds / planned).sqrt();
    let side = |n: usize| ((n as f64 * scale) as usize).clamp(1, n);
    (side(width), side(height))
}

/// Trace the same primary and diffuse rays (generated on `before`) through `before`
/// and `after` at `width` × `height`, alternating `runs` rounds: medians and counts
/// per ray. Where that would take more than [`MEASURE_BUDGET_SECONDS`], fewer rays
/// are traced (the image shrinks, its aspect kept; each row says its size). Reports its
/// steps (the builds, then each round of each workload).
pub fn before_after(
    before: &Scene,
    after: &Scene,
    size: (usize, usize),
    runs: usize,
    progress: &dyn Progress,
) -> Vec<BeforeAfter> {
    const WORKLOADS: [RayKind; 2] = [RayKind::Primary, RayKind::Diffuse];
    progress.add_steps(1);
    progress.message("building the BVHs before and after");
    let accel_before = SceneAccel::build(before, &BuildSettings::default());
    let accel_after = SceneAccel::build(after, &BuildSettings::default());
    progress.advance(1);
    let traced = Traced {
        scene: before,
        before: &accel_before,
        after: &accel_after,
        view: View::Iso,
    };
    traced.compare(&WORKLOADS, size, runs, progress)
}

/// A scene traced through two tracers (its own, and a changed one that holds the same
/// surfaces), from one view.
pub struct Traced<'a, A, B> {
    /// The scene the rays are generated on (through `before`).
    pub scene: &'a Scene,
    /// The tracer before the change.
    pub before: &'a A,
    /// The tracer after it.
    pub after: &'a B,
    /// Where the camera stands.
    pub view: View,
}

impl<A: Tracer, B: Tracer> Traced<'_, A, B> {
    /// The rays of `kinds` at `size` (or fewer, within [`MEASURE_BUDGET_SECONDS`]),
    /// through both tracers in `runs` alternating rounds: medians and counts per ray.
    pub fn compare(
        &self,
        kinds: &[RayKind],
        size: (usize, usize),
        runs: usize,
        progress: &dyn Progress,
    ) -> Vec<BeforeAfter> {
        progress.add_steps((kinds.len() * runs.max(1)) as u64);
        // Each round traces each scene twice, timed then counted; the secondary rays are
        // generated from primary rays at their own size, so the primary budget bounds
        // both.
        let traces = 2 * runs.max(1);
        let share = MEASURE_BUDGET_SECONDS / kinds.len().max(1) as f64;
        let scenes = (self.scene, self.before, self.after);
        let primary_size =
            budgeted_size(self.view, RayKind::Primary, scenes, size, traces + 1, share);
        kinds
            .iter()
            .map(|&kind| {
                progress.message(&format!("tracing {} rays before and after", kind.name()));
                let (width, height) = match kind {
                    RayKind::Primary => primary_size,
                    _ => {
                        let own =
                            budgeted_size(self.view, kind, scenes, primary_size, traces, share);
                        (own.0.min(primary_size.0), own.1.min(primary_size.1))
                    }
                };
                let work = Workload::generate_from(
                    self.view,
                    kind,
                    self.scene,
                    self.before,
                    (width, height),
                    1,
                );
                // A round times each tracer over at least ~10 ms (the median of as many
                // traces as that takes), so that workloads of a millisecond measure
                // the rays rather than the scheduler.
                let once = measure(self.before, &work, 1).seconds;
                let repeats = ((MIN_ROUND_SECONDS / once.max(1e-6)).ceil() as usize).clamp(1, 64);
                let (mut a, mut b) = (Vec::new(), Vec::new());
                for _ in 0..runs.max(1) {
                    a.push(measure(self.before, &work, repeats));
                    b.push(measure(self.after, &work, repeats));
                    progress.advance(1);
                }
                let median_of =
                    |runs: &[TraceRun]| median(&runs.iter().map(|r| r.seconds).collect::<Vec<_>>());
                let rays = work.rays.len();
                BeforeAfter {
                    workload: kind.name(),
                    width,
                    height,
                    rays,
                    box_before: a[0].box_tests_per_ray,
                    box_after: b[0].box_tests_per_ray,
                    tri_before: a[0].tri_tests_per_ray,
                    tri_after: b[0].tri_tests_per_ray,
                    pair_before: a[0].pair_tests_per_ray,
                    pair_after: b[0].pair_tests_per_ray,
                    mrays_before: rays as f64 / median_of(&a) / 1e6,
                    mrays_after: rays as f64 / median_of(&b) / 1e6,
                }
            })
            .collect()
    }
}

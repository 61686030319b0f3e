//! Deterministic ray workloads, as DESIGN.md defines them, and the runners that trace
//! them on all threads of the current rayon pool.
//!
//! - Camera: looks at the bounds' centre from the (1, 1, 1) diagonal direction, at 1.2 ×
//!   the bounds' diagonal, 45° vertical field of view, +Y up.
//! - `primary`: one ray per pixel centre, in 8×8 tiles (tile-major order: coherent
//!   rays run together and threads take whole tiles).
//! - `diffuse`: from each primary hit, one cosine-weighted bounce about the geometric
//!   normal (turned to face the camera), seeded per pixel.
//! - `shadow`: from each primary hit, an occlusion ray toward a point light at
//!   `centre + diagonal · (0.3, 1.0, 0.5)`, stopping just short of it.
//!
//! Secondary rays start `1e-4 ·` diagonal off the surface. Pixels whose primary ray
//! misses have no secondary ray.

use super::intersect::Intersector;
use super::packet::PacketBuffer;
use super::{Counters, Hit, NoCounters, RayCounters, SceneAccel, Tracer};
use crate::geom::{Aabb, Ray};
use crate::mesh::Scene;
use crate::random::SplitMix64;
use glam::Vec3;
use rayon::prelude::*;
use std::str::FromStr;

/// Side of the square pixel tiles rays are generated and traced in.
pub const TILE: usize = 8;
/// Rays per parallel work item (one tile).
const CHUNK: usize = TILE * TILE;

/// Which rays to trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    /// Camera rays, closest hit.
    Primary,
    /// One diffuse bounce per primary hit, closest hit.
    Diffuse,
    /// Occlusion toward a point light per primary hit, any hit.
    Shadow,
}

impl RayKind {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Diffuse => "diffuse",
            RayKind::Shadow => "shadow",
        }
    }
}

impl FromStr for RayKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "primary" => Ok(Self::Primary),
            "diffuse" => Ok(Self::Diffuse),
            "shadow" => Ok(Self::Shadow),
            _ => Err(format!("unknown ray kind '{s}' (primary, diffuse, shadow)")),
        }
    }
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Unit right vector scaled by tan(fov/2)·aspect.
    pub right: Vec3,
    /// Unit up vector scaled by tan(fov/2).
    pub up: Vec3,
}

impl Camera {
    /// The default camera for `bounds` and an image of `width` × `height`.
    pub fn default_for(bounds: &Aabb, width: usize, height: usize) -> Self {
        let center = if bounds.is_empty() {
            Vec3::ZERO
        } else {
            bounds.center()
        };
        let distance = 1.2 * bounds.diagonal_length().max(1e-6);
        Self::look_at(
            center + Vec3::ONE.normalize() * distance,
            center,
            45.0,
            width,
            height,
        )
    }

    /// A camera at `eye` looking at `target`, `fov_degrees` vertical field of view.
    pub fn look_at(eye: Vec3, target: Vec3, fov_degrees: f32, width: usize, height: usize) -> Self {
        let forward = (target - eye).normalize();
        let right = forward.cross(Vec3::Y).normalize();
        let up = right.cross(forward);
        let tan = (fov_degrees.to_radians() * 0.5).tan();
        let aspect = width as f32 / height.max(1) as f32;
        Self {
            eye,
            forward,
            right: right * tan * aspect,
            up: up * tan,
        }
    }

    /// The ray through pixel `(x, y)` (row 0 at the top) of a `width` × `height` image.
    pub fn ray(&self, x: usize, y: usize, width: usize, height: usize) -> Ray {
        let sx = 2.0 * (x as f32 + 0.5) / width as f32 - 1.0;
        let sy = 1.0 - 2.0 * (y as f32 + 0.5) / height as f32;
        Ray::new(
            self.eye,
            (self.forward + self.right * sx + self.up * sy).normalize(),
        )
    }
}

/// Rays to trace, with the pixel each belongs to.
#[derive(Clone, Debug)]
pub struct Workload {
    /// Which rays these are.
    pub kind: RayKind,
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// The rays, in tile order.
    pub rays: Vec<Ray>,
    /// `pixels[i]` = `y · width + x` of ray `i`.
    pub pixels: Vec<u32>,
}

/// Pixel indices of a `width` × `height` image in 8×8 tile order.
fn tile_order(width: usize, height: usize) -> Vec<u32> {
    let mut pixels = Vec::with_capacity(width * height);
    for ty in (0..height).step_by(TILE) {
        for tx in (0..width).step_by(TILE) {
            for y in ty..(ty + TILE).min(height) {
                for x in tx..(tx + TILE).min(width) {
                    pixels.push((y * width + x) as u32);
                }
            }
        }
    }
    pixels
}

impl Workload {
    /// Camera rays for every pixel.
    pub fn primary(camera: &Camera, width: usize, height: usize) -> Self {
        let pixels = tile_order(width, height);
        let rays = pixels
            .iter()
            .map(|&p| camera.ray(p as usize % width, p as usize / width, width, height))
            .collect();
        Self {
            kind: RayKind::Primary,
            width,
            height,
            rays,
            pixels,
        }
    }

    /// Camera rays grouped into packets of `side` × `side` neighbouring pixels (see
    /// [`Self::grouped`]).
    pub fn primary_packets(
        camera: &Camera,
        width: usize,
        height: usize,
        side: usize,
    ) -> (Self, Vec<u32>) {
        Self::primary(camera, width, height).grouped(side)
    }

    /// The same rays grouped into packets by `side` × `side` blocks of pixels (smaller
    /// at the right and bottom edges when `side` does not divide the image; pixels
    /// without a ray leave packets short), blocks row-major, rays row-major inside.
    /// Returns the reordered workload and the packet boundaries: packet `k` is
    /// `rays[starts[k]..starts[k + 1]]`.
    pub fn grouped(&self, side: usize) -> (Self, Vec<u32>) {
        let side = side.max(1);
        let blocks_across = self.width.div_ceil(side);
        let block = |pixel: u32| {
            let (x, y) = (pixel as usize % self.width, pixel as usize / self.width);
            (y / side) * blocks_across + x / side
        };
        let mut order: Vec<u32> = (0..self.rays.len() as u32).collect();
        order.sort_unstable_by_key(|&i| (block(self.pixels[i as usize]), self.pixels[i as usize]));
        let mut starts = vec![0u32];
        for k in 1..order.len() {
            if block(self.pixels[order[k] as usize]) != block(self.pixels[order[k - 1] as usize]) {
                starts.push(k as u32);
            }
        }
        starts.push(order.len() as u32);
        if order.is_empty() {
            starts.truncate(1);
        }
        let grouped = Self {
            kind: self.kind,
            width: self.width,
            height: self.height,
            rays: order.iter().map(|&i| self.rays[i as usize]).collect(),
            pixels: order.iter().map(|&i| self.pixels[i as usize]).collect(),
        };
        (grouped, starts)
    }

    /// The workload of `kind` for `scene` seen by the default camera (secondary rays
    /// start from primary hits found with `accel`).
    pub fn generate(
        kind: RayKind,
        scene: &Scene,
        accel: &impl Tracer,
        width: usize,
        height: usize,
        seed: u64,
    ) -> Self {
        let bounds = scene.bounds();
        let primary = Self::primary(&Camera::default_for(&bounds, width, height), width, height);
        if kind == RayKind::Primary {
            return primary;
        }
        let hits = trace_closest::<NoCounters>(accel, &primary.rays).0;
        let diagonal = bounds.diagonal_length();
        let offset = 1e-4 * diagonal;
        let light = bounds.center() + diagonal * Vec3::new(0.3, 1.0, 0.5);
        let secondary: Vec<(Ray, u32)> = (0..hits.len())
            .into_par_iter()
            .filter(|&i| hits[i].is_hit())
            .map(|i| {
                let (ray, hit) = (&primary.rays[i], &hits[i]);
                let normal = geometric_normal(scene, hit);
                let normal = if normal.dot(ray.direction) > 0.0 {
                    -normal
                } else {
                    normal
                };
                let origin = ray.at(hit.t) + normal * offset;
                let pixel = primary.pixels[i];
                let ray = match kind {
                    RayKind::Shadow => Ray {
                        origin,
                        direction: light - origin,
                        t_min: 0.0,
                        t_max: 1.0 - 1e-4,
                    },
                    _ => {
                        let mut rng = SplitMix64::new(
                            seed ^ (pixel as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
                        );
                        Ray::new(
                            origin,
                            cosine_direction(normal, rng.next_f32(), rng.next_f32()),
                        )
                    }
                };
                (ray, pixel)
            })
            .collect();
        let (rays, pixels) = secondary.into_iter().unzip();
        Self {
            kind,
            width,
            height,
            rays,
            pixels,
        }
    }
}

/// Unit geometric normal of the hit triangle in world space.
pub fn geometric_normal(scene: &Scene, hit: &Hit) -> Vec3 {
    let instance = &scene.instances[hit.instance as usize];
    let [a, b, c] = scene.meshes[instance.mesh]
        .corners(hit.triangle as usize)
        .map(|p| instance.transform.transform_point3(p));
    (b - a).cross(c - a).normalize_or(Vec3::Y)
}

/// A cosine-weighted direction about the unit `normal` from two uniform numbers.
fn cosine_direction(normal: Vec3, r1: f32, r2: f32) -> Vec3 {
    let (tangent, bitangent) = normal.any_orthonormal_pair();
    let phi = std::f32::consts::TAU * r1;
    let radius = r2.sqrt();
    (tangent * (radius * phi.cos())
        + bitangent * (radius * phi.sin())
        + normal * (1.0 - r2).max(0.0).sqrt())
    .normalize()
}

/// Run `trace` on every ray on the current rayon pool, a tile (64 rays) per work item;
/// returns the outcomes and per-ray counters (zero-sized and free for [`NoCounters`]).
fn trace_each<C: Counters + Copy, R: Copy + Send>(
    rays: &[Ray],
    nothing: R,
    trace: impl Fn(&Ray, &mut C) -> R + Sync,
) -> (Vec<R>, Vec<C>) {
    let mut outcomes = vec![nothing; rays.len()];
    let mut counters = vec![C::default(); rays.len()];
    rays.par_chunks(CHUNK)
        .zip(outcomes.par_chunks_mut(CHUNK))
        .zip(counters.par_chunks_mut(CHUNK))
        .for_each(|((rays, outcomes), counters)| {
            for ((ray, outcome), counter) in rays.iter().zip(outcomes).zip(counters) {
                *outcome = trace(ray, counter);
            }
        });
    (outcomes, counters)
}

/// Closest hits of `rays` on the current rayon pool, with per-ray counters.
pub fn trace_closest<C: Counters + Copy>(tracer: &impl Tracer, rays: &[Ray]) -> (Vec<Hit>, Vec<C>) {
    trace_each(rays, Hit::MISS, |ray, counters| {
        tracer.intersect(ray, counters)
    })
}

/// Occlusion of `rays` on the current rayon pool, with per-ray counters.
pub fn trace_occluded<C: Counters + Copy>(
    tracer: &impl Tracer,
    rays: &[Ray],
) -> (Vec<bool>, Vec<C>) {
    trace_each(rays, false, |ray, counters| tracer.occluded(ray, counters))
}

/// One parallel work item of packets: its rays, the packet sizes, and the per-ray
/// outputs and counters.
type PacketItem<'a, R, C> = (&'a [Ray], Vec<usize>, &'a mut [R], &'a mut [C]);

/// Split `rays` and per-ray outputs into work items of whole packets (`starts` as
/// from [`Workload::primary_packets`]), about 64 rays each.
fn packet_items<'a, R, C>(
    rays: &'a [Ray],
    starts: &[u32],
    mut outcomes: &'a mut [R],
    mut counters: &'a mut [C],
) -> Vec<PacketItem<'a, R, C>> {
    let mut items = Vec::new();
    let mut k = 0;
    while k + 1 < starts.len() {
        let begin = starts[k] as usize;
        let mut sizes = Vec::new();
        while k + 1 < starts.len() && (sizes.is_empty() || starts[k] as usize - begin < CHUNK) {
            sizes.push((starts[k + 1] - starts[k]) as usize);
            k += 1;
        }
        let end = starts[k] as usize;
        let (head, tail) = std::mem::take(&mut outcomes).split_at_mut(end - begin);
        outcomes = tail;
        let (counted, rest) = std::mem::take(&mut counters).split_at_mut(end - begin);
        counters = rest;
        items.push((&rays[begin..end], sizes, head, counted));
    }
    items
}

/// Run `trace(buffer, rays, outcomes, counters)` on every packet (`starts` as from
/// [`Workload::grouped`]) on the current rayon pool, one packet buffer per work item.
fn trace_packets<R: Copy + Send, C: Counters + Copy>(
    rays: &[Ray],
    starts: &[u32],
    nothing: R,
    trace: impl Fn(&mut PacketBuffer, &[Ray], &mut [R], &mut [C]) + Sync,
) -> (Vec<R>, Vec<C>) {
    let mut outcomes = vec![nothing; rays.len()];
    let mut counters = vec![C::default(); rays.len()];
    packet_items(rays, starts, &mut outcomes, &mut counters)
        .into_par_iter()
        .for_each_init(
            PacketBuffer::default,
            |buffer, (rays, sizes, outcomes, counters)| {
                let mut at = 0;
                for size in sizes {
                    let range = at..at + size;
                    trace(
                        buffer,
                        &rays[range.clone()],
                        &mut outcomes[range.clone()],
                        &mut counters[range],
                    );
                    at += size;
                }
            },
        );
    (outcomes, counters)
}

/// Closest hits of packets of rays (`starts` as from [`Workload::grouped`]) with
/// packet traversal and intersector `I`, on the current rayon pool, with per-ray
/// counters.
pub fn trace_packets_closest<I: Intersector, C: Counters + Copy>(
    accel: &SceneAccel,
    rays: &[Ray],
    starts: &[u32],
) -> (Vec<Hit>, Vec<C>) {
    trace_packets(rays, starts, Hit::MISS, |buffer, rays, hits, counters| {
        accel.intersect_packet::<I, C>(buffer, rays, hits, counters)
    })
}

/// Occlusion of packets of rays (`starts` as from [`Workload::grouped`]) with packet
/// traversal and intersector `I`, on the current rayon pool, with per-ray counters.
pub fn trace_packets_occluded<I: Intersector, C: Counters + Copy>(
    accel: &SceneAccel,
    rays: &[Ray],
    starts: &[u32],
) -> (Vec<bool>, Vec<C>) {
    trace_packets(rays, starts, false, |buffer, rays, occluded, counters| {
        accel.occluded_packet::<I, C>(buffer, rays, occluded, counters)
    })
}

/// Closest hits of `rays` one at a time with intersector `I`, on the current rayon
/// pool, with per-ray counters (the reference for [`trace_packets_closest`]).
pub fn trace_closest_by<I: Intersector, C: Counters + Copy>(
    accel: &SceneAccel,
    rays: &[Ray],
) -> (Vec<Hit>, Vec<C>) {
    trace_each(rays, Hit::MISS, |ray, counters| {
        accel.intersect_by::<I, C>(ray, counters)
    })
}

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
#[derive(Clone, Debug, serde::Serialize)]
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

//! Lint's probe rays: 128² rays from the default camera, every crossing found by an
//! any-hit traversal that never stops, through the TLAS to every placement a ray meets.
//! From the crossings: stacked alpha-tested layers, and *stacks* (three or more
//! parallel triangles that a ray crosses at one depth: copies, z-fighting layers,
//! folds). Cost: one BVH build and O(crossings) per ray.

use super::{Finding, LintSettings, Severity};
use crate::mesh::Scene;
use rayon::prelude::*;

#[cfg(test)]
mod tests;

/// A triangle that a probe ray crosses.
#[derive(Clone, Copy, Debug)]
pub(super) struct Crossing {
    /// Distance along the ray.
    t: f32,
    /// The triangle's geometry.
    geometry: u32,
    /// The triangle, within its geometry.
    triangle: u32,
    /// Whether the triangle is alpha-tested.
    alpha: bool,
    /// Unit normal, in world space.
    normal: glam::Vec3,
    /// Whether the ray crosses it away from its edges (every barycentric coordinate at
    /// least [`EDGE_MARGIN`]): a ray through an edge or corner crosses its neighbours at
    /// the same depth, which is no stack.
    interior: bool,
}

/// Barycentric margin of an interior crossing.
const EDGE_MARGIN: f32 = 1e-3;

/// The most crossings a probe ray collects: past them it stops, so that a stack of a
/// million copies costs a probe ray about this many triangle tests, not a million
/// (counts of layers then read "at least").
pub(super) const MAX_CROSSINGS: usize = 1024;

/// The most triangle tests a probe ray makes, crossings or not: rays through the boxes
/// of a million copies that miss them stop here too. Probes of real meshes never come
/// near it (a few hundred tests at most).
pub(super) const MAX_TESTS: usize = 1 << 14;

/// Every triangle that each of `width` × `height` primary rays from the default camera
/// crosses (up to [`MAX_CROSSINGS`], in at most [`MAX_TESTS`] triangle tests), reduced
/// by `per_ray`. The crossings come from an any-hit traversal that stops only at a cap,
/// through the TLAS to every placement whose box the ray meets.
pub(super) fn probe_crossings<R: Send>(
    scene: &Scene,
    width: usize,
    height: usize,
    per_ray: impl Fn(&mut Vec<Crossing>) -> R + Sync,
) -> Vec<R> {
    use crate::bvh::BuildSettings;
    use crate::simd::Portable;
    use crate::trace::traverse::any_hit;
    use crate::trace::{transform_query, Camera, NoCounters, RayQuery, SceneAccel, Workload};
    // Any tree finds the same crossings: the fast build.
    let accel = SceneAccel::build(scene, &BuildSettings::fast());
    let camera = Camera::default_for(&scene.bounds(), width, height);
    let work = Workload::primary(&camera, width, height);
    work.rays
        .par_iter()
        .map(|ray| {
            let query = RayQuery::new(ray);
            let mut crossed = Vec::new();
            let mut tests = 0usize;
            // The crossings with placement `instance`, whose inverse is `to_object`.
            let mut cross = |instance: usize, to_object: &glam::Affine3A| -> bool {
                let placement = &scene.instances[instance];
                let local = transform_query(&query, to_object);
                let alpha = &scene.meshes[placement.mesh].alpha_tested;
                any_hit::<Portable, _, _, _>(
                    &accel.blas[placement.mesh],
                    &local,
                    ray.t_max,
                    &mut NoCounters,
                    |blocks, t_max, _| {
                        for block in blocks {
                            tests += block.count() as usize;
                            for lane in 0..block.count() as usize {
                                let triangle = block.triangle(lane);
                                if let Some((t, u, v)) = triangle.intersect(&local, t_max) {
                                    // The world's edges' cross product: right under
                                    // any affine placement, shears and uneven scales
                                    // included.
                                    let world = |e| placement.transform.transform_vector3(e);
                                    let normal = world(triangle.e1).cross(world(triangle.e2));
                                    crossed.push(Crossing {
                                        t,
                                        geometry: placement.mesh as u32,
                                        triangle: triangle.id,
                                        alpha: alpha.get(triangle.id as usize) == Some(&true),
                                        normal: normal.normalize_or_zero(),
                                        interior: u.min(v).min(1.0 - u - v) >= EDGE_MARGIN,
                                    });
                                }
                            }
                        }
                        crossed.len() >= MAX_CROSSINGS || tests >= MAX_TESTS
                    },
                )
            };
            match &accel.tlas {
                // One untransformed placement.
                None => {
                    cross(0, &glam::Affine3A::IDENTITY);
                }
                Some(tlas) => {
                    any_hit::<Portable, _, _, _>(
                        tlas,
                        &query,
                        ray.t_max,
                        &mut NoCounters,
                        |leaves, _, _| {
                            leaves
                                .iter()
                                .any(|leaf| cross(leaf.instance as usize, &leaf.world_to_object))
                        },
                    );
                }
            }
            per_ray(&mut crossed)
        })
        .collect()
}

/// Alpha-tested layers along `width` × `height` primary rays from the default
/// camera: per ray, how many alpha-tested triangles it crosses before its first opaque
/// hit, each an any-hit shader call (alpha test) a tracer would run.
pub fn alpha_layers(scene: &Scene, width: usize, height: usize) -> Vec<u32> {
    probe_crossings(scene, width, height, |crossed| alpha_layers_of(crossed))
}

/// How many alpha-tested triangles come before the first opaque one in `crossed`.
pub(super) fn alpha_layers_of(crossed: &[Crossing]) -> u32 {
    let opaque = crossed
        .iter()
        .filter(|c| !c.alpha)
        .fold(f32::INFINITY, |t, c| t.min(c.t));
    crossed.iter().filter(|c| c.alpha && c.t < opaque).count() as u32
}

/// Triangles whose planes make an angle of at most this (its cosine, 26°) with a
/// stack's first triangle join it: layers are parallel (facing the same way, or
/// opposite in a fold), where the bumps of a surface that a grazing ray crosses
/// several times are not.
pub const STACK_ANGLE: f32 = 0.9;

/// The fewest layers that make a stack: two surfaces back to back (a thin shell, a
/// decal) are common and cheap.
pub const STACK_LAYERS: usize = 3;

/// Stack depth tolerance as a share of the scene's box diagonal.
pub const STACK_TOLERANCE: f32 = 1e-4;

/// The crossings of `window` (nearest first) that are parallel to its first: a stack's
/// layers.
pub(super) fn layers(window: &[Crossing]) -> impl Iterator<Item = &Crossing> {
    let first = window[0].normal;
    window
        .iter()
        .filter(move |c| c.normal.dot(first).abs() >= STACK_ANGLE)
}

/// The deepest stack among one ray's crossings, as `(geometry, triangle)` nearest
/// first: the most triangles crossed in their interiors, each facing within
/// [`STACK_ANGLE`] of the first, all within `tolerance` of the first along the ray;
/// empty when it has fewer than [`STACK_LAYERS`].
pub(super) fn deepest_stack(crossed: &mut Vec<Crossing>, tolerance: f32) -> Vec<(u32, u32)> {
    crossed.retain(|c| c.interior);
    crossed.sort_by(|a, b| a.t.total_cmp(&b.t));
    // The crossings within `tolerance` of crossing i end before `end`; a window no
    // longer than the deepest stack so far cannot hold a deeper one, so a stack of L
    // layers costs O(L), not O(L²).
    let (mut deepest, mut deepest_window) = (STACK_LAYERS - 1, None);
    let mut end = 0;
    for i in 0..crossed.len() {
        while end < crossed.len() && crossed[end].t - crossed[i].t <= tolerance {
            end += 1;
        }
        if end - i <= deepest {
            continue;
        }
        let count = layers(&crossed[i..end]).count();
        if count > deepest {
            (deepest, deepest_window) = (count, Some(i..end));
        }
    }
    deepest_window.map_or_else(Vec::new, |window| {
        layers(&crossed[window])
            .map(|c| (c.geometry, c.triangle))
            .collect()
    })
}

/// Stacked alpha-tested layers, from [`alpha_layers_of`] per probe ray.
pub(super) fn lint_alpha_layers(layers: &[u32], findings: &mut Vec<Finding>) {
    let meeting: Vec<u32> = layers.iter().copied().filter(|&l| l > 0).collect();
    if meeting.is_empty() {
        return;
    }
    let mean = meeting.iter().map(|&l| l as f64).sum::<f64>() / meeting.len() as f64;
    let most = meeting.iter().copied().max().unwrap_or(0);
    if most < 2 {
        return;
    }
    findings.push(Finding {
        kind: "stacked-alpha",
        severity: if mean >= 2.0 {
            Severity::Warning
        } else {
            Severity::Info
        },
        geometry: 0,
        count: meeting.iter().filter(|&&l| l >= 2).count(),
        worst: vec![],
        figures: vec![
            ("mean_alpha_tests_per_ray_meeting_alpha", mean),
            ("most_alpha_tests_on_one_ray", most as f64),
            ("rays_meeting_alpha", meeting.len() as f64),
        ],
        advice: "rays cross several alpha-tested layers before an opaque hit, running an \
                 any-hit shader for each: merge the layers, make the inner ones opaque, or \
                 cut the alpha-tested area down to the visible shape",
    });
}

/// The share of probe rays through stacks from which they are a warning (below, a
/// few folded or overlapping triangles: worth knowing).
const STACKED_RAYS_WARNING: f64 = 0.01;

/// Stacked triangles, from [`deepest_stack`] per probe ray: the geometry of the
/// deepest stack, with that stack's triangles in it as the worst; a warning when
/// [`STACKED_RAYS_WARNING`] of the rays or more cross a stack.
pub(super) fn lint_stacks(
    stacks: &[Vec<(u32, u32)>],
    rays: usize,
    tolerance: f32,
    settings: &LintSettings,
    findings: &mut Vec<Finding>,
) {
    let Some(deepest) = stacks.iter().max_by_key(|s| s.len()) else {
        return;
    };
    if deepest.is_empty() {
        return;
    }
    let stacked: Vec<&Vec<(u32, u32)>> = stacks.iter().filter(|s| !s.is_empty()).collect();
    let mut triangles: Vec<(u32, u32)> = stacked.iter().flat_map(|s| s.iter().copied()).collect();
    triangles.sort_unstable();
    triangles.dedup();
    let geometry = deepest[0].0;
    let mean = stacked.iter().map(|s| s.len() as f64).sum::<f64>() / stacked.len() as f64;
    let share = stacked.len() as f64 / rays as f64;
    findings.push(Finding {
        kind: "stacked-triangles",
        severity: if share >= STACKED_RAYS_WARNING {
            Severity::Warning
        } else {
            Severity::Info
        },
        geometry: geometry as usize,
        count: triangles.len(),
        worst: deepest
            .iter()
            .filter(|&&(g, _)| g == geometry)
            .map(|&(_, t)| t)
            .take(settings.worst)
            .collect(),
        figures: vec![
            ("most_layers_on_one_ray", deepest.len() as f64),
            ("mean_layers_per_stacked_ray", mean),
            ("share_of_rays_through_stacks", share),
            ("depth_tolerance", tolerance as f64),
        ],
        advice: "rays cross several parallel triangles at (almost) one depth and test \
                 every one, though only the nearest can be seen: remove the hidden layers \
                 or merge them into one surface (rtmesh repair removes exact copies)",
    });
}

//! Mesh repair after NVIDIA's "Creating Optimal Meshes for Ray Tracing": fix what
//! [`crate::lint`] finds, keeping the map from every output triangle to its input
//! triangle.
//!
//! - Weld vertices with identical positions (so that neighbours share edges).
//! - Alpha-tested triangles mixed with opaque ones: an opaque geometry and an
//!   alpha-tested one, both placed by every instance of the original.
//! - Overlapping geometries (boxes overlapping by half or more, each placed once):
//!   merged into one geometry, transforms baked in, kept only when probe rays need
//!   fewer box tests.
//! - Scattered geometries (pieces far apart, see [`Pieces`]): one
//!   geometry per piece, placed by every instance of the original, kept only when
//!   probe rays (64², primary and diffuse) need fewer box tests through the result:
//!   a surface-area estimate said yes on Sponza, whose pieces then overlap in the
//!   top level and double the primary rays' box tests.
//! - Degenerate triangles (repeated indices, zero area): removed, or made inactive
//!   (all three corners NaN, the DXR convention) so that triangle ids stay put.
//! - Duplicate triangles (the corners and winding of an earlier triangle, see
//!   [`crate::mesh::duplicates`]): removed; mirrored copies (opposite winding) stay.
//! - Elongated triangles: conforming longest-edge bisection (Rivara, "New longest-edge
//!   algorithms for the refinement and/or improvement of unstructured triangulations",
//!   IJNME 1997). Each round follows, from every triangle whose box is mostly empty,
//!   the longest-edge propagation path (on to the neighbour across the longest edge
//!   until that edge is the longest of both triangles) and splits those terminal
//!   edges, longest first, at their midpoints in *every* triangle that uses them (no
//!   T-junction appears and a watertight mesh stays watertight), one split per
//!   triangle per round. Splitting only terminal edges never cuts a triangle across a
//!   short edge, which would breed slivers. A split triangle `(a, b, c)` on edge `ab`
//!   becomes `(a, m, c)` and `(m, b, c)`: same
//!   winding, same surface. Rounds repeat until nothing is left to split or the
//!   triangle budget is spent, and the round whose BVH costs the probe rays the fewest
//!   box and triangle tests is kept (the input, unless that saves 2%): the surface area
//!   heuristic, which judged this before, accepted splits of long slivers that raised
//!   the measured box tests by up to 2.6×. Cost per round O(T) plus the edge adjacency,
//!   a BVH build, O(T log T), and 8192 probe rays.

use crate::analysis::grouping::{assemble, merge_overlapping, split_pieces};
use crate::analysis::{Pieces, RepairMap, Repaired, TriangleShape};
use crate::lint::LintSettings;
use crate::mesh::{duplicates, validate, weld_exact, EdgeAdjacency, Scene, TriMesh, NO_EDGE};
use glam::Vec3;
use serde::Serialize;

/// What to do with degenerate triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Degenerate {
    /// Leave them.
    Keep,
    /// Drop them.
    Remove,
    /// Point them at a NaN vertex: inactive, ids kept.
    Inactive,
}

/// Which repairs to run.
#[derive(Clone, Debug, Serialize)]
pub struct RepairSettings {
    /// Merge vertices with identical positions (always done before splitting).
    pub weld: bool,
    /// Degenerate triangles.
    pub degenerate: Degenerate,
    /// Remove triangles with the corners and winding of an earlier triangle.
    pub remove_duplicates: bool,
    /// Split elongated triangles (as [`LintSettings`] define them).
    pub split_elongated: bool,
    /// Keep every split (to the budget) even where the tracer's probe rays say it does
    /// not pay: for builders that handle long thin triangles worse than rtmesh's SAH
    /// builder (NVIDIA's advice is about hardware builders). By default a split is kept
    /// only when it saves 2% of the probe rays' box and triangle tests.
    pub force_split: bool,
    /// Thresholds for "elongated".
    pub lint: LintSettings,
    /// Most output triangles per input triangle when splitting.
    pub triangle_budget: f32,
    /// Split geometries whose pieces are far apart into one geometry per piece, when
    /// that lowers the box tests per ray of probe rays (64², primary and diffuse).
    pub split_scattered: bool,
    /// Split alpha-tested triangles out of geometries that mix them with opaque ones:
    /// the opaque geometry (first) can then be flagged opaque and skip any-hit shaders.
    pub split_alpha: bool,
    /// Merge geometries whose boxes overlap by half or more (each placed once) into
    /// one, when that lowers the box tests per ray of probe rays.
    pub merge_overlapping: bool,
}

impl Default for RepairSettings {
    fn default() -> Self {
        Self {
            weld: true,
            degenerate: Degenerate::Remove,
            remove_duplicates: true,
            split_elongated: false,
            force_split: false,
            lint: LintSettings::default(),
            triangle_budget: 2.0,
            split_scattered: false,
            split_alpha: false,
            merge_overlapping: false,
        }
    }
}

/// What repair did, summed over geometries.
#[derive(Clone, Debug, Default, PartialEq, Serialize, schemars::JsonSchema)]
pub struct RepairReport {
    /// Input triangles.
    pub triangles_in: usize,
    /// Output triangles.
    pub triangles_out: usize,
    /// Vertices merged by welding.
    pub merged_vertices: usize,
    /// Degenerate triangles removed.
    pub removed_degenerate: usize,
    /// Degenerate triangles made inactive.
    pub made_inactive: usize,
    /// Duplicate triangles removed.
    pub removed_duplicates: usize,
    /// Edges split.
    pub split_edges: usize,
    /// Elongated triangles before.
    pub elongated_before: usize,
    /// Elongated triangles after (splitting a fan makes more, smaller ones).
    pub elongated_after: usize,
    /// Σ over triangles of box half-area × box empty space, before: the box area rays
    /// test for nothing.
    pub wasted_box_area_before: f64,
    /// The same after.
    pub wasted_box_area_after: f64,
    /// True when the kept splits stopped at the triangle budget.
    pub budget_reached: bool,
    /// Geometries split into one geometry per piece.
    pub split_geometries: usize,
    /// Geometries split into an opaque and an alpha-tested geometry.
    pub split_alpha_geometries: usize,
    /// Groups of overlapping geometries merged into one.
    pub merged_groups: usize,
    /// Output geometries.
    pub geometries_out: usize,
    /// Output geometries with no alpha-tested triangle, to be flagged opaque
    /// ([`TriMesh::is_opaque`]).
    pub opaque_geometries: Vec<u32>,
}

/// The shape of triangle `t`, or `None` when an index is out of range or a corner
/// is not finite.
fn shape(mesh: &TriMesh, t: usize) -> Option<TriangleShape> {
    mesh.finite_corners(t).map(TriangleShape::of)
}

/// Elongated triangles and the wasted box area (Σ half-area × empty space).
fn elongation(mesh: &TriMesh, settings: &LintSettings) -> (usize, f64) {
    (0..mesh.triangle_count())
        .filter_map(|t| shape(mesh, t))
        .fold((0, 0.0), |(count, wasted), s| {
            (
                count + s.is_elongated(settings.empty_space, settings.aspect) as usize,
                wasted + (s.box_half_area * s.empty_space) as f64,
            )
        })
}

/// Repair one geometry.
pub fn repair_mesh(mesh: &TriMesh, settings: &RepairSettings) -> (Repaired, RepairReport) {
    let (elongated_before, wasted_box_area_before) = elongation(mesh, &settings.lint);
    let mut report = RepairReport {
        triangles_in: mesh.triangle_count(),
        elongated_before,
        wasted_box_area_before,
        ..RepairReport::default()
    };
    let mut mesh = if settings.weld || settings.split_elongated {
        let welded = weld_exact(mesh);
        report.merged_vertices = welded.merged;
        welded.mesh
    } else {
        mesh.clone()
    };
    let mut input_triangle: Vec<u32> = (0..mesh.triangle_count() as u32).collect();
    if settings.degenerate != Degenerate::Keep {
        let validation = validate(&mesh);
        let degenerate = validation.degenerate();
        if settings.degenerate == Degenerate::Remove {
            remove_triangles(&mut mesh, &mut input_triangle, &degenerate);
            report.removed_degenerate = degenerate.len();
        } else if !degenerate.is_empty() {
            let nan = mesh.positions.len() as u32;
            mesh.positions.push(Vec3::NAN);
            for attribute in &mut mesh.attributes {
                attribute.push_zeros(1);
            }
            for &t in &degenerate {
                mesh.triangles[t as usize] = [nan; 3];
            }
            report.made_inactive = degenerate.len();
        }
    }
    if settings.remove_duplicates {
        let repeated = duplicates(&mesh).repeated;
        remove_triangles(&mut mesh, &mut input_triangle, &repeated);
        report.removed_duplicates = repeated.len();
    }
    if settings.split_elongated {
        let budget = (settings.triangle_budget.max(1.0) * report.triangles_in as f32) as usize;
        let (split, reached) = split_elongated(
            &mut mesh,
            &mut input_triangle,
            &settings.lint,
            budget,
            settings.force_split,
        );
        report.split_edges = split;
        report.budget_reached = reached;
    }
    report.triangles_out = mesh.triangle_count();
    (report.elongated_after, report.wasted_box_area_after) = elongation(&mesh, &settings.lint);
    (
        Repaired {
            mesh,
            input_triangle,
        },
        report,
    )
}

/// Repair every geometry of `scene` (materials kept); with `split_scattered`, the
/// geometries whose pieces are far apart ([`Pieces::scattered`]) become
/// one geometry per piece, each placed wherever the original was, if probe rays say
/// that traces with fewer box tests. Returns the repaired scene, the map back to input
/// geometries and triangles, and the summed report.
pub fn repair(scene: &Scene, settings: &RepairSettings) -> (Scene, RepairMap, RepairReport) {
    let mut total = RepairReport::default();
    // Per input geometry: the repaired geometry, and its pieces where it is scattered.
    let mut variants: Vec<(Vec<Repaired>, Option<Vec<Repaired>>)> =
        Vec::with_capacity(scene.meshes.len());
    for mesh in &scene.meshes {
        let (repaired, report) = repair_mesh(mesh, settings);
        total.triangles_in += report.triangles_in;
        total.triangles_out += report.triangles_out;
        total.merged_vertices += report.merged_vertices;
        total.removed_degenerate += report.removed_degenerate;
        total.removed_duplicates += report.removed_duplicates;
        total.made_inactive += report.made_inactive;
        total.split_edges += report.split_edges;
        total.elongated_before += report.elongated_before;
        total.elongated_after += report.elongated_after;
        total.wasted_box_area_before += report.wasted_box_area_before;
        total.wasted_box_area_after += report.wasted_box_area_after;
        total.budget_reached |= report.budget_reached;
        let alpha = repaired.mesh.alpha_tested.iter().filter(|&&a| a).count();
        if settings.split_alpha && alpha > 0 && alpha < repaired.mesh.triangle_count() {
            // Opaque triangles first, then the alpha-tested ones.
            let part: Vec<u32> = repaired
                .mesh
                .alpha_tested
                .iter()
                .map(|&a| a as u32)
                .collect();
            total.split_alpha_geometries += 1;
            variants.push((split_pieces(&repaired, &part, 2), None));
            continue;
        }
        let pieces = Pieces::of(&repaired.mesh);
        let split = (settings.split_scattered && pieces.scattered())
            .then(|| split_pieces(&repaired, &pieces.of_triangle, pieces.boxes.len()));
        variants.push((vec![repaired], split));
    }
    let (whole, whole_map) = assemble(scene, &variants, false);
    let (out, map) = if variants.iter().any(|v| v.1.is_some()) {
        // Keep the split only if the tracer says so, on probe rays.
        let (split, split_map) = assemble(scene, &variants, true);
        let rays = probe_rays(&whole);
        if probe_box_tests(&rays, &split) < probe_box_tests(&rays, &whole) {
            total.split_geometries = variants.iter().filter(|v| v.1.is_some()).count();
            (split, split_map)
        } else {
            (whole, whole_map)
        }
    } else {
        (whole, whole_map)
    };
    let (out, map) = if settings.merge_overlapping {
        let merge = merge_overlapping(&out, &map);
        let rays = merge
            .as_ref()
            .map(|_| probe_rays(scene))
            .unwrap_or_default();
        match merge {
            Some((merged, merged_map, groups))
                if probe_box_tests(&rays, &merged) < probe_box_tests(&rays, &out) =>
            {
                total.merged_groups = groups;
                (merged, merged_map)
            }
            _ => (out, map),
        }
    } else {
        (out, map)
    };
    total.geometries_out = out.meshes.len();
    total.opaque_geometries = (0..out.meshes.len() as u32)
        .filter(|&g| out.meshes[g as usize].is_opaque())
        .collect();
    (out, map, total)
}

/// The probe rays for `reference`: 64 × 64 primary rays and their diffuse bounces.
fn probe_rays(reference: &Scene) -> Vec<crate::Ray> {
    use crate::trace::{RayKind, SceneAccel, Workload};
    let accel = SceneAccel::build(reference, &crate::bvh::BuildSettings::default());
    [RayKind::Primary, RayKind::Diffuse]
        .into_iter()
        .flat_map(|kind| Workload::generate(kind, reference, &accel, 64, 64, 1).rays)
        .collect()
}

/// Mean box tests and triangle tests per ray of `rays` traced through `candidate`.
fn probe_tests(rays: &[crate::Ray], candidate: &Scene) -> (f64, f64) {
    use crate::trace::run::trace_closest;
    use crate::trace::{Counters, RayCounters, SceneAccel};
    let accel = SceneAccel::build(candidate, &crate::bvh::BuildSettings::default());
    let mut total = RayCounters::default();
    for counters in trace_closest::<RayCounters>(&accel, rays).1 {
        total.merge(&counters);
    }
    let per_ray = |count: u64| count as f64 / rays.len().max(1) as f64;
    (per_ray(total.box_tests), per_ray(total.triangle_tests))
}

/// Mean box tests per ray of `rays` traced through `candidate`.
fn probe_box_tests(rays: &[crate::Ray], candidate: &Scene) -> f64 {
    probe_tests(rays, candidate).0
}

/// Remove the triangles `ids` (ascending), with their attributes, from `mesh` and
/// their input ids from `input_triangle`.
fn remove_triangles(mesh: &mut TriMesh, input_triangle: &mut Vec<u32>, ids: &[u32]) {
    if ids.is_empty() {
        return;
    }
    let kept: Vec<u32> = (0..mesh.triangle_count() as u32)
        .filter(|t| ids.binary_search(t).is_err())
        .collect();
    let mut out = TriMesh {
        name: std::mem::take(&mut mesh.name),
        positions: std::mem::take(&mut mesh.positions),
        attributes: std::mem::take(&mut mesh.attributes),
        triangles: kept.iter().map(|&t| mesh.triangles[t as usize]).collect(),
        ..TriMesh::default()
    };
    out.take_triangle_data(mesh, &kept);
    *mesh = out;
    *input_triangle = kept.iter().map(|&t| input_triangle[t as usize]).collect();
}

/// Least share of the probe rays' tests the splits must save to be kept.
const MIN_SAVING: f64 = 0.02;

/// What the splits are judged by: box tests plus triangle tests per probe ray through
/// the tracer's BVH over `mesh`.
fn probe_cost(rays: &[crate::Ray], mesh: &TriMesh) -> f64 {
    let (boxes, triangles) = probe_tests(rays, &Scene::from_mesh(mesh.clone()));
    boxes + triangles
}

/// Conforming bisection of the triangles of `mesh` (welded) whose boxes are mostly
/// empty, at most `budget` triangles in the end. Rounds run until nothing is left to
/// split or the budget is spent; the mesh kept is the round whose BVH (built by the
/// tracer) costs the probe rays (those of the input) the fewest box and triangle tests
/// (a fan needs two rounds before its boxes shrink, so one round's loss is not a reason
/// to stop), unless that saves under 2% of the input's tests, when the mesh is left as
/// it was. Returns the edges split and whether
/// the budget stopped it.
fn split_elongated(
    mesh: &mut TriMesh,
    input_triangle: &mut Vec<u32>,
    settings: &LintSettings,
    budget: usize,
    force: bool,
) -> (usize, bool) {
    // Measured splits are judged against the input (its probe rays, its cost, and the
    // input itself to go back to); forced ones keep the last round.
    let judge = (!force).then(|| {
        let rays = probe_rays(&Scene::from_mesh(mesh.clone()));
        let initial = probe_cost(&rays, mesh);
        (rays, initial, mesh.clone(), input_triangle.clone())
    });
    let mut cheapest: Option<(f64, TriMesh, Vec<u32>, usize)> = None;
    let mut split = 0;
    let mut reached = false;
    for _round in 0..64 {
        // Adjacency by position, so that splits cross UV seams and normal creases and
        // the mesh stays watertight.
        let topology = mesh.topology();
        let adjacency = EdgeAdjacency::build(&topology);
        let length = |e: u32| {
            let [a, b] = adjacency.edges[e as usize];
            (topology.positions[a as usize] - topology.positions[b as usize]).length_squared()
        };
        let longest_of = |t: usize| {
            adjacency.triangle_edges[t]
                .iter()
                .copied()
                .filter(|&e| e != NO_EDGE)
                .max_by(|&a, &b| length(a).total_cmp(&length(b)).then(b.cmp(&a)))
        };
        // From every triangle whose box is mostly empty, Rivara's longest-edge
        // propagation path: on to the neighbour across the longest edge until that edge
        // is the longest of both triangles (or a boundary or non-manifold edge), whose
        // split then cuts no triangle across a short edge.
        let mut candidates: Vec<u32> = (0..mesh.triangle_count())
            .filter(|&t| {
                shape(mesh, t)
                    .is_some_and(|s| s.area > 0.0 && s.empty_space >= settings.empty_space)
            })
            .filter_map(|t| {
                let mut edge = longest_of(t)?;
                let mut at = t as u32;
                for _ in 0..64 {
                    let around = adjacency.triangles_of(edge);
                    let [first, second] = around[..] else {
                        break;
                    };
                    let neighbour = if first == at { second } else { first };
                    match longest_of(neighbour as usize) {
                        Some(next) if next != edge => {
                            at = neighbour;
                            edge = next;
                        }
                        _ => break,
                    }
                }
                Some(edge)
            })
            .collect();
        if candidates.is_empty() {
            break;
        }
        candidates.sort_unstable_by(|&a, &b| length(b).total_cmp(&length(a)).then(a.cmp(&b)));
        candidates.dedup();
        let mut taken = vec![false; mesh.triangle_count()];
        let mut accepted = Vec::new();
        let mut count = mesh.triangle_count();
        for e in candidates {
            let triangles = adjacency.triangles_of(e);
            if triangles.iter().any(|&t| taken[t as usize]) {
                continue;
            }
            if count + triangles.len() > budget {
                reached = true;
                break;
            }
            for &t in triangles {
                taken[t as usize] = true;
            }
            count += triangles.len();
            accepted.push(e);
        }
        apply_splits(mesh, input_triangle, &adjacency, &accepted);
        split += accepted.len();
        if let Some((rays, ..)) = &judge {
            let cost = probe_cost(rays, mesh);
            if cheapest.as_ref().is_none_or(|c| cost < c.0) {
                cheapest = Some((cost, mesh.clone(), input_triangle.clone(), split));
            }
        }
        if reached || accepted.is_empty() {
            break;
        }
    }
    let Some((_, initial, original, original_input)) = judge else {
        return (split, reached);
    };
    // Splits that save under 2% of the tests are not worth their triangles.
    match cheapest {
        Some((cost, kept, kept_input, kept_split)) if cost <= (1.0 - MIN_SAVING) * initial => {
            *mesh = kept;
            *input_triangle = kept_input;
            (kept_split, reached)
        }
        _ => {
            *mesh = original;
            *input_triangle = original_input;
            (0, false)
        }
    }
}

/// Split every triangle of each edge in `edges` (of the topology `adjacency` was built
/// on) at the edge's midpoint. Each distinct pair of end vertices (the two sides of a
/// seam are two) gets its own midpoint vertex, with attributes interpolated between its
/// ends, so seams stay seams.
fn apply_splits(
    mesh: &mut TriMesh,
    input_triangle: &mut Vec<u32>,
    adjacency: &EdgeAdjacency,
    edges: &[u32],
) {
    let mut midpoints: std::collections::HashMap<(u32, u32), u32> = Default::default();
    for &e in edges {
        midpoints.clear();
        for &t in adjacency.triangles_of(e) {
            let t = t as usize;
            let k = (0..3)
                .find(|&k| adjacency.triangle_edges[t][k] == e)
                .expect("the edge is a side of its triangle");
            let tri = mesh.triangles[t];
            let (from, to, opposite) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let ends = (from.min(to), from.max(to));
            let m = *midpoints.entry(ends).or_insert_with(|| {
                let (a, b) = (ends.0 as usize, ends.1 as usize);
                mesh.positions
                    .push((mesh.positions[a] + mesh.positions[b]) * 0.5);
                for attribute in &mut mesh.attributes {
                    attribute.push_midpoint(a, b);
                }
                mesh.positions.len() as u32 - 1
            });
            mesh.triangles[t] = rotate_to(k, [from, m, opposite]);
            mesh.push_triangle_like_self(t, [m, to, opposite]);
            input_triangle.push(input_triangle[t]);
        }
    }
}

/// `replacement`, listed from the parent's corner `k`, rotated back so that the kept
/// half lists its corners in the parent's order.
fn rotate_to(k: usize, replacement: [u32; 3]) -> [u32; 3] {
    let mut out = [0; 3];
    for (i, &v) in replacement.iter().enumerate() {
        out[(k + i) % 3] = v;
    }
    out
}

//! Mesh lint after NVIDIA's "Creating Optimal Meshes for Ray Tracing" (Pawel Kozlowski
//! and Evan Hart, NVIDIA developer blog): the pitfalls a BVH pays for, found in a user's
//! scene with counts, the worst offenders, a severity and one line of advice.
//!
//! Per-triangle measures (one pass, O(T), parallel):
//! - box empty space `1 − min(1, 2A / F)`: `A` the triangle's area, `F` the largest
//!   face of its axis-aligned box. A triangle lying in a box face fills at most half of
//!   it, hence the 2: an axis-aligned right triangle scores 0, a diagonal sliver
//!   scores near 1 (its box is almost all empty space, which every ray near it tests);
//! - aspect `L² / 2A`: longest edge over the shortest altitude (2/√3 for an
//!   equilateral triangle, infinite for a degenerate one).
//!
//! A triangle is *elongated* when its box is at least `empty_space` empty (default
//! 0.8) or its aspect is at least `aspect` (default 25). The figure that matters for a
//! BVH is the share of the summed triangle box areas (the leaves' SAH cost) that the
//! elongated triangles carry. A *fan* is a vertex with at least `fan_valence`
//! triangles of which most are elongated. Geometry findings use connected components
//! (welded by exact position): a geometry whose pieces' boxes cover less than half its
//! own box area is *scattered* (split it into instances); small geometries whose boxes
//! overlap heavily should be merged.
//!
//! Probe rays (128² from the default camera, every crossing found by an any-hit
//! traversal that never stops) count stacked alpha-tested layers and find *stacks*:
//! three or more parallel triangles that a ray crosses at one depth (copies, z-fighting
//! layers, folds), each of which every ray through them tests. Cost: one BVH build
//! and O(crossings) per ray.

mod deforming;
mod probe;

pub use deforming::{lint_deforming, DeformingError, PoseMismatch};
pub use probe::{alpha_layers, STACK_ANGLE, STACK_LAYERS, STACK_TOLERANCE};

use probe::{alpha_layers_of, deepest_stack, lint_alpha_layers, lint_stacks, probe_crossings};

use crate::analysis::{overlapping_instances, proposed_grouping, Pieces, TriangleShape};
use crate::mesh::{validate, Scene, TriMesh};
use rayon::prelude::*;
use serde::Serialize;

/// How serious a finding is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// Worth knowing.
    Info,
    /// Costs trace speed.
    Warning,
    /// Wrong or unusable geometry.
    Error,
}

/// One problem found.
#[derive(Clone, Debug, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Finding {
    /// Short name: `elongated-triangles`, `fans`, `degenerate-triangles`,
    /// `inactive-triangles`, `out-of-range-indices`, `infinite-positions`,
    /// `duplicate-triangles`, `back-to-back-triangles`, `mixed-alpha`, `stacked-alpha`,
    /// `stacked-triangles`, `scattered-geometry`, `overlapping-geometries`, `deforming-mesh`.
    pub kind: &'static str,
    /// How serious.
    pub severity: Severity,
    /// Geometry (mesh) index the finding is about.
    pub geometry: usize,
    /// How many triangles (vertices for fans, geometries for overlaps).
    pub count: usize,
    /// The worst offenders, worst first: triangle ids within the geometry (vertex ids
    /// for fans, geometry ids for overlaps).
    pub worst: Vec<u32>,
    /// Figures behind the finding, by name.
    pub figures: Vec<(&'static str, f64)>,
    /// What to do about it.
    pub advice: &'static str,
}

/// Thresholds.
#[derive(Clone, Debug, Serialize)]
pub struct LintSettings {
    /// Box empty space at or above which a triangle is elongated.
    pub empty_space: f32,
    /// Aspect at or above which a triangle is elongated.
    pub aspect: f32,
    /// Triangles around a vertex from which it may be a fan.
    pub fan_valence: usize,
    /// Offenders listed per finding.
    pub worst: usize,
}

impl Default for LintSettings {
    fn default() -> Self {
        Self {
            empty_space: 0.8,
            aspect: 25.0,
            fan_valence: 12,
            worst: 10,
        }
    }
}

/// Quantiles of a per-triangle measure.
#[derive(Clone, Debug, Default, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Quantiles {
    /// Median.
    pub p50: f32,
    /// 90th percentile.
    pub p90: f32,
    /// 99th percentile.
    pub p99: f32,
    /// Largest.
    pub max: f32,
}

impl Quantiles {
    fn of(mut values: Vec<f32>) -> Self {
        if values.is_empty() {
            return Self::default();
        }
        values.sort_unstable_by(f32::total_cmp);
        let at = |q: f64| values[((values.len() - 1) as f64 * q).round() as usize];
        Self {
            p50: at(0.5),
            p90: at(0.9),
            p99: at(0.99),
            max: at(1.0),
        }
    }
}

/// Everything lint found.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct LintReport {
    /// Triangles in all geometries.
    pub triangles: usize,
    /// Geometries (meshes).
    pub geometries: usize,
    /// Box empty space over all valid triangles.
    pub empty_space: Quantiles,
    /// Aspect over all valid non-degenerate triangles.
    pub aspect: Quantiles,
    /// Findings, by geometry then kind.
    pub findings: Vec<Finding>,
    /// Seconds lint took.
    pub seconds: f64,
}

/// The worst `n` of `ids` by `score` (largest first).
fn worst_by(mut ids: Vec<u32>, n: usize, score: impl Fn(u32) -> f32) -> Vec<u32> {
    ids.sort_by(|&a, &b| score(b).total_cmp(&score(a)).then(a.cmp(&b)));
    ids.truncate(n);
    ids
}

/// Probe rays per side of the image that lint traces for stacked layers.
const PROBE_SIDE: usize = 128;

/// Lint every geometry of `scene`.
pub fn lint(scene: &Scene, settings: &LintSettings) -> LintReport {
    let start = std::time::Instant::now();
    let mut findings = Vec::new();
    let mut empty_all = Vec::new();
    let mut aspect_all = Vec::new();
    let mut pieces = Vec::with_capacity(scene.meshes.len());
    for (g, mesh) in scene.meshes.iter().enumerate() {
        let validation = validate(mesh);
        let shapes: Vec<Option<TriangleShape>> = (0..mesh.triangle_count())
            .into_par_iter()
            .map(|t| mesh.finite_corners(t).map(TriangleShape::of))
            .collect();
        for shape in shapes.iter().flatten() {
            empty_all.push(shape.empty_space);
            if shape.area > 0.0 {
                aspect_all.push(shape.aspect);
            }
        }
        lint_triangles(g, mesh, &shapes, settings, &mut findings);
        lint_broken(g, mesh, &validation, settings, &mut findings);
        lint_duplicates(g, mesh, settings, &mut findings);
        lint_alpha(g, mesh, settings, &mut findings);
        pieces.push(Pieces::of(mesh));
        lint_pieces(g, &pieces[g], settings, &mut findings);
    }
    lint_overlaps(scene, settings, &mut findings);
    estimate_grouping(scene, &pieces, &mut findings);
    let tolerance = STACK_TOLERANCE * scene.bounds().diagonal_length();
    let (layers, stacks): (Vec<u32>, Vec<Vec<(u32, u32)>>) =
        probe_crossings(scene, PROBE_SIDE, PROBE_SIDE, |crossed| {
            (alpha_layers_of(crossed), deepest_stack(crossed, tolerance))
        })
        .into_iter()
        .unzip();
    lint_alpha_layers(&layers, &mut findings);
    lint_stacks(&stacks, layers.len(), tolerance, settings, &mut findings);
    LintReport {
        triangles: scene.meshes.iter().map(TriMesh::triangle_count).sum(),
        geometries: scene.meshes.len(),
        empty_space: Quantiles::of(empty_all),
        aspect: Quantiles::of(aspect_all),
        findings,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Elongated triangles and fans.
fn lint_triangles(
    g: usize,
    mesh: &TriMesh,
    shapes: &[Option<TriangleShape>],
    settings: &LintSettings,
    findings: &mut Vec<Finding>,
) {
    let elongated: Vec<u32> = (0..shapes.len() as u32)
        .filter(|&t| {
            shapes[t as usize]
                .is_some_and(|s| s.is_elongated(settings.empty_space, settings.aspect))
        })
        .collect();
    if elongated.is_empty() {
        return;
    }
    let weight = |t: u32| shapes[t as usize].map_or(0.0, |s| s.box_half_area);
    let total: f64 = (0..shapes.len() as u32).map(|t| weight(t) as f64).sum();
    let carried: f64 = elongated.iter().map(|&t| weight(t) as f64).sum();
    let wasted = |t: u32| shapes[t as usize].map_or(0.0, |s| s.box_half_area * s.empty_space);
    findings.push(Finding {
        kind: "elongated-triangles",
        severity: Severity::Warning,
        geometry: g,
        count: elongated.len(),
        worst: worst_by(elongated.clone(), settings.worst, wasted),
        figures: vec![
            (
                "share_of_triangles",
                elongated.len() as f64 / shapes.len() as f64,
            ),
            (
                "share_of_leaf_sah_cost",
                carried / total.max(f64::MIN_POSITIVE),
            ),
        ],
        advice: "long thin triangles have large, mostly empty boxes that many rays test: \
                 split them (rtmesh repair --split-elongated) or remodel",
    });
    // Fans: vertices most of whose many triangles are elongated.
    let mut around = vec![(0u32, 0u32); mesh.positions.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let thin = elongated.binary_search(&(t as u32)).is_ok();
        for &v in tri {
            if let Some(count) = around.get_mut(v as usize) {
                count.0 += 1;
                count.1 += thin as u32;
            }
        }
    }
    let fans: Vec<u32> = (0..around.len() as u32)
        .filter(|&v| {
            let (all, thin) = around[v as usize];
            all as usize >= settings.fan_valence && 2 * thin > all
        })
        .collect();
    if !fans.is_empty() {
        let valence = |v: u32| around[v as usize].0 as f32;
        let most = fans.iter().map(|&v| valence(v)).fold(0.0, f32::max);
        findings.push(Finding {
            kind: "fans",
            severity: Severity::Warning,
            geometry: g,
            count: fans.len(),
            worst: worst_by(fans, settings.worst, valence),
            figures: vec![("largest_valence", most as f64)],
            advice: "many long thin triangles around one vertex overlap each other's boxes: \
                     split them or re-triangulate the fan (e.g. as a strip or grid)",
        });
    }
}

/// Degenerate, inactive (NaN), infinite and out-of-range triangles.
fn lint_broken(
    g: usize,
    mesh: &TriMesh,
    validation: &crate::mesh::Validation,
    settings: &LintSettings,
    findings: &mut Vec<Finding>,
) {
    let degenerate = validation.degenerate();
    if !degenerate.is_empty() {
        let at_origin = degenerate
            .iter()
            .filter(|&&t| {
                mesh.corners(t as usize)
                    .iter()
                    .all(|p| *p == glam::Vec3::ZERO)
            })
            .count();
        findings.push(Finding {
            kind: "degenerate-triangles",
            severity: Severity::Warning,
            geometry: g,
            count: degenerate.len(),
            worst: degenerate.iter().copied().take(settings.worst).collect(),
            figures: vec![
                (
                    "repeated_indices",
                    validation.repeated_vertices.len() as f64,
                ),
                ("zero_area", validation.zero_area.len() as f64),
                ("at_origin", at_origin as f64),
            ],
            advice: if at_origin == degenerate.len() {
                "all degenerate triangles sit at the origin: a refit stretches boxes to reach \
                 them when the mesh moves; remove them or mark them inactive (NaN)"
            } else {
                "degenerate triangles cost box and triangle tests and never hit: remove them \
                 (rtmesh repair) or mark them inactive with --inactive"
            },
        });
    }
    let nan: Vec<u32> = validation
        .non_finite_positions
        .iter()
        .copied()
        .filter(|&t| {
            mesh.triangles[t as usize]
                .iter()
                .any(|&v| mesh.positions[v as usize].is_nan())
        })
        .collect();
    let infinite: Vec<u32> = validation
        .non_finite_positions
        .iter()
        .copied()
        .filter(|t| nan.binary_search(t).is_err())
        .collect();
    let broken = [
        (
            "inactive-triangles",
            Severity::Info,
            nan,
            "triangles with NaN corners are inactive (the DXR convention): the tracer skips them",
        ),
        (
            "infinite-positions",
            Severity::Error,
            infinite,
            "triangles with infinite corners are skipped; fix the positions",
        ),
        (
            "out-of-range-indices",
            Severity::Error,
            validation.out_of_range_indices.clone(),
            "triangles naming vertices that do not exist are skipped; fix the indices",
        ),
    ];
    push_id_findings(g, settings, findings, broken, |_| vec![]);
}

/// One finding of geometry `g` per `(kind, severity, triangle ids, advice)` with ids,
/// the first ids its worst, with `figures(ids)`.
fn push_id_findings<const N: usize>(
    g: usize,
    settings: &LintSettings,
    findings: &mut Vec<Finding>,
    kinds: [(&'static str, Severity, Vec<u32>, &'static str); N],
    figures: impl Fn(&[u32]) -> Vec<(&'static str, f64)>,
) {
    for (kind, severity, ids, advice) in kinds {
        if !ids.is_empty() {
            findings.push(Finding {
                kind,
                severity,
                geometry: g,
                count: ids.len(),
                worst: ids.iter().copied().take(settings.worst).collect(),
                figures: figures(&ids),
                advice,
            });
        }
    }
}

/// Triangles on the corners of an earlier one ([`crate::mesh::duplicates`]).
fn lint_duplicates(g: usize, mesh: &TriMesh, settings: &LintSettings, findings: &mut Vec<Finding>) {
    let found = crate::mesh::duplicates(mesh);
    let copies = [
        (
            "duplicate-triangles",
            Severity::Warning,
            found.repeated,
            "copies of a triangle (same corners, same winding) are tested again by every \
             ray that reaches them and hide nothing: remove them (rtmesh repair does)",
        ),
        (
            "back-to-back-triangles",
            Severity::Info,
            found.back_to_back,
            "a triangle and its mirror (same corners, opposite winding) make a surface \
             two-sided for a rasteriser; a ray tracer without back-face culling needs \
             only one, and tests both",
        ),
    ];
    let share = |ids: &[u32]| {
        vec![(
            "share_of_triangles",
            ids.len() as f64 / mesh.triangle_count() as f64,
        )]
    };
    push_id_findings(g, settings, findings, copies, share);
}

/// Alpha-tested triangles mixed into a geometry with opaque ones.
fn lint_alpha(g: usize, mesh: &TriMesh, settings: &LintSettings, findings: &mut Vec<Finding>) {
    let alpha: Vec<u32> = (0..mesh.triangle_count() as u32)
        .filter(|&t| mesh.alpha_tested.get(t as usize).copied().unwrap_or(false))
        .collect();
    if alpha.is_empty() || alpha.len() == mesh.triangle_count() {
        return;
    }
    findings.push(Finding {
        kind: "mixed-alpha",
        severity: Severity::Warning,
        geometry: g,
        count: alpha.len(),
        worst: alpha.iter().copied().take(settings.worst).collect(),
        figures: vec![("opaque", (mesh.triangle_count() - alpha.len()) as f64)],
        advice: "alpha-tested triangles in an otherwise opaque geometry force any-hit \
                 shaders on the whole geometry: split them into their own geometry and flag \
                 the rest opaque",
    });
}

/// Connected pieces of a geometry and whether they leave its box mostly empty.
fn lint_pieces(g: usize, pieces: &Pieces, settings: &LintSettings, findings: &mut Vec<Finding>) {
    if pieces.scattered() {
        let ids: Vec<u32> = (0..pieces.boxes.len() as u32).collect();
        findings.push(Finding {
            kind: "scattered-geometry",
            severity: Severity::Warning,
            geometry: g,
            count: pieces.boxes.len(),
            worst: worst_by(ids, settings.worst, |p| {
                pieces.boxes[p as usize].half_area()
            }),
            figures: vec![(
                "pieces_box_area_over_geometry_box_area",
                pieces.coverage as f64,
            )],
            advice: "this geometry's pieces are far apart: its box is mostly empty space that \
                     rays enter for nothing; split the pieces into separate instances \
                     (rtmesh repair --split-scattered)",
        });
    }
}

/// Pairs of geometries whose boxes overlap heavily: merged, they would share one BVH
/// and rays would not traverse both.
fn lint_overlaps(scene: &Scene, settings: &LintSettings, findings: &mut Vec<Finding>) {
    let pairs = overlapping_instances(scene);
    let placements = scene.placements();
    let instanced = |i: usize| placements[scene.instances[i].mesh] > 1;
    for mine in pairs.chunk_by(|p, q| p.0 == q.0) {
        let a = mine[0].0;
        let advice = if instanced(a) || mine.iter().any(|p| instanced(p.1)) {
            "rays through the overlap traverse several BVHs; instanced geometry is \
             involved, which merging would copy (`repair --merge-overlapping` leaves it): \
             place the instances apart, or accept the extra traversal"
        } else {
            "rays through the overlap traverse several BVHs: merge geometries whose \
             boxes overlap this much into one (`repair --merge-overlapping`)"
        };
        findings.push(Finding {
            kind: "overlapping-geometries",
            severity: Severity::Info,
            geometry: scene.instances[a].mesh,
            count: mine.len(),
            worst: mine
                .iter()
                .map(|p| p.1 as u32)
                .take(settings.worst)
                .collect(),
            figures: vec![(
                "largest_box_overlap",
                mine.iter().map(|p| p.2).fold(0.0, f32::max) as f64,
            )],
            advice,
        });
    }
}

/// The two-level SAH cost of the scene as it is and as the proposed grouping
/// ([`proposed_grouping`]) would make it, added to the grouping
/// findings as `two_level_sah_before` and `two_level_sah_after`. Builds the BVHs of
/// both (only for scenes with such findings).
fn estimate_grouping(scene: &Scene, pieces: &[Pieces], findings: &mut [Finding]) {
    let is_grouping =
        |f: &Finding| matches!(f.kind, "scattered-geometry" | "overlapping-geometries");
    if !findings.iter().any(is_grouping) {
        return;
    }
    let Some(proposed) = proposed_grouping(scene, pieces) else {
        return;
    };
    let cost = |scene: &Scene| {
        crate::trace::SceneAccel::build(scene, &crate::bvh::BuildSettings::default())
            .two_level_sah_cost()
    };
    let (before, after) = (cost(scene), cost(&proposed));
    for finding in findings.iter_mut().filter(|f| is_grouping(f)) {
        finding.figures.push(("two_level_sah_before", before));
        finding.figures.push(("two_level_sah_after", after));
    }
}

//! The main job: a scene in, the scene prepared for ray tracing out, with the proof.
//!
//! [`optimize`] runs, in order:
//! 1. **lint** on the input ([`crate::lint`]);
//! 2. **the safe repairs** ([`safe_repairs`]): weld identical vertices (attributes
//!    kept, so seams stay), drop degenerate triangles and exact copies, split
//!    scattered geometries and merge overlapping ones where probe rays measure a gain,
//!    split alpha-tested from opaque triangles ([`crate::repair`]);
//! 3. **the target**: [`Target::Pairs`] pairs triangles that share an edge by vertex
//!    index ([`crate::pair::PairSettings::by_index`]), taking whichever of the input's
//!    own consecutive pairs, `sah-max` and `window:2` pairs the most triangles (the
//!    input's order on a tie), and writes
//!    each pair as two consecutive triangles, so that the windowed first-fit pairers of
//!    Embree, HIPRT and GPURT ([`crate::pair::first_fit`]) recover exactly these pairs
//!    (checked on every run: [`FirstFitCheck`]);
//! 4. **the measurement** (optional): primary, diffuse and shadow rays through the
//!    input's triangle BVH and the output's BVH (pair leaves for pairs), alternating
//!    rounds, medians; BVH and geometry bytes and build time; and, through the map back
//!    to input triangles, whether every primary ray hits the same input triangle.
//!
//! Cost: linear in the triangles for the repairs and pairing (the greedy pairing sorts
//! the edges), plus the measurement, which is held to
//! [`crate::trace::measure::MEASURE_BUDGET_SECONDS`] per comparison whatever the mesh.

pub mod html;

use crate::analysis::{RepairMap, TriangleShape};
use crate::bvh::BuildSettings;
use crate::lint::{LintReport, LintSettings};
use crate::mesh::{validate, Scene, TriMesh};
use crate::pair::{self, first_fit, PairMethod, PairSettings, Pairing};
use crate::progress::Progress;
use crate::repair::{Degenerate, RepairReport, RepairSettings};
use crate::trace::accel::AccelStats;
use crate::trace::measure::{BeforeAfter, Traced};
use crate::trace::run::trace_closest;
use crate::trace::{Hit, LeafBlock, NoCounters, RayKind, SceneAccel, View, Workload};
use schemars::JsonSchema;
use serde::Serialize;
use std::fmt;
use std::str::FromStr;

/// Version of [`OptimizeReport`]'s layout: raised when a key changes meaning or goes.
pub const SCHEMA: u32 = 1;

/// What the output is prepared for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Target {
    /// Triangle pairs (quads) for tracers and hardware that test two at a time.
    Pairs,
    /// Triangles: the safe repairs only, order kept.
    Triangles,
    /// Strip-RT strips: each geometry's triangles in strip order (corners as they
    /// were), the strip lengths in [`Optimized::sequences`].
    Strips,
    /// Precomputed clusters for animated meshes: each geometry's triangles in cluster
    /// order (grown by Acc(k)), the cluster sizes in [`Optimized::sequences`].
    Clusters,
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Target::Pairs => "pairs",
            Target::Triangles => "triangles",
            Target::Strips => "strips",
            Target::Clusters => "clusters",
        })
    }
}

impl FromStr for Target {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "pairs" => Ok(Target::Pairs),
            "triangles" => Ok(Target::Triangles),
            "strips" => Ok(Target::Strips),
            "clusters" => Ok(Target::Clusters),
            _ => Err(format!(
                "unknown target `{s}`: expected pairs, triangles, strips or clusters"
            )),
        }
    }
}

/// The before/after measurement's settings.
#[derive(Clone, Debug)]
pub struct MeasureOptions {
    /// Image size of the primary rays (fewer where tracing would take over the time
    /// budget).
    pub size: (usize, usize),
    /// Alternating timed rounds (medians).
    pub runs: usize,
    /// Where the camera stands.
    pub view: View,
}

impl Default for MeasureOptions {
    fn default() -> Self {
        Self {
            size: (512, 512),
            runs: 5,
            view: View::Iso,
        }
    }
}

/// What [`optimize`] does.
#[derive(Clone, Debug)]
pub struct OptimizeOptions {
    /// What to prepare for.
    pub target: Target,
    /// The repairs ([`safe_repairs`] by default).
    pub repair: RepairSettings,
    /// The pairing method; `None` takes the best of the input order, `sah-max` and
    /// `window:2`. `sah-max` rather than `sah`: on the dragon it pairs 100% against
    /// 89.7%, for 0.91× the BVH bytes in rtmesh's tracer and in Embree's quads, the
    /// same Mrays/s in both, and the same preparation time within noise
    /// (docs/measurements/optimize.md).
    pub pair_method: Option<PairMethod>,
    /// The before/after measurement; `None` skips it.
    pub measure: Option<MeasureOptions>,
}

impl Default for OptimizeOptions {
    fn default() -> Self {
        Self {
            target: Target::Pairs,
            repair: safe_repairs(),
            pair_method: None,
            measure: Some(MeasureOptions::default()),
        }
    }
}

/// The repairs that change no surface a ray can hit: weld identical vertices, drop
/// degenerate triangles and exact copies, split scattered and merge overlapping
/// geometries where probe rays measure a gain, split alpha-tested from opaque
/// triangles. (Splitting elongated triangles adds vertices and is left to `repair`.)
pub fn safe_repairs() -> RepairSettings {
    RepairSettings {
        weld: true,
        degenerate: Degenerate::Remove,
        remove_duplicates: true,
        split_scattered: true,
        merge_overlapping: true,
        split_alpha: true,
        ..RepairSettings::default()
    }
}

/// Why [`optimize`] gave no scene.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum OptimizeError {
    /// No triangle of the input can be hit by a ray.
    #[error("nothing to trace: {}", if *triangles == 0 {
        "the input holds no triangle".to_owned()
    } else {
        format!("none of the {triangles} triangles has three finite, distinct corners that span an area")
    })]
    NothingToTrace {
        /// Triangles in the input.
        triangles: usize,
    },
}

/// Figures of one workload.
#[derive(Clone, Debug, Default, Serialize, JsonSchema)]
pub struct RayFigures {
    /// Rays traced.
    pub rays: usize,
    /// Ray–box tests per ray.
    pub box_tests_per_ray: f64,
    /// Ray–triangle tests per ray (single triangles).
    pub tri_tests_per_ray: f64,
    /// Ray–pair tests per ray (one test covers both triangles of a pair).
    pub pair_tests_per_ray: f64,
    /// Millions of rays per second, median of the alternating rounds.
    pub mrays_per_s: f64,
}

/// One side of the measurement: the three workloads and the BVH.
#[derive(Clone, Debug, Default, Serialize, JsonSchema)]
pub struct Figures {
    /// Camera rays, closest hit.
    pub primary: RayFigures,
    /// One diffuse bounce per primary hit, closest hit.
    pub diffuse: RayFigures,
    /// Occlusion toward a point light per primary hit.
    pub shadow: RayFigures,
    /// Bytes of the BVH: nodes and leaf primitives, all levels.
    pub bvh_bytes: usize,
    /// Bytes of the geometry a BLAS is built from: 12 per vertex position and 12 per
    /// triangle's indices.
    pub geometry_bytes: usize,
    /// Seconds to build the BVH.
    pub build_seconds: f64,
    /// SAH cost of the BVH (the TLAS for scenes of several instances).
    pub sah_cost: f32,
}

/// Whether the output's primary rays hit the same input triangles as the input's.
#[derive(Clone, Debug, Default, Serialize, JsonSchema)]
pub struct SameHits {
    /// Primary rays compared.
    pub rays: usize,
    /// Rays that hit the same input triangle (or miss in both).
    pub same: usize,
    /// Rays that hit another triangle at the same distance: an edge or vertex shared
    /// by two triangles, or a removed exact copy.
    pub ties: usize,
    /// Rays whose hit differs otherwise.
    pub different: usize,
    /// `(same + ties) / rays`.
    pub share: f64,
}

/// One pairing method's result, summed over geometries.
#[derive(Clone, Debug, Serialize, JsonSchema)]
pub struct Candidate {
    /// `input-order` (the input's consecutive pairs), or the method as `--method`
    /// spells it.
    pub method: String,
    /// Paired triangles over all triangles.
    pub pair_ratio: f64,
}

/// The pairs the first-fit pairers of production tracers find in the output.
#[derive(Clone, Debug, Default, Serialize, JsonSchema)]
pub struct FirstFitCheck {
    /// Share of triangles Embree's quadifier (window of 32, distance ≤ 31) pairs.
    pub embree_window_32: f64,
    /// Share HIPRT's first-fit pairs within warps of 32 consecutive triangles.
    pub wave_32: f64,
    /// Share AMD GPURT's first-fit pairs within waves of 64.
    pub wave_64: f64,
    /// All three find exactly rtmesh's pairs, no more, no fewer.
    pub exact: bool,
    /// Vertices copied so that no two unpaired triangles share an edge by index (a
    /// first-fit pairer would pair them, though rtmesh does not: their shared edge
    /// runs the same way in both, or the greedy order left them apart).
    pub vertices_copied: usize,
}

/// How the output was paired.
#[derive(Clone, Debug, Serialize, JsonSchema)]
pub struct PairingChoice {
    /// The method kept (`mixed` when geometries kept different ones).
    pub method: String,
    /// Every method tried.
    pub candidates: Vec<Candidate>,
    /// What hardware pairers recover.
    pub first_fit: FirstFitCheck,
}

/// One output geometry (BLAS).
#[derive(Clone, Debug, Serialize, JsonSchema)]
pub struct GeometryRow {
    /// Its name in the source, if any.
    pub name: String,
    /// Triangles.
    pub triangles: usize,
    /// Instances placing it.
    pub instances: usize,
    /// SAH cost of its own BVH.
    pub sah_cost: f32,
    /// Bytes of its BVH.
    pub bvh_bytes: usize,
    /// Bytes of its positions and indices.
    pub geometry_bytes: usize,
    /// No alpha-tested triangle: may carry DXR's `GEOMETRY_FLAG_OPAQUE`.
    pub opaque: bool,
}

/// Counts of a per-triangle measure in bins.
#[derive(Clone, Debug, Default, Serialize, JsonSchema)]
pub struct Histogram {
    /// Bin edges, one more than the bins; the last bin also counts larger values.
    pub edges: Vec<f64>,
    /// Values per bin.
    pub counts: Vec<u64>,
}

impl Histogram {
    /// `values` in bins of `edges` (ascending): bin `i` holds `edges[i] ≤ v <
    /// edges[i + 1]`, the last also everything above, the first everything below.
    pub fn of(values: impl Iterator<Item = f64>, edges: Vec<f64>) -> Self {
        let bins = edges.len().saturating_sub(1).max(1);
        let mut counts = vec![0u64; bins];
        for v in values.filter(|v| v.is_finite()) {
            let i = edges.partition_point(|&e| e <= v).saturating_sub(1);
            counts[i.min(bins - 1)] += 1;
        }
        Self { edges, counts }
    }
}

/// The distributions the report draws.
#[derive(Clone, Debug, Default, Serialize, JsonSchema)]
pub struct Histograms {
    /// Box empty space of the output's triangles (1 − area / box projected area).
    pub empty_space: Histogram,
    /// Aspect of the output's triangles (longest edge² / (2 · area)), on a log scale.
    pub aspect: Histogram,
    /// Pair box surface area over the sum of its two triangles' box areas.
    pub pair_box_ratio: Histogram,
}

/// Seconds per step.
#[derive(Clone, Debug, Default, Serialize, JsonSchema)]
pub struct Seconds {
    /// Lint.
    pub lint: f64,
    /// The repairs.
    pub repair: f64,
    /// Preparing for the target (pairing and reordering).
    pub target: f64,
    /// Lint, repairs and target, wall clock (lint and the repairs run side by side):
    /// the preparation, reading, writing and measuring excluded.
    pub prepare: f64,
    /// Running the hardware pairers' first-fit rules on the output (the check, not
    /// part of the preparation).
    pub check: f64,
    /// The before/after measurement.
    pub measure: f64,
}

/// A production tracer's verdict: the input and the output traced by it (Embree, given
/// the input's triangles and the output's pairs as quads), filled in by callers that
/// have one (`rtmesh optimize` built with `--features embree`).
#[derive(Clone, Debug, Serialize, JsonSchema)]
pub struct ProductionCheck {
    /// The tracer and how it was given the scenes.
    pub tracer: String,
    /// Workload kind.
    pub workload: String,
    /// Rays traced.
    pub rays: usize,
    /// Mrays/s on the input.
    pub mrays_before: f64,
    /// Mrays/s on the output.
    pub mrays_after: f64,
    /// The tracer's BVH bytes for the input.
    pub bvh_bytes_before: usize,
    /// For the output.
    pub bvh_bytes_after: usize,
    /// Build seconds for the input.
    pub build_seconds_before: f64,
    /// For the output.
    pub build_seconds_after: f64,
    /// Share of primary rays that hit the same input triangle.
    pub same_hits: f64,
}

/// What [`optimize`] found, did and measured: the JSON of `rtmesh optimize --json`
/// (with the file keys the command adds) and of the HTML report.
#[derive(Clone, Debug, Serialize, JsonSchema)]
pub struct OptimizeReport {
    /// [`SCHEMA`].
    pub schema: u32,
    /// rtmesh's version.
    pub rtmesh_version: String,
    /// What the output is prepared for.
    pub target: Target,
    /// Triangles in the input, over its geometries.
    pub triangles_in: usize,
    /// Triangles in the output.
    pub triangles_out: usize,
    /// Geometries in the input.
    pub geometries_in: usize,
    /// Geometries in the output.
    pub geometries_out: usize,
    /// Instances in the output.
    pub instances_out: usize,
    /// Paired triangles over the output's triangles (0 for other targets).
    pub pair_ratio: f64,
    /// How the output was paired (target pairs).
    pub pairing: Option<PairingChoice>,
    /// Lint's findings on the input.
    pub lint: LintReport,
    /// The repairs made.
    pub repairs: RepairReport,
    /// Same first hits, through the map back to the input (with the measurement).
    pub same_hits: Option<SameHits>,
    /// The input traced (with the measurement).
    pub before: Option<Figures>,
    /// The output traced.
    pub after: Option<Figures>,
    /// The output's geometries.
    pub geometries: Vec<GeometryRow>,
    /// Distributions for the report's pictures.
    pub histograms: Histograms,
    /// Production tracers' figures, where the caller has one (else empty).
    pub production: Vec<ProductionCheck>,
    /// Seconds per step (`seconds` in `rtmesh optimize --json` is the file's whole time).
    pub step_seconds: Seconds,
}

/// The prepared scene with the figures that prove it, and the map back.
#[derive(Clone, Debug)]
pub struct Optimized {
    /// The prepared scene, ready to write.
    pub scene: Scene,
    /// The report.
    pub report: OptimizeReport,
    /// Per output geometry, the input geometry of every output triangle.
    pub input_geometry: Vec<Vec<u32>>,
    /// Per output geometry, the input triangle of every output triangle.
    pub input_triangle: Vec<Vec<u32>>,
    /// Per output geometry, its pairs: output triangles `2k` and `2k + 1` for `k` below.
    pub pair_counts: Vec<usize>,
    /// Per output geometry, for the strips and clusters targets: the length of each
    /// strip or cluster, which lie back to back in the output's triangle order (each
    /// within one primitive). Empty for the other targets.
    pub sequences: Vec<Vec<u32>>,
}

impl Optimized {
    /// The pairs of output geometry `g` as a [`Pairing`] of its triangles.
    pub fn pairing(&self, g: usize) -> Pairing {
        consecutive_pairs(self.scene.meshes[g].triangle_count(), self.pair_counts[g])
    }

    /// [`Self::pairing`] of every output geometry, for [`SceneAccel::build_paired`].
    pub fn pairings(&self) -> Vec<Pairing> {
        (0..self.scene.meshes.len())
            .map(|g| self.pairing(g))
            .collect()
    }
}

/// The pairing `(0, 1), (2, 3), …` of the first `pairs` couples of `triangles`.
fn consecutive_pairs(triangles: usize, pairs: usize) -> Pairing {
    Pairing {
        pairs: (0..pairs as u32).map(|k| [2 * k, 2 * k + 1]).collect(),
        unpaired: (2 * pairs as u32..triangles as u32).collect(),
    }
}

/// Optimize `scene` for `options.target`: the prepared scene and the report.
///
/// ```
/// use rtmesh::optimize::{optimize, OptimizeOptions, Target};
///
/// // Two triangles of a square, given twice (an exact copy) and unwelded.
/// let mut mesh = rtmesh::TriMesh::default();
/// let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
/// for corners in [[0, 1, 2], [0, 2, 3], [0, 1, 2]] {
///     for c in corners {
///         mesh.positions.push(glam::Vec3::from(p[c]));
///     }
///     let v = mesh.positions.len() as u32;
///     mesh.triangles.push([v - 3, v - 2, v - 1]);
/// }
/// mesh.material_ids = vec![0; 3];
/// mesh.alpha_tested = vec![false; 3];
/// let scene = rtmesh::Scene::from_mesh(mesh);
///
/// let options = OptimizeOptions { measure: None, ..OptimizeOptions::default() };
/// let (prepared, report) = optimize(&scene, &options)?;
/// assert_eq!(report.target, Target::Pairs);
/// assert_eq!(report.repairs.removed_duplicates, 1);
/// assert_eq!(report.triangles_out, 2);
/// assert_eq!(report.pair_ratio, 1.0);
/// // The pair shares its edge's vertex indices, as hardware pairers need.
/// let t = &prepared.meshes[0].triangles;
/// assert_eq!(t[0].iter().filter(|v| t[1].contains(v)).count(), 2);
/// # Ok::<(), rtmesh::optimize::OptimizeError>(())
/// ```
pub fn optimize(
    scene: &Scene,
    options: &OptimizeOptions,
) -> Result<(Scene, OptimizeReport), OptimizeError> {
    optimize_mapped(scene, options, &()).map(|o| (o.scene, o.report))
}

/// [`optimize`], with the maps back to the input and the pairs, reporting progress.
pub fn optimize_mapped(
    scene: &Scene,
    options: &OptimizeOptions,
    progress: &dyn Progress,
) -> Result<Optimized, OptimizeError> {
    let mut seconds = Seconds::default();
    progress.add_steps(2);
    progress.message("linting and repairing");
    // Lint reads the input and repair copies it: they run side by side.
    let clock = std::time::Instant::now();
    let ((lint, lint_seconds), ((mut out, map, repairs), repair_seconds)) = rayon::join(
        || {
            let clock = std::time::Instant::now();
            let lint = crate::lint::lint(scene, &LintSettings::default());
            (lint, clock.elapsed().as_secs_f64())
        },
        || {
            let clock = std::time::Instant::now();
            let repaired = crate::repair::repair(scene, &options.repair);
            (repaired, clock.elapsed().as_secs_f64())
        },
    );
    (seconds.lint, seconds.repair) = (lint_seconds, repair_seconds);
    let lint_and_repair = clock.elapsed().as_secs_f64();
    progress.advance(1);
    let traceable: usize = out.meshes.iter().map(traceable_triangles).sum();
    if traceable == 0 {
        return Err(OptimizeError::NothingToTrace {
            triangles: scene.meshes.iter().map(TriMesh::triangle_count).sum(),
        });
    }

    progress.message(&format!("preparing {}", options.target));
    let clock = std::time::Instant::now();
    let mut map = map;
    let (pairing, pair_counts) = match options.target {
        Target::Pairs => {
            let (choice, vertices_copied, counts) = pair_for_hardware(&mut out, &mut map, options);
            (Some((choice, vertices_copied)), counts)
        }
        _ => (None, vec![0; out.meshes.len()]),
    };
    let sequences = match options.target {
        Target::Strips | Target::Clusters => in_sequences(&mut out, &mut map, options.target),
        _ => vec![Vec::new(); out.meshes.len()],
    };
    seconds.target = clock.elapsed().as_secs_f64();
    seconds.prepare = lint_and_repair + seconds.target;
    progress.advance(1);
    let pairing = pairing.map(|(mut choice, vertices_copied)| {
        let clock = std::time::Instant::now();
        choice.first_fit = FirstFitCheck {
            vertices_copied,
            ..first_fit_check(&out, &pair_counts)
        };
        seconds.check = clock.elapsed().as_secs_f64();
        choice
    });

    let triangles_out: usize = out.meshes.iter().map(TriMesh::triangle_count).sum();
    let paired: usize = pair_counts.iter().map(|&k| 2 * k).sum();
    let mut optimized = Optimized {
        report: OptimizeReport {
            schema: SCHEMA,
            rtmesh_version: env!("CARGO_PKG_VERSION").to_owned(),
            target: options.target,
            triangles_in: repairs.triangles_in,
            triangles_out,
            geometries_in: scene.meshes.len(),
            geometries_out: out.meshes.len(),
            instances_out: out.instances.len(),
            pair_ratio: paired as f64 / triangles_out.max(1) as f64,
            pairing,
            lint,
            repairs,
            same_hits: None,
            before: None,
            after: None,
            geometries: Vec::new(),
            histograms: Histograms::default(),
            production: Vec::new(),
            step_seconds: seconds,
        },
        scene: out,
        input_geometry: map.input_geometry,
        input_triangle: map.input_triangle,
        pair_counts,
        sequences,
    };
    optimized.report.histograms = histograms(&optimized);
    // The output's BVH is the one its target traces: pair leaves for pairs.
    let build = BuildSettings::default();
    if options.target == Target::Pairs {
        let after = SceneAccel::build_paired(&optimized.scene, &optimized.pairings(), &build);
        measure_output(scene, &mut optimized, &after, options, progress);
    } else {
        let after = SceneAccel::build(&optimized.scene, &build);
        measure_output(scene, &mut optimized, &after, options, progress);
    }
    Ok(optimized)
}

/// The per-geometry rows of the output's BVH `after`, and with `options.measure` the
/// before/after figures and same hits.
fn measure_output<L: LeafBlock>(
    input: &Scene,
    optimized: &mut Optimized,
    after: &SceneAccel<L>,
    options: &OptimizeOptions,
    progress: &dyn Progress,
) {
    optimized.report.geometries = geometry_rows(&optimized.scene, after);
    if let Some(measure) = &options.measure {
        let clock = std::time::Instant::now();
        let before = SceneAccel::build(input, &BuildSettings::default());
        let (figures_before, figures_after, same) =
            compare(input, &before, optimized, after, measure, progress);
        optimized.report.before = Some(figures_before);
        optimized.report.after = Some(figures_after);
        optimized.report.same_hits = Some(same);
        optimized.report.step_seconds.measure = clock.elapsed().as_secs_f64();
    }
}

/// Put each geometry's triangles in strip order (Strip-RT, default length) or cluster
/// order (grown by Acc(k), default limits), corners as they were, and compose the
/// map; returns each geometry's strip or cluster lengths.
fn in_sequences(
    scene: &mut Scene,
    map: &mut crate::analysis::RepairMap,
    target: Target,
) -> Vec<Vec<u32>> {
    let mut all = Vec::with_capacity(scene.meshes.len());
    for (g, mesh) in scene.meshes.iter_mut().enumerate() {
        let (order, lengths): (Vec<u32>, Vec<u32>) = if target == Target::Strips {
            let strips = crate::strip::sah::stripify(mesh, &Default::default());
            let lengths = (0..strips.len())
                .map(|s| strips.triangles_of(s).len() as u32)
                .collect();
            (strips.triangle_source, lengths)
        } else {
            let clusters = crate::cluster::grow(mesh, &Default::default());
            let lengths = (0..clusters.len())
                .map(|c| clusters.triangles_of(c).len() as u32)
                .collect();
            (clusters.input_triangle, lengths)
        };
        *mesh = mesh.reordered(&order);
        for ids in [&mut map.input_triangle[g], &mut map.input_geometry[g]] {
            *ids = order.iter().map(|&t| ids[t as usize]).collect();
        }
        all.push(lengths);
    }
    all
}

/// Triangles a ray can hit: indices in range, finite corners, non-zero area.
fn traceable_triangles(mesh: &TriMesh) -> usize {
    let v = validate(mesh);
    mesh.triangle_count()
        - v.out_of_range_indices.len()
        - v.non_finite_positions.len()
        - v.repeated_vertices.len()
        - v.zero_area.len()
}

/// Pair every geometry of `scene` by vertex index with the best candidate, reorder it
/// (pairs first) and separate unpaired triangles that share an edge by index; updates
/// the map to the input. Returns the choice (its first-fit check is the caller's), the
/// vertices copied, and each geometry's pair count.
fn pair_for_hardware(
    scene: &mut Scene,
    map: &mut RepairMap,
    options: &OptimizeOptions,
) -> (PairingChoice, usize, Vec<usize>) {
    let fixed = options.pair_method.map(|method| PairSettings {
        method,
        prescan_threshold: None,
        by_index: true,
        ..PairSettings::default()
    });
    let names: Vec<String> = match options.pair_method {
        Some(method) => vec![method.to_string()],
        None => vec![
            "input-order".to_owned(),
            PairMethod::SahMax.to_string(),
            PairMethod::Window(2).to_string(),
        ],
    };
    let mut paired_by = vec![0usize; names.len()];
    let mut kept = Vec::with_capacity(scene.meshes.len());
    let mut pair_counts = Vec::with_capacity(scene.meshes.len());
    let mut vertices_copied = 0;
    for (g, mesh) in scene.meshes.iter_mut().enumerate() {
        let topology = mesh.indices_within_groups();
        let candidates: Vec<Pairing> = match &fixed {
            Some(settings) => vec![pair::pair(&topology, settings).0],
            None => vec![
                pair::prescan(&topology),
                pair::matching::raise(
                    &topology,
                    &pair::greedy::pair_sah(&topology),
                    Some(PairSettings::default().pair_box_limit),
                ),
                pair::window::pair_window(&topology, 2),
            ],
        };
        for (count, candidate) in paired_by.iter_mut().zip(&candidates) {
            *count += candidate.paired_triangles();
        }
        // The most pairs; on a tie the earlier candidate (the input order first).
        let best = (0..candidates.len())
            .max_by_key(|&i| (candidates[i].paired_triangles(), std::cmp::Reverse(i)))
            .expect("a candidate");
        kept.push(best);
        let paired = pair::reorder(mesh, &topology, &candidates[best]);
        for ids in [&mut map.input_triangle[g], &mut map.input_geometry[g]] {
            *ids = paired
                .input_triangle
                .iter()
                .map(|&t| ids[t as usize])
                .collect();
        }
        *mesh = paired.mesh;
        vertices_copied += separate_unpaired(mesh, paired.pair_count);
        pair_counts.push(paired.pair_count);
    }
    let total: usize = scene.meshes.iter().map(TriMesh::triangle_count).sum();
    let method = match kept.first() {
        Some(&first) if kept.iter().all(|&k| k == first) => names[first].clone(),
        Some(_) => "mixed".to_owned(),
        None => names[0].clone(),
    };
    let choice = PairingChoice {
        method,
        candidates: names
            .into_iter()
            .zip(paired_by)
            .map(|(method, paired)| Candidate {
                method,
                pair_ratio: paired as f64 / total.max(1) as f64,
            })
            .collect(),
        first_fit: FirstFitCheck::default(),
    };
    (choice, vertices_copied, pair_counts)
}

/// Give every unpaired triangle (from `2 · pair_count` on) that shares an edge by vertex
/// index with an earlier unpaired one its own copies of its corners, so that a
/// first-fit pairer cannot make a pair rtmesh did not. Returns the vertices copied.
fn separate_unpaired(mesh: &mut TriMesh, pair_count: usize) -> usize {
    let mut claimed = std::collections::HashSet::new();
    let mut copied = 0;
    for t in 2 * pair_count..mesh.triangle_count() {
        let [a, b, c] = mesh.triangles[t];
        let edges = [(a, b), (b, c), (c, a)].map(|(p, q)| (p.min(q), p.max(q)));
        if edges.iter().any(|e| claimed.contains(e)) {
            if mesh.triangles[t]
                .iter()
                .any(|&v| v as usize >= mesh.positions.len())
            {
                continue;
            }
            mesh.triangles[t] = [a, b, c].map(|v| mesh.copy_vertex(v as usize));
            copied += 3;
        } else {
            claimed.extend(edges);
        }
    }
    copied
}

/// Run the first-fit pairers on every primitive of the output (the triangles of one
/// geometry, group and material, in order, as the writers write them).
fn first_fit_check(scene: &Scene, pair_counts: &[usize]) -> FirstFitCheck {
    let mut found = [0usize; 3];
    let mut exact = true;
    let mut total = 0;
    for (mesh, &pairs) in scene.meshes.iter().zip(pair_counts) {
        total += mesh.triangle_count();
        for ids in mesh.primitives().values() {
            let triangles: Vec<[u32; 3]> =
                ids.iter().map(|&t| mesh.triangles[t as usize]).collect();
            let expected: Vec<[u32; 2]> = ids
                .chunks_exact(2)
                .filter(|c| (c[1] as usize) < 2 * pairs && c[0] % 2 == 0 && c[1] == c[0] + 1)
                .map(|c| [c[0], c[1]])
                .collect();
            for (k, pairing) in [
                first_fit::embree_window(&triangles, 31),
                first_fit::waves(&triangles, 32),
                first_fit::waves(&triangles, 64),
            ]
            .iter()
            .enumerate()
            {
                found[k] += pairing.paired_triangles();
                let got: Vec<[u32; 2]> = pairing
                    .pairs
                    .iter()
                    .map(|&[a, b]| [ids[a as usize], ids[b as usize]])
                    .collect();
                exact &= got == expected;
            }
        }
    }
    let share = |n: usize| n as f64 / total.max(1) as f64;
    FirstFitCheck {
        embree_window_32: share(found[0]),
        wave_32: share(found[1]),
        wave_64: share(found[2]),
        exact,
        vertices_copied: 0,
    }
}

/// Histograms of the output's triangles and pairs.
fn histograms(optimized: &Optimized) -> Histograms {
    let shapes: Vec<TriangleShape> = optimized
        .scene
        .meshes
        .iter()
        .flat_map(|m| (0..m.triangle_count()).filter_map(move |t| m.finite_corners(t)))
        .map(TriangleShape::of)
        .filter(|s| s.area > 0.0)
        .collect();
    let mut ratios = Vec::new();
    for (g, mesh) in optimized.scene.meshes.iter().enumerate() {
        for k in 0..optimized.pair_counts[g] {
            let boxes = [2 * k, 2 * k + 1].map(|t| crate::Aabb::from_points(&mesh.corners(t)));
            let sum = boxes[0].half_area() + boxes[1].half_area();
            if sum > 0.0 {
                ratios.push((boxes[0].union(boxes[1]).half_area() / sum) as f64);
            }
        }
    }
    Histograms {
        empty_space: Histogram::of(
            shapes.iter().map(|s| s.empty_space as f64),
            (0..=10).map(|i| i as f64 / 10.0).collect(),
        ),
        aspect: Histogram::of(
            shapes.iter().map(|s| s.aspect as f64),
            [
                1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0, 512.0, 1024.0,
            ]
            .to_vec(),
        ),
        pair_box_ratio: Histogram::of(
            ratios.into_iter(),
            (0..=12).map(|i| 0.5 + i as f64 / 8.0).collect(),
        ),
    }
}

/// The output's geometries with their own BVHs' figures.
fn geometry_rows<L: LeafBlock>(scene: &Scene, accel: &SceneAccel<L>) -> Vec<GeometryRow> {
    scene
        .meshes
        .iter()
        .zip(&accel.blas)
        .enumerate()
        .map(|(g, (mesh, bvh))| {
            let stats = bvh.stats();
            GeometryRow {
                name: mesh.name.clone(),
                triangles: mesh.triangle_count(),
                instances: scene.instances.iter().filter(|i| i.mesh == g).count(),
                sah_cost: stats.sah_cost,
                bvh_bytes: stats.node_bytes + bvh.primitives.len() * std::mem::size_of::<L>(),
                geometry_bytes: geometry_bytes(mesh),
                opaque: mesh.is_opaque(),
            }
        })
        .collect()
}

/// 12 bytes per position and per triangle's indices.
fn geometry_bytes(mesh: &TriMesh) -> usize {
    12 * (mesh.positions.len() + mesh.triangle_count())
}

/// Compare the hits of the same rays through `input` (`before`) and through
/// `optimized`'s scene (`after`, any tracer of it), by the input triangle each came
/// from; another triangle at the same distance (to 1e-6 relative) is a tie.
pub fn same_hits(input: &Scene, optimized: &Optimized, before: &[Hit], after: &[Hit]) -> SameHits {
    let mut same = SameHits {
        rays: before.len(),
        ..SameHits::default()
    };
    for (b, a) in before.iter().zip(after) {
        let source_before = b
            .is_hit()
            .then(|| (input.instances[b.instance as usize].mesh as u32, b.triangle));
        let source_after = a.is_hit().then(|| {
            let g = optimized.scene.instances[a.instance as usize].mesh;
            let t = a.triangle as usize;
            (
                optimized.input_geometry[g][t],
                optimized.input_triangle[g][t],
            )
        });
        if source_before == source_after {
            same.same += 1;
        } else if b.is_hit() && a.is_hit() && (a.t - b.t).abs() <= 1e-6 * b.t.abs().max(1.0) {
            same.ties += 1;
        } else {
            same.different += 1;
        }
    }
    same.share = (same.same + same.ties) as f64 / same.rays.max(1) as f64;
    same
}

/// Trace the input and the output alike: the figures of both, and the same-hits check
/// of the primary rays through the map back to input triangles.
fn compare<L: LeafBlock>(
    input: &Scene,
    before: &SceneAccel,
    optimized: &Optimized,
    after: &SceneAccel<L>,
    options: &MeasureOptions,
    progress: &dyn Progress,
) -> (Figures, Figures, SameHits) {
    const KINDS: [RayKind; 3] = [RayKind::Primary, RayKind::Diffuse, RayKind::Shadow];
    let traced = Traced {
        scene: input,
        before,
        after,
        view: options.view,
    };
    let rows = traced.compare(&KINDS, options.size, options.runs, progress);
    let side = |row: &BeforeAfter, after: bool| RayFigures {
        rays: row.rays,
        box_tests_per_ray: if after { row.box_after } else { row.box_before },
        tri_tests_per_ray: if after { row.tri_after } else { row.tri_before },
        pair_tests_per_ray: if after {
            row.pair_after
        } else {
            row.pair_before
        },
        mrays_per_s: if after {
            row.mrays_after
        } else {
            row.mrays_before
        },
    };
    let figures = |after: bool, stats: AccelStats, bytes: usize| Figures {
        primary: side(&rows[0], after),
        diffuse: side(&rows[1], after),
        shadow: side(&rows[2], after),
        bvh_bytes: stats.bytes,
        geometry_bytes: bytes,
        build_seconds: stats.build_seconds,
        sah_cost: stats.sah_cost,
    };
    let before_figures = figures(
        false,
        before.stats(),
        input.meshes.iter().map(geometry_bytes).sum(),
    );
    let after_figures = figures(
        true,
        after.stats(),
        optimized.scene.meshes.iter().map(geometry_bytes).sum(),
    );
    // Same hits, on the primary rays of the measurement's size.
    let (width, height) = (rows[0].width, rows[0].height);
    let work = Workload::generate_from(
        options.view,
        RayKind::Primary,
        input,
        before,
        (width, height),
        1,
    );
    let hits_before = trace_closest::<NoCounters>(before, &work.rays).0;
    let hits_after = trace_closest::<NoCounters>(after, &work.rays).0;
    let same = same_hits(input, optimized, &hits_before, &hits_after);
    (before_figures, after_figures, same)
}

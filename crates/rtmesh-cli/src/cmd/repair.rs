//! `rtmesh repair`: fix what lint finds, write the result, measure the gain.

use crate::args::{load, parse_size_or_zero};
use crate::output::{emit, refuse_overwriting_input, steps_bar, write_mesh};
use anyhow::{Context, Result};
use rtmesh::lint::LintSettings;
use rtmesh::progress::Progress;
use rtmesh::repair::{Degenerate, RepairReport, RepairSettings};
use rtmesh::trace::measure::{before_after, BeforeAfter};
use serde::Serialize;
use std::path::PathBuf;

/// Fix what lint finds, write the result, and measure the gain with the tracer.
///
/// Welds identical positions, removes degenerate triangles (or with --inactive points
/// them at a NaN vertex, keeping triangle ids), removes copies of earlier triangles
/// (same corners, same winding), with --split-alpha separates alpha-tested from opaque
/// triangles, with --split-scattered puts each far-apart piece of a geometry in its own
/// geometry, and with --split-elongated splits elongated triangles by conforming
/// longest-edge bisection (neighbours across a split edge are split too: no
/// T-junctions, watertight stays watertight) up to --budget times the input
/// triangles, keeping the round that saves the most box and triangle tests of probe
/// rays (none, unless it saves 2%; --force-split keeps every split). Then traces the
/// same primary and diffuse rays through the input and the result, alternating runs,
/// and reports box tests, triangle tests and Mrays/s before and after.
#[derive(clap::Args)]
pub struct Args {
    /// The mesh file, or builtin:NAME.
    mesh: String,
    /// Write the repaired mesh here (.obj, .ply, .gltf, .glb or .stl).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Split elongated triangles.
    #[arg(long)]
    split_elongated: bool,
    /// With --split-elongated: keep every split up to --budget, even where the tracer
    /// measures no gain (for hardware BVH builders, which handle long thin triangles
    /// worse than rtmesh's SAH builder).
    #[arg(long, requires = "split_elongated")]
    force_split: bool,
    /// Split geometries whose pieces are far apart into one geometry (and instance)
    /// per piece.
    #[arg(long)]
    split_scattered: bool,
    /// Split alpha-tested triangles out of geometries that mix them with opaque ones
    /// (the opaque geometry comes first and has no alpha-tested triangle).
    #[arg(long)]
    split_alpha: bool,
    /// Merge geometries whose boxes overlap by half or more (each placed once) into
    /// one, when probe rays need fewer box tests that way.
    #[arg(long)]
    merge_overlapping: bool,
    /// Make degenerate triangles inactive (NaN) instead of removing them.
    #[arg(long)]
    inactive: bool,
    /// Keep triangles that repeat an earlier triangle's corners and winding (by default
    /// they are removed; mirrored copies are always kept).
    #[arg(long)]
    keep_duplicates: bool,
    /// Most output triangles per input triangle when splitting.
    #[arg(long, default_value_t = 2.0)]
    budget: f32,
    /// Box empty space from which a triangle is elongated.
    #[arg(long, default_value_t = 0.8)]
    empty_space: f32,
    /// Aspect from which a triangle is elongated.
    #[arg(long, default_value_t = 25.0)]
    aspect: f32,
    /// Write the map back to the input (JSON: `input_geometry` and `input_triangle`,
    /// each per output geometry and triangle).
    #[arg(long, value_name = "FILE")]
    map: Option<PathBuf>,
    /// Image size of the before/after measurement (0x0 skips it). Where tracing it would
    /// take over 2 s in all (a million copies of one triangle, say), fewer rays are traced.
    #[arg(long, default_value = "512x512", value_parser = parse_size_or_zero)]
    size: (usize, usize),
    /// Timed rounds of the measurement (medians).
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// What `repair` changed and measured.
#[derive(Serialize)]
pub struct Report {
    mesh: String,
    output: Option<PathBuf>,
    #[serde(flatten)]
    repair: RepairReport,
    /// Geometries in the input.
    #[serde(skip)]
    geometries_in: usize,
    /// The before/after measurement (absent with `--size 0x0`).
    trace: Option<Vec<BeforeAfter>>,
    /// Whether splits were asked for but none kept, for want of a measured gain.
    #[serde(skip)]
    splits_declined: bool,
}

/// Repair, write, measure.
pub fn run(args: Args) -> Result<()> {
    let scene = load(&args.mesh)?;
    if let Some(output) = &args.output {
        refuse_overwriting_input(&args.mesh, &scene, output)?;
    }
    let settings = RepairSettings {
        degenerate: if args.inactive {
            Degenerate::Inactive
        } else {
            Degenerate::Remove
        },
        remove_duplicates: !args.keep_duplicates,
        split_elongated: args.split_elongated,
        force_split: args.force_split,
        split_scattered: args.split_scattered,
        split_alpha: args.split_alpha,
        merge_overlapping: args.merge_overlapping,
        triangle_budget: args.budget,
        lint: LintSettings {
            empty_space: args.empty_space,
            aspect: args.aspect,
            ..LintSettings::default()
        },
        ..RepairSettings::default()
    };
    // Repairing and writing; measuring adds its own steps.
    let bar = steps_bar(1 + args.output.is_some() as usize);
    bar.message(&format!("repairing {}", args.mesh));
    let (repaired, maps, repair) = rtmesh::repair::repair(&scene, &settings);
    bar.advance(1);
    if let Some(output) = &args.output {
        bar.message(&format!("writing {}", output.display()));
        write_mesh(&args.mesh, &repaired, output)?;
        bar.advance(1);
    }
    if let Some(path) = &args.map {
        std::fs::write(path, serde_json::to_string(&maps)?)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    let trace =
        (args.size.0 > 0).then(|| before_after(&scene, &repaired, args.size, args.runs, &bar));
    bar.0.finish_and_clear();
    let splits_declined = args.split_elongated
        && !args.force_split
        && repair.split_edges == 0
        && repair.elongated_before > 0;
    let report = Report {
        mesh: args.mesh,
        output: args.output,
        geometries_in: scene.meshes.len(),
        repair,
        trace,
        splits_declined,
    };
    emit(&report, args.json, print)
}

fn print(report: &Report) {
    let r = &report.repair;
    println!(
        "{}: {} → {} triangles; {} vertices welded, {} degenerate removed, {} made inactive, {} duplicates removed, {} edges split{}",
        report.mesh, r.triangles_in, r.triangles_out, r.merged_vertices,
        r.removed_degenerate, r.made_inactive, r.removed_duplicates, r.split_edges,
        if r.budget_reached {
            " (budget reached)"
        } else if report.splits_declined {
            " (no round of splits saved 2% of the probe rays' box and triangle tests; --force-split keeps them anyway)"
        } else {
            ""
        }
    );
    println!(
        "  geometries   {} → {} ({} scattered geometries split into pieces, {} into opaque and alpha-tested)",
        report.geometries_in, r.geometries_out, r.split_geometries, r.split_alpha_geometries
    );
    println!(
        "  opaque       {} of {} geometries have no alpha-tested triangle: flag them opaque (DXR GEOMETRY_FLAG_OPAQUE, Vulkan GEOMETRY_OPAQUE_BIT) so no any-hit shader runs",
        r.opaque_geometries.len(),
        r.geometries_out
    );
    if r.merged_groups > 0 {
        println!(
            "  merged       {} groups of overlapping geometries",
            r.merged_groups
        );
    }
    println!(
        "  elongated    {} → {} triangles, wasted box area {:.4} → {:.4}",
        r.elongated_before, r.elongated_after, r.wasted_box_area_before, r.wasted_box_area_after
    );
    for row in report.trace.iter().flatten() {
        println!(
            "  {:<8} box/ray {:.2} → {:.2}, tri/ray {:.2} → {:.2}, Mrays/s {:.2} → {:.2} ({:+.1}%)",
            row.workload,
            row.box_before,
            row.box_after,
            row.tri_before,
            row.tri_after,
            row.mrays_before,
            row.mrays_after,
            100.0 * (row.mrays_after / row.mrays_before - 1.0)
        );
    }
    if let Some(output) = &report.output {
        println!("wrote {}", output.display());
    }
}

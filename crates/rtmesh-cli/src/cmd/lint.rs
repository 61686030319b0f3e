//! `rtmesh lint`: what makes a mesh slow to ray trace.

use crate::args::load;
use crate::output::emit;
use anyhow::Result;
use rtmesh::lint::{LintReport, LintSettings};
use serde::Serialize;

/// Find what makes a mesh slow to ray trace (after NVIDIA's advice).
///
/// Per geometry: elongated triangles (box mostly empty space, or long and thin), fans,
/// degenerate, inactive (NaN), infinite and out-of-range triangles, duplicate and
/// back-to-back (mirrored) triangles, alpha-tested triangles mixed with opaque ones,
/// geometries whose pieces are far apart, and geometries whose boxes overlap; over the
/// scene, 128² probe rays that cross several alpha-tested triangles or a stack of
/// parallel triangles at one depth. Each finding has a count, the worst offenders'
/// ids, a severity, figures and one line of advice (the text lists 10 findings of a
/// kind and counts the rest; --json lists all). The grouping findings add the
/// two-level SAH cost (TLAS over instances, each charged its BLAS's cost) of the scene
/// as it is and as `repair --split-scattered --merge-overlapping` would regroup it: an
/// estimate, which repair checks with probe rays before it keeps a regrouping.
#[derive(clap::Args)]
pub struct Args {
    /// The mesh file, or builtin:NAME.
    mesh: String,
    /// Box empty space (0..1) from which a triangle is elongated.
    #[arg(long, default_value_t = 0.8)]
    empty_space: f32,
    /// Aspect (longest edge² / twice the area) from which a triangle is elongated.
    #[arg(long, default_value_t = 25.0)]
    aspect: f32,
    /// Another pose of the same mesh (same triangles, moved vertices); repeat for more.
    /// Adds the rebuild-or-refit finding: SAH cost of the rest pose's BVH refitted to
    /// each pose over a BVH rebuilt for it.
    #[arg(long, value_name = "MESH")]
    pose: Vec<String>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// What `lint` found.
#[derive(Serialize)]
pub struct Report {
    mesh: String,
    #[serde(flatten)]
    lint: LintReport,
}

/// Lint, with the poses if given.
pub fn run(args: Args) -> Result<()> {
    let scene = load(&args.mesh)?;
    let settings = LintSettings {
        empty_space: args.empty_space,
        aspect: args.aspect,
        ..LintSettings::default()
    };
    let mut lint = rtmesh::lint::lint(&scene, &settings);
    if !args.pose.is_empty() {
        let poses = args
            .pose
            .iter()
            .map(|p| load(p))
            .collect::<Result<Vec<_>>>()?;
        let finding = rtmesh::lint::lint_deforming(&scene, &poses)
            .map_err(|e| anyhow::anyhow!("--pose: {e}"))?;
        lint.findings.push(finding);
    }
    let report = Report {
        mesh: args.mesh,
        lint,
    };
    emit(&report, args.json, |r| print(&r.mesh, &r.lint))
}

/// How many findings of one kind `rtmesh lint` prints (a scene of many geometries or
/// placements may have thousands).
const PRINTED_PER_KIND: usize = 10;

/// The text form of `report` for the mesh called `name`.
fn print(name: &str, report: &LintReport) {
    println!(
        "{name}: {} triangles in {} geometries, linted in {:.3} s",
        report.triangles, report.geometries, report.seconds
    );
    println!(
        "  box empty space  p50 {:.2}  p90 {:.2}  p99 {:.2}  max {:.2}",
        report.empty_space.p50,
        report.empty_space.p90,
        report.empty_space.p99,
        report.empty_space.max
    );
    println!(
        "  aspect           p50 {:.1}  p90 {:.1}  p99 {:.1}  max {:.1}",
        report.aspect.p50, report.aspect.p90, report.aspect.p99, report.aspect.max
    );
    if report.findings.is_empty() {
        println!("  no findings");
    }
    // Findings of one kind past the first few are counted, not printed (`--json` has all).
    let mut shown: std::collections::BTreeMap<&str, usize> = Default::default();
    for f in &report.findings {
        let seen = shown.entry(f.kind).or_default();
        *seen += 1;
        if *seen > PRINTED_PER_KIND {
            continue;
        }
        let figures: Vec<String> = f
            .figures
            .iter()
            .map(|(k, v)| format!("{k} {}", figure_text(*v)))
            .collect();
        let figures = if figures.is_empty() {
            String::new()
        } else {
            format!(" ({})", figures.join(", "))
        };
        println!(
            "  [{:?}] geometry {} {}: {}{figures}; worst {:?}",
            f.severity, f.geometry, f.kind, f.count, f.worst
        );
        println!("      {}", f.advice);
    }
    for (kind, &count) in &shown {
        if count > PRINTED_PER_KIND {
            let more = count - PRINTED_PER_KIND;
            println!("  ... and {more} more {kind} findings (--json lists every one)");
        }
    }
}

/// A lint figure as text: whole numbers without decimals, small ones in scientific
/// notation, the rest to three decimals.
fn figure_text(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{v:.0}")
    } else if v.abs() >= 0.01 {
        format!("{v:.3}")
    } else {
        format!("{v:.2e}")
    }
}

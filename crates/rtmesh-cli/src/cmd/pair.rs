//! `rtmesh pair`: triangles that share an edge, paired for tracers that test two at a
//! time.

use crate::args::load;
use crate::output::{emit, refuse_overwriting_input, write_mesh};
use anyhow::Result;
use rtmesh::pair::{PairMethod, PairReport, PairSettings};
use serde::Serialize;
use std::path::PathBuf;

/// Pair triangles that share an edge, for tracers that test triangles two at a time.
///
/// Welds identical positions first (so split vertices still share edges), pairs each
/// geometry, and with -o writes the mesh with every pair as two consecutive
/// triangles: the quad (v0, v1, v2, v3) as (v0, v1, v2) and (v2, v1, v3), windings
/// kept, then the unpaired triangles. Methods: sah (Aman & Fenney's greedy scan by
/// edge box area, the default), sah-compressed (the same keyed by position, for
/// triangle soups), window:N (the paper's baseline over the input order), sah-max (sah
/// raised by augmenting paths, never pairing across an edge whose pair box is much
/// worse than the two triangles' boxes: see --pair-box-limit), max (a maximum
/// matching, no box limit).
#[derive(clap::Args)]
pub struct Args {
    /// The mesh file, or builtin:NAME.
    mesh: String,
    /// Write the paired mesh here (.obj, .ply, .gltf, .glb or .stl).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// sah, sah-compressed, window:N, sah-max or max.
    #[arg(long, default_value = "sah")]
    method: PairMethod,
    /// Optimise even when the input order is already paired (the pre-scan skips the
    /// work when consecutive triangles pair at 85% or more).
    #[arg(long)]
    no_prescan: bool,
    /// sah-max: largest pair box area over the sum of the two triangles' box areas
    /// (1.0: a pair's box test costs no more, by SAH, than the two triangles'; the
    /// default lets it grow by a quarter, which pairs 99.99% of the dragon).
    #[arg(long, default_value_t = 1.25)]
    pair_box_limit: f32,
    /// Pair only across edges whose two vertex indices are shared (same attributes
    /// too), not only positions: no pair crosses a UV seam, and hardware pairers that
    /// match indices (Embree, HIPRT, GPURT) find every pair. `optimize` does this.
    #[arg(long)]
    by_index: bool,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// What `pair` did.
#[derive(Serialize)]
pub struct Report {
    mesh: String,
    output: Option<PathBuf>,
    #[serde(flatten)]
    pairing: PairReport,
}

/// Pair, write if asked, report.
pub fn run(args: Args) -> Result<()> {
    let mut scene = load(&args.mesh)?;
    if let Some(output) = &args.output {
        refuse_overwriting_input(&args.mesh, &scene, output)?;
    }
    let settings = PairSettings {
        method: args.method,
        prescan_threshold: (!args.no_prescan).then_some(0.85),
        pair_box_limit: args.pair_box_limit,
        by_index: args.by_index,
    };
    let pairing = rtmesh::pair::pair_scene(&mut scene, &settings);
    if let Some(output) = &args.output {
        write_mesh(&args.mesh, &scene, output)?;
    }
    let report = Report {
        mesh: args.mesh,
        output: args.output,
        pairing,
    };
    emit(&report, args.json, print)
}

fn print(report: &Report) {
    let p = &report.pairing;
    println!(
        "{}: {} of {} triangles paired ({:.2}%) by {} in {:.4} s{}",
        report.mesh,
        p.paired_triangles,
        p.triangles,
        100.0 * p.pair_ratio,
        p.method,
        p.seconds,
        if p.prescan_skipped {
            " (input already paired: order kept)"
        } else {
            ""
        }
    );
    if let Some(output) = &report.output {
        println!(
            "wrote {} (pairs first, then unpaired triangles)",
            output.display()
        );
    }
}

//! `rtmesh demo`: rtmesh on the built-in scenes.

use crate::output::emit_list;
use anyhow::Result;
use rtmesh::bvh::BuildSettings;
use rtmesh::lint::{LintReport, LintSettings};
use rtmesh::mesh::MeshInfo;
use rtmesh::pair::{PairMethod, Pairing};
use rtmesh::repair::{RepairReport, RepairSettings};
use rtmesh::trace::accel::AccelStats;
use rtmesh::trace::intersect::IntersectorKind;
use rtmesh::trace::measure::{before_after, measure, measure_packets_by_kind, BeforeAfter};
use rtmesh::trace::{RayKind, SceneAccel, TraceRun, Workload};
use serde::Serialize;
use std::collections::BTreeMap;

/// Run rtmesh on the built-in scenes: info, BVH, traced speed, packets, pairing, lint
/// and repair.
///
/// Per built-in scene: mesh info, the BVH, primary and diffuse rays at 512x512, 8x8
/// packets against single rays, the share of triangles SAH pairing pairs, lint's
/// findings, and repair (split elongated and scattered, merge overlapping) with box
/// tests per ray before and after at 256x256.
#[derive(clap::Args)]
pub struct Args {
    /// Print a JSON array (one object per scene) instead of text.
    #[arg(long)]
    json: bool,
}

/// One built-in scene's figures.
#[derive(Serialize)]
pub struct Report {
    scene: &'static str,
    info: MeshInfo,
    bvh: AccelStats,
    /// Primary and diffuse rays, single-ray traversal.
    trace: BTreeMap<&'static str, TraceRun>,
    /// The primary rays in 8x8 packets.
    packets_8x8: TraceRun,
    sah_pair_ratio: f64,
    lint: LintReport,
    repair: Repair,
    /// Geometries in the scene.
    #[serde(skip)]
    geometries: usize,
}

/// Repair's report and its measurement.
#[derive(Serialize)]
struct Repair {
    report: RepairReport,
    trace: Vec<BeforeAfter>,
}

/// Every built-in scene, one after the other.
pub fn run(args: Args) -> Result<()> {
    let mut reports = Vec::new();
    for &name in &rtmesh::scenes::NAMES {
        let report = scene_report(name);
        if !args.json {
            print(&report);
        }
        reports.push(report);
    }
    if args.json {
        emit_list(&reports)
    } else {
        println!("\nnext: rtmesh render builtin:blob -o blob.png --heatmap boxes; rtmesh lint MESH; rtmesh repair MESH --split-elongated; rtmesh bench packets MESH...");
        Ok(())
    }
}

fn scene_report(name: &'static str) -> Report {
    let scene = rtmesh::scenes::by_name(name).expect("built-in");
    let accel = SceneAccel::build(&scene, &BuildSettings::default());
    let trace: BTreeMap<_, _> = [RayKind::Primary, RayKind::Diffuse]
        .into_iter()
        .map(|kind| {
            let work = Workload::generate(kind, &scene, &accel, 512, 512, 1);
            (kind.name(), measure(&accel, &work, 3))
        })
        .collect();
    // Packets of 8x8 camera rays on the same primary rays.
    let (grouped, starts) =
        Workload::generate(RayKind::Primary, &scene, &accel, 512, 512, 1).grouped(8);
    let packets_8x8 =
        measure_packets_by_kind(IntersectorKind::MollerPacket, &accel, &grouped, &starts, 3);
    let (_, pairings) = rtmesh::pair::weld_and_pair(&scene, PairMethod::Sah);
    let paired: usize = pairings.iter().map(Pairing::paired_triangles).sum();
    let settings = RepairSettings {
        split_elongated: true,
        split_scattered: true,
        merge_overlapping: true,
        ..RepairSettings::default()
    };
    let (repaired, _, repair) = rtmesh::repair::repair(&scene, &settings);
    Report {
        scene: name,
        info: MeshInfo::of(&scene),
        bvh: accel.stats(),
        trace,
        packets_8x8,
        sah_pair_ratio: paired as f64 / scene.instanced_triangle_count().max(1) as f64,
        lint: rtmesh::lint::lint(&scene, &LintSettings::default()),
        repair: Repair {
            report: repair,
            trace: before_after(&scene, &repaired, (256, 256), 1, &()),
        },
        geometries: scene.meshes.len(),
    }
}

fn print(report: &Report) {
    super::info::print(&format!("builtin:{}", report.scene), &report.info);
    let bvh = &report.bvh;
    println!(
        "  bvh                {:>10} nodes, SAH {:.2}, {:.0} bytes/triangle, built in {:.3} s",
        bvh.nodes, bvh.sah_cost, bvh.bytes_per_triangle, bvh.build_seconds
    );
    for kind in [RayKind::Primary, RayKind::Diffuse] {
        let run = &report.trace[kind.name()];
        println!(
            "  trace {:<12} {:>10.2} Mrays/s, {:.1} box and {:.1} triangle tests per ray, {} of {} rays hit",
            kind.name(), run.mrays_per_s, run.box_tests_per_ray, run.tri_tests_per_ray, run.hits, run.rays
        );
    }
    let primary = &report.trace[RayKind::Primary.name()];
    println!(
        "  8x8 packets        {:>10.2} Mrays/s ({:.2}x single rays), {:.1} box tests per ray",
        report.packets_8x8.mrays_per_s,
        report.packets_8x8.mrays_per_s / primary.mrays_per_s.max(1e-9),
        report.packets_8x8.box_tests_per_ray
    );
    println!(
        "  sah pairing        {:>9.2}% of triangles paired",
        100.0 * report.sah_pair_ratio
    );
    let found: Vec<String> = report
        .lint
        .findings
        .iter()
        .map(|f| format!("{} ({})", f.kind, f.count))
        .collect();
    println!(
        "  lint               {}",
        if found.is_empty() {
            "no findings".to_owned()
        } else {
            found.join(", ")
        }
    );
    let repair = &report.repair.report;
    println!(
        "  repair             {} → {} triangles, {} → {} geometries{}",
        repair.triangles_in,
        repair.triangles_out,
        report.geometries,
        repair.geometries_out,
        report
            .repair
            .trace
            .iter()
            .map(|m| format!(
                ", {} box/ray {:.1} → {:.1}",
                m.workload, m.box_before, m.box_after
            ))
            .collect::<String>()
    );
}

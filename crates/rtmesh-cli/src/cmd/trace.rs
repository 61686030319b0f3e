//! `rtmesh trace`: a ray workload through rtmesh's BVH, with speed and work per ray.

use crate::args::{load, parse_size, CameraArg, Intersector, Rays};
use crate::output::emit;
use anyhow::{Context, Result};
use clap::ValueEnum;
use rtmesh::bvh::BuildSettings;
use rtmesh::pair::PairMethod;
use rtmesh::trace::accel::AccelStats;
use rtmesh::trace::intersect::IntersectorKind;
use rtmesh::trace::measure::{measure, measure_by_kind, measure_packets_by_kind, with_threads};
use rtmesh::trace::strip::{Inside, StripAccel};
use rtmesh::trace::{RayKind, SceneAccel, TraceRun, Workload};
use serde::Serialize;

/// Leaf primitives of the BVH.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Leaf {
    /// 4 triangles per SIMD test.
    Tri,
    /// 4 triangle pairs per SIMD test, paired by --pair-method after welding.
    Pair,
    /// Strip-RT strips (default settings), traced directly: a BVH over the strips, a
    /// stored 4-bit box per four triangles of a strip, and the blocks a ray enters
    /// decoded and tested four at a time (the scene flattened and welded).
    Strip,
}

/// Ray packets for `trace`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Packets {
    /// 8x8 for primary and shadow rays, single rays for diffuse ones.
    Auto,
    /// Single rays.
    None,
    /// 2×2 pixels.
    #[value(name = "2x2")]
    Two,
    /// 4×4 pixels.
    #[value(name = "4x4")]
    Four,
    /// 8×8 pixels.
    #[value(name = "8x8")]
    Eight,
}

impl Packets {
    /// Rays per packet side for rays of `kind` (auto: 8 for coherent rays through
    /// triangle leaves, `triangle_leaves`, single rays otherwise).
    pub fn side(self, kind: RayKind, triangle_leaves: bool) -> usize {
        match self {
            Packets::Auto if kind != RayKind::Diffuse && triangle_leaves => 8,
            Packets::Auto | Packets::None => 1,
            Packets::Two => 2,
            Packets::Four => 4,
            Packets::Eight => 8,
        }
    }
}

/// Trace a ray workload through rtmesh's BVH and report speed and work per ray.
///
/// Builds an 8-wide binned-SAH BVH (two levels for scenes with instances), traces the
/// workload `--runs` times with counters off and reports the median, then once with
/// counters on for box and triangle tests per ray.
#[derive(clap::Args)]
pub struct Args {
    /// The mesh file, or builtin:NAME.
    mesh: String,
    /// Which rays.
    #[arg(long, value_enum, default_value = "primary")]
    rays: Rays,
    /// Image size WIDTHxHEIGHT (one primary ray per pixel).
    #[arg(long, default_value = "1024x1024", value_parser = parse_size)]
    size: (usize, usize),
    #[command(flatten)]
    camera: CameraArg,
    /// Threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Timed runs; the median is reported.
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// Leaf primitives.
    #[arg(long, value_enum, default_value = "tri")]
    leaf: Leaf,
    /// How to pair for --leaf pair: sah, sah-compressed, window:N, sah-max, max.
    #[arg(long, default_value = "sah")]
    pair_method: PairMethod,
    /// Ray packets of neighbouring pixels. A packet's rays traverse the BVH together: a
    /// frustum test per node for the whole packet, then the exact test per ray, and for
    /// camera packets (one origin) the intersector's shared terms once per packet.
    /// They pay for coherent rays (primary; shadow rays converging on one light) and
    /// stop paying for diffuse bounces (origins and directions scattered), so auto
    /// picks 8x8 for primary and shadow rays and single rays for diffuse ones (see
    /// `rtmesh bench packets`).
    #[arg(long, value_enum, default_value = "auto")]
    packet: Packets,
    /// Ray-triangle test in the leaves. Default: moller-packet for packets (its shared
    /// terms are computed once per packet), the built-in Möller-Trumbore with
    /// precomputed edges for single rays.
    #[arg(long, value_enum)]
    intersector: Option<Intersector>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// What `trace` measured.
#[derive(Serialize)]
pub struct Report {
    mesh: String,
    ray_kind: &'static str,
    threads: usize,
    /// `NxN` or `none`.
    packet: String,
    intersector: &'static str,
    #[serde(flatten)]
    run: TraceRun,
    bvh: AccelStats,
}

/// Build, trace, report.
pub fn run(args: Args) -> Result<()> {
    let kind = RayKind::from(args.rays);
    let side = args.packet.side(kind, args.leaf == Leaf::Tri);
    let intersector = args.intersector.map(IntersectorKind::from);
    if args.leaf != Leaf::Tri && (side > 1 || intersector.is_some()) {
        anyhow::bail!("--packet and --intersector work with --leaf tri only");
    }
    let scene = load(&args.mesh)?;
    let (width, height) = args.size;
    let (bvh, run, threads) = with_threads(args.threads, || -> Result<_> {
        let triangles = SceneAccel::build(&scene, &BuildSettings::default());
        let work = Workload::generate_from(
            args.camera.view,
            kind,
            &scene,
            &triangles,
            (width, height),
            1,
        );
        let (stats, run) = if args.leaf == Leaf::Strip {
            let accel = strip_accel(&scene)
                .with_context(|| format!("{}: cannot flatten the scene", args.mesh))?;
            (accel.0, measure(&accel.1, &work, args.runs))
        } else if args.leaf == Leaf::Pair {
            let (welded, pairings) = rtmesh::pair::weld_and_pair(&scene, args.pair_method);
            let pairs = SceneAccel::build_paired(&welded, &pairings, &BuildSettings::default());
            (pairs.stats(), measure(&pairs, &work, args.runs))
        } else if side > 1 {
            let (packed, starts) = work.grouped(side);
            let kind = intersector.unwrap_or(IntersectorKind::MollerPacket);
            let run = measure_packets_by_kind(kind, &triangles, &packed, &starts, args.runs);
            (triangles.stats(), run)
        } else if let Some(kind) = intersector {
            (
                triangles.stats(),
                measure_by_kind(kind, &triangles, &work, args.runs),
            )
        } else {
            (triangles.stats(), measure(&triangles, &work, args.runs))
        };
        Ok((stats, run, rayon::current_num_threads()))
    })?;
    let report = Report {
        mesh: args.mesh,
        ray_kind: kind.name(),
        threads,
        packet: if side > 1 {
            format!("{side}x{side}")
        } else {
            "none".to_owned()
        },
        intersector: match (intersector, side > 1) {
            (Some(kind), _) => kind.name(),
            (None, true) => IntersectorKind::MollerPacket.name(),
            (None, false) => "builtin",
        },
        run,
        bvh,
    };
    emit(&report, args.json, print)
}

/// The scene as Strip-RT strips traced directly, and the figures of its hierarchy.
fn strip_accel(scene: &rtmesh::Scene) -> Result<(AccelStats, StripAccel)> {
    let mesh = rtmesh::mesh::weld_exact(&scene.flatten()?).mesh;
    let strips = rtmesh::strip::sah::stripify(&mesh, &Default::default());
    let accel = StripAccel::build(&mesh.positions, &strips, 1, Inside::Quantized)
        .expect("the default maximum length is within the tracer's");
    let bvh = accel.stats();
    let bytes = accel.hierarchy_bytes() + accel.topology_bytes() + accel.position_bytes();
    let stats = AccelStats {
        nodes: bvh.nodes,
        leaves: bvh.leaves,
        sah_cost: bvh.sah_cost,
        build_seconds: accel.build_seconds(),
        bytes,
        bytes_per_triangle: bytes as f64 / mesh.triangle_count().max(1) as f64,
        depth: bvh.depth,
    };
    Ok((stats, accel))
}

fn print(report: &Report) {
    let (run, bvh) = (&report.run, &report.bvh);
    println!(
        "{}: {} {} rays on {} threads, packets {}, intersector {}",
        report.mesh, run.rays, report.ray_kind, report.threads, report.packet, report.intersector
    );
    println!(
        "  speed        {:>10.2} Mrays/s  (median of {} runs: {:.4} s)",
        run.mrays_per_s,
        run.all_seconds.len(),
        run.seconds
    );
    println!(
        "  per ray      {:>10.2} box tests, {:.2} triangle tests, {:.2} pair tests, {:.2} nodes",
        run.box_tests_per_ray, run.tri_tests_per_ray, run.pair_tests_per_ray, run.nodes_per_ray
    );
    println!(
        "  hits         {:>10}  (checksum {:016x})",
        run.hits, run.hit_checksum
    );
    println!(
        "  bvh          {:>10} nodes, {} leaves, SAH {:.2}, depth {}, {:.1} MB ({:.1} bytes/triangle), built in {:.3} s",
        bvh.nodes, bvh.leaves, bvh.sah_cost, bvh.depth, bvh.bytes as f64 / 1e6, bvh.bytes_per_triangle, bvh.build_seconds
    );
}

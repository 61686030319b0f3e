//! `rtmesh`: the command-line face of the rtmesh library. Each subcommand is a thin
//! wrapper: parse arguments, read the mesh (with a progress bar), call the library,
//! print a human summary or, with `--json`, one JSON object on stdout.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use rtmesh::bvh::BuildSettings;
use rtmesh::lint::{LintReport, LintSettings};
use rtmesh::mesh::MeshInfo;
use rtmesh::pair::{PairMethod, PairReport, PairSettings, Pairing};
use rtmesh::render::HeatmapMetric;
use rtmesh::repair::{Degenerate, RepairSettings};
use rtmesh::trace::compare::{CompareSettings, Comparison};
use rtmesh::trace::intersect::{Intersector, IntersectorKind, Simd, TriangleSoa, WithIntersector};
use rtmesh::trace::{workload, RayKind, SceneAccel, Workload};
use rtmesh::Scene;
use std::path::{Path, PathBuf};

/// Prepare triangle meshes for ray tracing and measure the gain.
///
/// MESH arguments are files (.obj, .ply, .gltf, .glb) or a built-in scene written
/// `builtin:NAME` (blob, grid, cylinder, room).
#[derive(Parser)]
#[command(name = "rtmesh", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Counts, bounds and topology of a mesh (after welding identical positions).
    ///
    /// Prints vertices, triangles, welded vertices, bounds, edge-connected components,
    /// boundary and non-manifold edges, and the broken triangles found.
    Info {
        /// The mesh file, or builtin:NAME.
        mesh: String,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Convert between formats, keeping triangle order (format from the extension).
    ///
    /// OBJ and PLY hold one level, so instances are flattened; glTF/GLB keep them.
    Convert {
        /// Input mesh file, or builtin:NAME.
        input: String,
        /// Output file: .obj, .ply (binary), .gltf (with .bin beside it) or .glb.
        output: PathBuf,
        /// Merge vertices closer than this distance (0 = identical positions only).
        #[arg(long, value_name = "DISTANCE")]
        weld: Option<f32>,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Pair triangles that share an edge, for tracers that test triangles two at a time.
    ///
    /// Welds identical positions first (so split vertices still share edges), pairs
    /// each geometry, and with -o writes the mesh with every pair as two consecutive
    /// triangles: the quad (v0, v1, v2, v3) as (v0, v1, v2) and (v2, v1, v3), windings
    /// kept, then the unpaired triangles. Methods: sah (Aman & Fenney's greedy scan by
    /// edge box area, the default), sah-compressed (the same keyed by position, for
    /// triangle soups), window:N (the paper's baseline over the input order), sah-max
    /// (sah raised by augmenting paths, never pairing across an edge whose pair box is
    /// much worse than the two triangles' boxes: see --pair-box-limit), max (a maximum
    /// matching, no box limit).
    Pair {
        /// The mesh file, or builtin:NAME.
        mesh: String,
        /// Write the paired mesh here (.obj, .ply, .gltf or .glb).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// sah, sah-compressed, window:N, sah-max or max.
        #[arg(long, default_value = "sah")]
        method: PairMethod,
        /// Optimise even when the input order is already paired (the pre-scan skips
        /// the work when consecutive triangles pair at 85% or more).
        #[arg(long)]
        no_prescan: bool,
        /// sah-max: largest pair box area over the sum of the two triangles' box areas
        /// (1.0: a pair's box test costs no more, by SAH, than the two triangles'; the
        /// default lets it grow by a quarter, which pairs 99.99% of the dragon).
        #[arg(long, default_value_t = 1.25)]
        pair_box_limit: f32,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Find what makes a mesh slow to ray trace (after NVIDIA's advice).
    ///
    /// Per geometry: elongated triangles (box mostly empty space, or long and thin),
    /// fans, degenerate, inactive (NaN), infinite and out-of-range triangles, duplicate
    /// and back-to-back (mirrored) triangles, alpha-tested triangles mixed with opaque
    /// ones, geometries whose pieces are far apart, and geometries whose boxes overlap;
    /// over the scene, 128² probe rays that cross several alpha-tested triangles or a
    /// stack of parallel triangles at one depth. Each finding has a count, the worst
    /// offenders' ids, a severity, figures and one line of advice (the text lists 10
    /// findings of a kind and counts the rest; --json lists all). The grouping findings
    /// add the two-level SAH cost (TLAS over instances, each charged its BLAS's cost) of
    /// the scene as it is and as `repair --split-scattered --merge-overlapping` would
    /// regroup it: an estimate, which repair checks with probe rays before it keeps a
    /// regrouping.
    Lint {
        /// The mesh file, or builtin:NAME.
        mesh: String,
        /// Box empty space (0..1) from which a triangle is elongated.
        #[arg(long, default_value_t = 0.8)]
        empty_space: f32,
        /// Aspect (longest edge² / twice the area) from which a triangle is elongated.
        #[arg(long, default_value_t = 25.0)]
        aspect: f32,
        /// Another pose of the same mesh (same triangles, moved vertices); repeat for
        /// more. Adds the rebuild-or-refit finding: SAH cost of the rest pose's BVH
        /// refitted to each pose over a BVH rebuilt for it.
        #[arg(long, value_name = "MESH")]
        pose: Vec<String>,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Fix what lint finds, write the result, and measure the gain with the tracer.
    ///
    /// Welds identical positions, removes degenerate triangles (or with --inactive
    /// points them at a NaN vertex, keeping triangle ids), removes copies of earlier
    /// triangles (same corners, same winding), with --split-alpha separates
    /// alpha-tested from opaque triangles, with --split-scattered puts
    /// each far-apart piece of a geometry in its own geometry, and with --split-elongated
    /// splits elongated triangles by conforming longest-edge bisection (neighbours
    /// across a split edge are split too: no T-junctions, watertight stays watertight)
    /// up to --budget times the input triangles, keeping the round that saves the most
    /// box and triangle tests of probe rays (none, unless it saves 2%; --force-split
    /// keeps every split). Then traces the same primary and
    /// diffuse rays through the input and the result, alternating runs, and reports box
    /// tests, triangle tests and Mrays/s before and after.
    Repair {
        /// The mesh file, or builtin:NAME.
        mesh: String,
        /// Write the repaired mesh here (.obj, .ply, .gltf or .glb).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Split elongated triangles.
        #[arg(long)]
        split_elongated: bool,
        /// With --split-elongated: keep every split up to --budget, even where the
        /// tracer measures no gain (for hardware BVH builders, which handle long thin
        /// triangles worse than rtmesh's SAH builder).
        #[arg(long, requires = "split_elongated")]
        force_split: bool,
        /// Split geometries whose pieces are far apart into one geometry (and
        /// instance) per piece.
        #[arg(long)]
        split_scattered: bool,
        /// Split alpha-tested triangles out of geometries that mix them with opaque
        /// ones (the opaque geometry comes first and has no alpha-tested triangle).
        #[arg(long)]
        split_alpha: bool,
        /// Merge geometries whose boxes overlap by half or more (each placed once)
        /// into one, when probe rays need fewer box tests that way.
        #[arg(long)]
        merge_overlapping: bool,
        /// Make degenerate triangles inactive (NaN) instead of removing them.
        #[arg(long)]
        inactive: bool,
        /// Keep triangles that repeat an earlier triangle's corners and winding (by
        /// default they are removed; mirrored copies are always kept).
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
        /// Image size of the before/after measurement (0x0 skips it).
        #[arg(long, default_value = "512x512", value_parser = parse_size_or_zero)]
        size: (usize, usize),
        /// Timed rounds of the measurement (medians).
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Trace a ray workload through rtmesh's BVH and report speed and work per ray.
    ///
    /// Builds an 8-wide binned-SAH BVH (two levels for scenes with instances), traces
    /// the workload `--runs` times with counters off and reports the median, then once
    /// with counters on for box and triangle tests per ray.
    Trace {
        /// The mesh file, or builtin:NAME.
        mesh: String,
        /// Which rays: primary (camera), diffuse (one bounce), shadow (to a point light).
        #[arg(long, default_value = "primary")]
        rays: RayKind,
        /// Image size WIDTHxHEIGHT (one primary ray per pixel).
        #[arg(long, default_value = "1024x1024", value_parser = parse_size)]
        size: (usize, usize),
        /// Threads (0 = all cores).
        #[arg(long, default_value_t = 0)]
        threads: usize,
        /// Timed runs; the median is reported.
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Leaf primitives: tri (4 triangles per SIMD test) or pair (4 triangle pairs
        /// per SIMD test, paired by --pair-method after welding identical positions).
        #[arg(long, default_value = "tri", value_parser = ["tri", "pair"])]
        leaf: String,
        /// How to pair for --leaf pair: sah, sah-compressed, window:N, sah-max, max.
        #[arg(long, default_value = "sah")]
        pair_method: PairMethod,
        /// Ray packets: auto, none, 2x2, 4x4 or 8x8 blocks of pixels. A packet's rays
        /// traverse the BVH together: a frustum test per node for the whole packet,
        /// then the exact test per ray, and for camera packets (one origin) the
        /// intersector's shared terms once per packet. They pay for coherent rays
        /// (primary; shadow rays converging on one light) and stop paying for diffuse
        /// bounces (origins and directions scattered), so auto picks 8x8 for primary
        /// and shadow rays and single rays for diffuse ones (see `rtmesh bench
        /// packets`).
        #[arg(long, default_value = "auto")]
        packet: String,
        /// Ray-triangle test in the leaves: moller, moller-pre, moller-packet,
        /// pluecker or watertight. Default: moller-packet for packets (its shared terms
        /// are computed once per packet), the built-in Möller-Trumbore with
        /// precomputed edges for single rays.
        #[arg(long)]
        intersector: Option<IntersectorKind>,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Render a PNG: the mesh shaded by its normals, or a heatmap of the tracer's work.
    ///
    /// The default camera looks at the centre of the bounds from the (1, 1, 1)
    /// diagonal. `--heatmap boxes` colours each pixel by the ray–box tests its primary
    /// ray needed, `--heatmap tris` by the triangle tests, with a legend bar below.
    Render {
        /// The mesh file, or builtin:NAME.
        mesh: String,
        /// Output PNG file.
        #[arg(short, long)]
        output: PathBuf,
        /// Show work per pixel instead of normals: boxes or tris.
        #[arg(long, value_parser = ["boxes", "tris"])]
        heatmap: Option<String>,
        /// Image size WIDTHxHEIGHT.
        #[arg(long, default_value = "800x600", value_parser = parse_size)]
        size: (usize, usize),
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Benchmark tables that compare methods or tracers on many meshes.
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
    /// Run rtmesh on the built-in scenes: info, BVH, traced speed, packets, pairing,
    /// lint and repair.
    ///
    /// Per built-in scene: mesh info, the BVH, primary and diffuse rays at 512x512,
    /// 8x8 packets against single rays, the share of triangles SAH pairing pairs, lint's
    /// findings, and repair (split elongated and scattered, merge overlapping) with box
    /// tests per ray before and after at 256x256.
    Demo {
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
}

/// Read a mesh file (with a progress bar for large files) or make a built-in scene.
fn load(mesh: &str) -> Result<Scene> {
    if let Some(name) = mesh.strip_prefix("builtin:") {
        return rtmesh::scenes::by_name(name).with_context(|| {
            format!(
                "no built-in scene '{name}' (have: {})",
                rtmesh::scenes::NAMES.join(", ")
            )
        });
    }
    let path = Path::new(mesh);
    let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let bar = if size > 4 << 20 {
        ProgressBar::new(size).with_style(
            ProgressStyle::with_template("reading {msg} {bar:30} {bytes}/{total_bytes} ({eta})")
                .expect("valid template"),
        )
    } else {
        ProgressBar::hidden()
    };
    bar.set_message(mesh.to_owned());
    let scene = rtmesh::io::read_with_progress(path, &mut |done, _| bar.set_position(done));
    bar.finish_and_clear();
    Ok(scene?)
}

/// A progress bar on standard error over `steps` steps of long work, with a message
/// saying which; drawn only when standard error is a terminal, never into the output.
fn steps_bar(steps: usize) -> ProgressBar {
    ProgressBar::new(steps as u64).with_style(
        ProgressStyle::with_template("{msg} {bar:30} {pos}/{len} ({elapsed}, {eta} left)")
            .expect("valid template"),
    )
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Trace the same rays through rtmesh and (with --vs) another tracer, side by side.
    ///
    /// For every mesh, thread count and workload: builds each structure --builds
    /// times and traces the workload --runs times, alternating tracers, and reports
    /// medians, the Mrays/s ratio and the share of rays that hit the same triangle.
    /// `--vs embree` needs a build with `--features embree` (and libembree-dev).
    Trace {
        /// Mesh files or builtin:NAME.
        #[arg(required = true)]
        meshes: Vec<String>,
        /// Tracers to compare with, comma separated: embree, obvhs (each needs the
        /// cargo feature of the same name).
        #[arg(long, value_delimiter = ',')]
        vs: Vec<String>,
        /// Workloads, comma separated.
        #[arg(long, value_delimiter = ',', default_value = "primary,diffuse")]
        rays: Vec<RayKind>,
        /// Thread counts, comma separated (0 = all cores).
        #[arg(long, value_delimiter = ',', default_value = "1,2")]
        threads: Vec<usize>,
        /// Image size WIDTHxHEIGHT.
        #[arg(long, default_value = "1024x1024", value_parser = parse_size)]
        size: (usize, usize),
        /// Timed runs per tracer (medians are reported).
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Builds per structure (median build time is reported).
        #[arg(long, default_value_t = 3)]
        builds: usize,
        /// Print one JSON object per line (mesh × workload × threads) instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// The pairing paper's table for rtmesh's tracer: pair counts, time and tracing.
    ///
    /// Per mesh (welded): each method's pairing time (median of --runs) and paired
    /// ratio, then the same rays (primary and diffuse) traced through triangle leaves
    /// and through each method's pair leaves, alternating configurations each round:
    /// box tests, triangle+pair tests and Mrays/s, with Δ against window:2.
    Pairing {
        /// Mesh files or builtin:NAME.
        #[arg(required = true)]
        meshes: Vec<String>,
        /// Methods, comma separated (window:2 is always measured as the baseline).
        #[arg(long, value_delimiter = ',', default_value = "sah,sah-max")]
        methods: Vec<PairMethod>,
        /// Workloads, comma separated.
        #[arg(long, value_delimiter = ',', default_value = "primary,diffuse")]
        rays: Vec<RayKind>,
        /// Threads (0 = all cores).
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// Image size WIDTHxHEIGHT.
        #[arg(long, default_value = "1024x1024", value_parser = parse_size)]
        size: (usize, usize),
        /// Timed rounds (medians are reported).
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Print one JSON object per line instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Packet traversal against single rays, side by side on the same rays.
    ///
    /// Per mesh and workload: the default single-ray tracer, then packets of each
    /// --packets shape with --intersector, timed in alternating rounds (medians),
    /// with box and triangle tests per ray from a counted run, the speedup over
    /// single rays, and whether every pixel hit the same triangle.
    Packets {
        /// Mesh files or builtin:NAME.
        #[arg(required = true)]
        meshes: Vec<String>,
        /// Workloads, comma separated.
        #[arg(long, value_delimiter = ',', default_value = "primary,diffuse,shadow")]
        rays: Vec<RayKind>,
        /// Packet shapes, comma separated (2x2, 4x4, 8x8).
        #[arg(long, value_delimiter = ',', default_value = "2x2,4x4,8x8", value_parser = parse_packet)]
        packets: Vec<usize>,
        /// Ray-triangle test in the packets' leaves.
        #[arg(long, default_value = "moller-packet")]
        intersector: IntersectorKind,
        /// Threads (0 = all cores).
        #[arg(long, default_value_t = 2)]
        threads: usize,
        /// Image size WIDTHxHEIGHT.
        #[arg(long, default_value = "1024x1024", value_parser = parse_size)]
        size: (usize, usize),
        /// Timed rounds (medians are reported).
        #[arg(long, default_value_t = 7)]
        runs: usize,
        /// Print one JSON object per line instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// The packet paper's experiment: every intersector, no acceleration structure.
    ///
    /// Per mesh: --size primary rays from the default camera in --packet packets
    /// (rays of a packet share the camera origin), each ray tested against every
    /// triangle, with each intersector (moller, moller-pre, moller-packet, pluecker,
    /// watertight) in scalar form and 4- and 8-wide SIMD (8-wide when the CPU has AVX).
    /// Reports the median Mrays/s, millions of ray-triangle tests per second, the
    /// speedup over scalar moller-pre and the share of rays hitting the same triangle
    /// as scalar moller-pre.
    Intersect {
        /// Mesh files or builtin:NAME (keep them small: the work is rays × triangles).
        #[arg(required = true)]
        meshes: Vec<String>,
        /// Image size WIDTHxHEIGHT.
        #[arg(long, default_value = "256x256", value_parser = parse_size)]
        size: (usize, usize),
        /// Packet shape: 1x1, 2x2, 4x4 or 8x8.
        #[arg(long, default_value = "2x2", value_parser = parse_packet)]
        packet: usize,
        /// Intersectors, comma separated (default: all).
        #[arg(long, value_delimiter = ',')]
        intersectors: Vec<IntersectorKind>,
        /// Threads (0 = all cores; the paper measured one).
        #[arg(long, default_value_t = 1)]
        threads: usize,
        /// Timed runs per configuration (medians are reported).
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Print one JSON object per line instead of a table.
        #[arg(long)]
        json: bool,
    },
}

/// `rtmesh trace --packet`: measure packets with the chosen intersector.
struct MeasurePackets<'a>(&'a SceneAccel, &'a Workload, &'a [u32], usize);

impl WithIntersector for MeasurePackets<'_> {
    type Output = rtmesh::trace::TraceRun;
    fn run<I: Intersector>(self) -> Self::Output {
        workload::measure_packets::<I>(self.0, self.1, self.2, self.3)
    }
}

/// `rtmesh trace --intersector` with single rays.
struct MeasureSingle<'a>(&'a SceneAccel, &'a Workload, usize);

impl WithIntersector for MeasureSingle<'_> {
    type Output = rtmesh::trace::TraceRun;
    fn run<I: Intersector>(self) -> Self::Output {
        workload::measure_by::<I>(self.0, self.1, self.2)
    }
}

/// A square packet shape `NxN` (N = 1, 2, 4 or 8) as its side N.
fn parse_packet(text: &str) -> Result<usize, String> {
    match text {
        "1x1" => Ok(1),
        "2x2" => Ok(2),
        "4x4" => Ok(4),
        "8x8" => Ok(8),
        _ => Err(format!(
            "bad packet '{text}': expected 1x1, 2x2, 4x4 or 8x8"
        )),
    }
}

/// WIDTHxHEIGHT, or 0x0 for "none".
fn parse_size_or_zero(text: &str) -> Result<(usize, usize), String> {
    if text == "0x0" {
        Ok((0, 0))
    } else {
        parse_size(text)
    }
}

fn parse_size(text: &str) -> Result<(usize, usize), String> {
    let (w, h) = text
        .split_once('x')
        .ok_or("expected WIDTHxHEIGHT, e.g. 1024x768")?;
    let parse = |v: &str| v.parse::<usize>().ok().filter(|&n| n > 0 && n <= 1 << 15);
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!(
            "bad size '{text}': expected WIDTHxHEIGHT with sides 1..32768"
        )),
    }
}

/// The file name of a mesh argument (the argument itself for builtin:NAME), for tables.
fn file_name(mesh: &str) -> &str {
    Path::new(mesh)
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or(mesh)
}

fn print_json(value: &impl serde::Serialize) -> Result<()> {
    println!("{}", serde_json::to_string_pretty(value)?);
    Ok(())
}

fn print_info(name: &str, info: &MeshInfo) {
    let b = &info.bounds;
    println!("{name}");
    println!(
        "  vertices           {:>10}  ({} after welding)",
        info.vertices, info.welded_vertices
    );
    println!("  triangles          {:>10}", info.triangles);
    println!(
        "  geometries         {:>10}  ({} instances, {} materials)",
        info.meshes, info.instances, info.materials
    );
    if !b.is_empty() {
        println!(
            "  bounds             [{:.4}, {:.4}, {:.4}] .. [{:.4}, {:.4}, {:.4}]",
            b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
        );
    } else {
        println!("  bounds             none (no finite corner)");
    }
    println!("  components         {:>10}", info.components);
    println!(
        "  edges              {:>10} manifold, {} boundary, {} non-manifold",
        info.manifold_edges, info.boundary_edges, info.nonmanifold_edges
    );
    println!(
        "  alpha-tested       {:>10} triangles",
        info.alpha_tested_triangles
    );
    println!(
        "  broken triangles   {:>10} non-finite, {} repeated-vertex, {} zero-area",
        info.non_finite_triangles, info.repeated_vertex_triangles, info.zero_area_triangles
    );
}

fn main() {
    // Rust ignores SIGPIPE, so `rtmesh lint MESH | head` would panic on the closed pipe;
    // restore the default (exit quietly) as command-line tools expect.
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any other thread exists; SIG_DFL is a
    // valid disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    if let Err(error) = run(cli) {
        eprintln!("error: {error:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info { mesh, json } => {
            let info = MeshInfo::of(&load(&mesh)?);
            if json {
                print_json(&info)
            } else {
                print_info(&mesh, &info);
                Ok(())
            }
        }
        Command::Convert {
            input,
            output,
            weld,
            json,
        } => {
            let mut scene = load(&input)?;
            let mut merged = 0;
            if let Some(tolerance) = weld {
                for mesh in &mut scene.meshes {
                    let result = rtmesh::mesh::weld(mesh, tolerance);
                    merged += result.merged;
                    *mesh = result.mesh;
                }
            }
            rtmesh::io::write(&scene, &output)?;
            let summary = serde_json::json!({
                "input": input, "output": output, "triangles": scene.instanced_triangle_count(),
                "vertices": scene.instanced_vertex_count(), "merged_vertices": merged,
            });
            if json {
                print_json(&summary)
            } else {
                println!(
                    "wrote {} ({} triangles, {} vertices, {} merged by welding)",
                    output.display(),
                    summary["triangles"],
                    summary["vertices"],
                    merged
                );
                Ok(())
            }
        }
        Command::Pair {
            mesh,
            output,
            method,
            no_prescan,
            pair_box_limit,
            json,
        } => {
            let mut scene = load(&mesh)?;
            let settings = PairSettings {
                method,
                prescan_threshold: (!no_prescan).then_some(0.85),
                pair_box_limit,
            };
            let report = pair_scene(&mut scene, &settings);
            if let Some(output) = &output {
                rtmesh::io::write(&scene, output)?;
            }
            if json {
                let mut value = serde_json::to_value(&report)?;
                value["mesh"] = serde_json::json!(mesh);
                value["output"] = serde_json::json!(output);
                print_json(&value)
            } else {
                println!(
                    "{mesh}: {} of {} triangles paired ({:.2}%) by {} in {:.4} s{}",
                    report.paired_triangles,
                    report.triangles,
                    100.0 * report.pair_ratio,
                    report.method,
                    report.seconds,
                    if report.prescan_skipped {
                        " (input already paired: order kept)"
                    } else {
                        ""
                    }
                );
                if let Some(output) = output {
                    println!(
                        "wrote {} (pairs first, then unpaired triangles)",
                        output.display()
                    );
                }
                Ok(())
            }
        }
        Command::Lint {
            mesh,
            empty_space,
            aspect,
            pose,
            json,
        } => {
            let scene = load(&mesh)?;
            let settings = LintSettings {
                empty_space,
                aspect,
                ..LintSettings::default()
            };
            let mut report = rtmesh::lint::lint(&scene, &settings);
            if !pose.is_empty() {
                let poses = pose.iter().map(|p| load(p)).collect::<Result<Vec<_>>>()?;
                let finding = rtmesh::lint::lint_deforming(&scene, &poses)
                    .map_err(|e| anyhow::anyhow!("--pose: {e}"))?;
                report.findings.push(finding);
            }
            if json {
                let mut value = serde_json::to_value(&report)?;
                value["mesh"] = serde_json::json!(mesh);
                print_json(&value)
            } else {
                print_lint(&mesh, &report);
                Ok(())
            }
        }
        Command::Repair {
            mesh,
            output,
            split_elongated,
            force_split,
            split_scattered,
            split_alpha,
            merge_overlapping,
            inactive,
            keep_duplicates,
            budget,
            empty_space,
            aspect,
            map,
            size,
            runs,
            json,
        } => {
            let scene = load(&mesh)?;
            let settings = RepairSettings {
                degenerate: if inactive {
                    Degenerate::Inactive
                } else {
                    Degenerate::Remove
                },
                remove_duplicates: !keep_duplicates,
                split_elongated,
                force_split,
                split_scattered,
                split_alpha,
                merge_overlapping,
                triangle_budget: budget,
                lint: LintSettings {
                    empty_space,
                    aspect,
                    ..LintSettings::default()
                },
                ..RepairSettings::default()
            };
            // Repairing and writing; measuring adds its own steps.
            let bar = steps_bar(1 + output.is_some() as usize);
            bar.set_message(format!("repairing {mesh}"));
            let (repaired, maps, report) = rtmesh::repair::repair(&scene, &settings);
            bar.inc(1);
            if let Some(output) = &output {
                bar.set_message(format!("writing {}", output.display()));
                rtmesh::io::write(&repaired, output)?;
                bar.inc(1);
            }
            if let Some(path) = &map {
                std::fs::write(path, serde_json::to_string(&maps)?)
                    .with_context(|| format!("writing {}", path.display()))?;
            }
            let measured =
                (size.0 > 0).then(|| measure_before_after(&scene, &repaired, size, runs, &bar));
            bar.finish_and_clear();
            if json {
                let mut value = serde_json::to_value(&report)?;
                value["mesh"] = serde_json::json!(mesh);
                value["output"] = serde_json::json!(output);
                value["trace"] = serde_json::json!(measured);
                print_json(&value)
            } else {
                println!(
                    "{mesh}: {} → {} triangles; {} vertices welded, {} degenerate removed, {} made inactive, {} duplicates removed, {} edges split{}",
                    report.triangles_in, report.triangles_out, report.merged_vertices,
                    report.removed_degenerate, report.made_inactive, report.removed_duplicates,
                    report.split_edges,
                    if report.budget_reached {
                        " (budget reached)"
                    } else if split_elongated
                        && !force_split
                        && report.split_edges == 0
                        && report.elongated_before > 0
                    {
                        " (no round of splits saved 2% of the probe rays' box and triangle tests; --force-split keeps them anyway)"
                    } else {
                        ""
                    }
                );
                println!(
                    "  geometries   {} → {} ({} scattered geometries split into pieces, {} into opaque and alpha-tested)",
                    scene.meshes.len(),
                    report.geometries_out,
                    report.split_geometries,
                    report.split_alpha_geometries
                );
                println!(
                    "  opaque       {} of {} geometries have no alpha-tested triangle: flag them opaque (DXR GEOMETRY_FLAG_OPAQUE, Vulkan GEOMETRY_OPAQUE_BIT) so no any-hit shader runs",
                    report.opaque_geometries.len(),
                    report.geometries_out
                );
                if report.merged_groups > 0 {
                    println!(
                        "  merged       {} groups of overlapping geometries",
                        report.merged_groups
                    );
                }
                println!(
                    "  elongated    {} → {} triangles, wasted box area {:.4} → {:.4}",
                    report.elongated_before,
                    report.elongated_after,
                    report.wasted_box_area_before,
                    report.wasted_box_area_after
                );
                for row in measured.iter().flatten() {
                    println!(
                        "  {:<8} box/ray {:.2} → {:.2}, tri/ray {:.2} → {:.2}, Mrays/s {:.2} → {:.2} ({:+.1}%)",
                        row.workload, row.box_before, row.box_after, row.tri_before, row.tri_after,
                        row.mrays_before, row.mrays_after, 100.0 * (row.mrays_after / row.mrays_before - 1.0)
                    );
                }
                if let Some(output) = output {
                    println!("wrote {}", output.display());
                }
                Ok(())
            }
        }
        Command::Trace {
            mesh,
            rays,
            size: (width, height),
            threads,
            runs,
            leaf,
            pair_method,
            packet,
            intersector,
            json,
        } => {
            let side = match packet.as_str() {
                "auto" if rays != RayKind::Diffuse && leaf == "tri" => 8,
                "auto" | "none" => 1,
                shape => parse_packet(shape).map_err(anyhow::Error::msg)?,
            };
            if leaf == "pair" && (side > 1 || intersector.is_some()) {
                anyhow::bail!("--packet and --intersector work with --leaf tri only");
            }
            let scene = load(&mesh)?;
            let report = workload::with_threads(threads, || {
                let triangles = SceneAccel::build(&scene, &BuildSettings::default());
                let mut work = Workload::generate(rays, &scene, &triangles, width, height, 1);
                let (stats, run) = if leaf == "pair" {
                    let (welded, pairings) = rtmesh::pair::weld_and_pair(&scene, pair_method);
                    let pairs =
                        SceneAccel::build_paired(&welded, &pairings, &BuildSettings::default());
                    (pairs.stats(), workload::measure(&pairs, &work, runs))
                } else if side > 1 {
                    let (packed, starts) = work.grouped(side);
                    work = packed;
                    let kind = intersector.unwrap_or(IntersectorKind::MollerPacket);
                    let run = kind.dispatch(MeasurePackets(&triangles, &work, &starts, runs));
                    (triangles.stats(), run)
                } else if let Some(kind) = intersector {
                    let run = kind.dispatch(MeasureSingle(&triangles, &work, runs));
                    (triangles.stats(), run)
                } else {
                    (
                        triangles.stats(),
                        workload::measure(&triangles, &work, runs),
                    )
                };
                (stats, run, rayon::current_num_threads())
            });
            let (bvh, run, threads) = report;
            let packet = if side > 1 {
                format!("{side}x{side}")
            } else {
                "none".to_owned()
            };
            let intersector = match (intersector, side > 1) {
                (Some(kind), _) => kind.name(),
                (None, true) => IntersectorKind::MollerPacket.name(),
                (None, false) => "builtin",
            };
            if json {
                let mut value = serde_json::to_value(&run)?;
                value["mesh"] = serde_json::json!(mesh);
                value["ray_kind"] = serde_json::json!(rays.name());
                value["threads"] = serde_json::json!(threads);
                value["packet"] = serde_json::json!(packet);
                value["intersector"] = serde_json::json!(intersector);
                value["bvh"] = serde_json::to_value(&bvh)?;
                value["bvh"]["bytes"] = serde_json::json!(bvh.bytes);
                print_json(&value)
            } else {
                println!(
                    "{mesh}: {} {} rays on {threads} threads, packets {packet}, intersector {intersector}",
                    run.rays,
                    rays.name()
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
                Ok(())
            }
        }
        Command::Render {
            mesh,
            output,
            heatmap,
            size: (width, height),
            json,
        } => {
            let scene = load(&mesh)?;
            let accel = SceneAccel::build(&scene, &BuildSettings::default());
            let summary = match heatmap.as_deref() {
                None => {
                    rtmesh::render::normals(&scene, &accel, width, height).write_png(&output)?;
                    serde_json::json!({"output": output, "width": width, "height": height, "shading": "normals"})
                }
                Some(kind) => {
                    let metric = if kind == "boxes" {
                        HeatmapMetric::BoxTests
                    } else {
                        HeatmapMetric::TriangleTests
                    };
                    let map = rtmesh::render::heatmap(&scene, &accel, width, height, metric);
                    map.image.write_png(&output)?;
                    serde_json::json!({"output": output, "width": width, "height": height, "heatmap": kind,
                        "mean_per_ray": map.mean, "max_per_ray": map.max, "scale_max": map.scale_max})
                }
            };
            if json {
                print_json(&summary)
            } else {
                println!(
                    "wrote {} ({width}x{height}{})",
                    output.display(),
                    heatmap
                        .map(|h| format!(
                            ", heatmap of {h} tests per ray: mean {:.2}, max {}",
                            summary["mean_per_ray"].as_f64().unwrap_or(0.0),
                            summary["max_per_ray"]
                        ))
                        .unwrap_or_default()
                );
                Ok(())
            }
        }
        Command::Bench {
            what:
                BenchCommand::Trace {
                    meshes,
                    vs,
                    rays,
                    threads,
                    size,
                    runs,
                    builds,
                    json,
                },
        } => bench_trace(&meshes, &vs, &rays, &threads, size, runs, builds, json),
        Command::Bench {
            what:
                BenchCommand::Packets {
                    meshes,
                    rays,
                    packets,
                    intersector,
                    threads,
                    size,
                    runs,
                    json,
                },
        } => workload::with_threads(threads, || {
            bench_packets(&meshes, &rays, &packets, intersector, size, runs, json)
        }),
        Command::Bench {
            what:
                BenchCommand::Intersect {
                    meshes,
                    size,
                    packet,
                    intersectors,
                    threads,
                    runs,
                    json,
                },
        } => workload::with_threads(threads, || {
            bench_intersect(&meshes, size, packet, &intersectors, runs, json)
        }),
        Command::Bench {
            what:
                BenchCommand::Pairing {
                    meshes,
                    methods,
                    rays,
                    threads,
                    size,
                    runs,
                    json,
                },
        } => workload::with_threads(threads, || {
            bench_pairing(&meshes, &methods, &rays, size, runs, json)
        }),
        Command::Demo { json } => {
            let mut report = Vec::new();
            for &name in &rtmesh::scenes::NAMES {
                let scene = rtmesh::scenes::by_name(name).expect("built-in");
                let info = MeshInfo::of(&scene);
                let accel = SceneAccel::build(&scene, &BuildSettings::default());
                let runs: Vec<_> = [RayKind::Primary, RayKind::Diffuse]
                    .into_iter()
                    .map(|kind| {
                        let work = Workload::generate(kind, &scene, &accel, 512, 512, 1);
                        (kind, workload::measure(&accel, &work, 3))
                    })
                    .collect();
                // Packets of 8x8 camera rays on the same primary rays.
                let primary = &runs[0].1;
                let (grouped, starts) =
                    Workload::generate(RayKind::Primary, &scene, &accel, 512, 512, 1).grouped(8);
                let packets = IntersectorKind::MollerPacket
                    .dispatch(MeasurePackets(&accel, &grouped, &starts, 3));
                let lint = rtmesh::lint::lint(&scene, &LintSettings::default());
                let (_, pairings) = rtmesh::pair::weld_and_pair(&scene, PairMethod::Sah);
                let paired: usize = pairings.iter().map(Pairing::paired_triangles).sum();
                let pair_ratio = paired as f64 / scene.instanced_triangle_count().max(1) as f64;
                let settings = RepairSettings {
                    split_elongated: true,
                    split_scattered: true,
                    merge_overlapping: true,
                    ..RepairSettings::default()
                };
                let (repaired, _, repair) = rtmesh::repair::repair(&scene, &settings);
                let measured =
                    measure_before_after(&scene, &repaired, (256, 256), 1, &ProgressBar::hidden());
                if !json {
                    print_info(&format!("builtin:{name}"), &info);
                    let bvh = accel.stats();
                    println!(
                        "  bvh                {:>10} nodes, SAH {:.2}, {:.0} bytes/triangle, built in {:.3} s",
                        bvh.nodes, bvh.sah_cost, bvh.bytes_per_triangle, bvh.build_seconds
                    );
                    for (kind, run) in &runs {
                        println!(
                            "  trace {:<12} {:>10.2} Mrays/s, {:.1} box and {:.1} triangle tests per ray, {} of {} rays hit",
                            kind.name(), run.mrays_per_s, run.box_tests_per_ray, run.tri_tests_per_ray, run.hits, run.rays
                        );
                    }
                    println!(
                        "  8x8 packets        {:>10.2} Mrays/s ({:.2}x single rays), {:.1} box tests per ray",
                        packets.mrays_per_s,
                        packets.mrays_per_s / primary.mrays_per_s.max(1e-9),
                        packets.box_tests_per_ray
                    );
                    println!(
                        "  sah pairing        {:>9.2}% of triangles paired",
                        100.0 * pair_ratio
                    );
                    let found: Vec<String> = lint
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
                    println!(
                        "  repair             {} → {} triangles, {} → {} geometries{}",
                        repair.triangles_in,
                        repair.triangles_out,
                        scene.meshes.len(),
                        repair.geometries_out,
                        measured
                            .iter()
                            .map(|m| format!(
                                ", {} box/ray {:.1} → {:.1}",
                                m.workload, m.box_before, m.box_after
                            ))
                            .collect::<String>()
                    );
                }
                let traces: serde_json::Map<String, serde_json::Value> = runs
                    .iter()
                    .map(|(kind, run)| {
                        (
                            kind.name().to_owned(),
                            serde_json::to_value(run).expect("plain data"),
                        )
                    })
                    .collect();
                report.push(serde_json::json!({
                    "scene": name, "info": info, "bvh": accel.stats(), "trace": traces,
                    "packets_8x8": packets, "sah_pair_ratio": pair_ratio, "lint": lint,
                    "repair": {"report": repair, "trace": measured},
                }));
            }
            if json {
                print_json(&report)
            } else {
                println!("\nnext: rtmesh render builtin:blob -o blob.png --heatmap boxes; rtmesh lint MESH; rtmesh repair MESH --split-elongated; rtmesh bench packets MESH...");
                Ok(())
            }
        }
    }
}

/// Weld and pair every geometry of `scene` in place (each mesh becomes its paired,
/// reordered form); the report sums the geometries.
fn pair_scene(scene: &mut Scene, settings: &PairSettings) -> PairReport {
    let mut total = PairReport {
        triangles: 0,
        paired_triangles: 0,
        pair_ratio: 0.0,
        method: settings.method.to_string(),
        seconds: 0.0,
        prescan_skipped: !scene.meshes.is_empty(),
    };
    for mesh in &mut scene.meshes {
        let welded = rtmesh::mesh::weld_exact(mesh).mesh;
        let (pairing, report) = rtmesh::pair::pair(&welded, settings);
        *mesh = rtmesh::pair::reorder(mesh, &welded, &pairing).mesh;
        total.triangles += report.triangles;
        total.paired_triangles += report.paired_triangles;
        total.seconds += report.seconds;
        total.prescan_skipped &= report.prescan_skipped;
    }
    total.pair_ratio = total.paired_triangles as f64 / total.triangles.max(1) as f64;
    total
}

/// The error for a comparison whose cargo feature was not built in.
#[allow(dead_code)]
fn missing_feature(reference: &str, name: &str, scene: &Scene) -> anyhow::Error {
    anyhow::anyhow!(
        "cannot compare {name} ({} triangles) with {reference}: this rtmesh was built without it; rebuild with `--features {reference}`",
        scene.instanced_triangle_count()
    )
}

/// Compare rtmesh with the tracer named `reference` (a cargo feature of the same name).
#[cfg_attr(
    not(all(feature = "embree", feature = "obvhs")),
    allow(unused_variables)
)]
fn compare_with(
    reference: &str,
    name: &str,
    scene: &Scene,
    settings: &CompareSettings,
) -> Result<Vec<Comparison>> {
    #[allow(unused_imports)]
    use rtmesh::trace::compare::compare;
    match reference {
        #[cfg(feature = "embree")]
        "embree" => compare::<rtmesh::embree::EmbreeScene>(name, scene, settings)
            .map_err(anyhow::Error::msg),
        #[cfg(feature = "obvhs")]
        "obvhs" => compare::<rtmesh::trace::compare::ObvhsScene>(name, scene, settings)
            .map_err(anyhow::Error::msg),
        #[cfg(not(feature = "embree"))]
        "embree" => Err(missing_feature(reference, name, scene)),
        #[cfg(not(feature = "obvhs"))]
        "obvhs" => Err(missing_feature(reference, name, scene)),
        other => anyhow::bail!("unknown tracer '{other}' for --vs (have: embree, obvhs)"),
    }
}

#[allow(clippy::too_many_arguments)]
fn bench_trace(
    meshes: &[String],
    vs: &[String],
    kinds: &[RayKind],
    thread_counts: &[usize],
    size: (usize, usize),
    runs: usize,
    builds: usize,
    json: bool,
) -> Result<()> {
    if !json {
        if vs.is_empty() {
            println!(
                "{:<24} {:>8} {:>3} {:>8} {:>11} {:>8} {:>8} {:>9}",
                "mesh", "rays", "thr", "workload", "Mrays/s", "box/ray", "tri/ray", "build s"
            );
        } else {
            println!(
                "{:<24} {:>8} {:>3} {:>8} {:>7} {:>11} {:>10} {:>7} {:>9} {:>9} {:>8}",
                "mesh",
                "rays",
                "thr",
                "workload",
                "vs",
                "rtmesh Mr/s",
                "other Mr/s",
                "ratio",
                "build rt",
                "build ref",
                "same"
            );
        }
    }
    let compare_settings = CompareSettings {
        kinds: kinds.to_vec(),
        size,
        thread_counts: thread_counts.to_vec(),
        runs,
        builds,
    };
    // One step per mesh and tracer compared (ticking on while one runs).
    let bar = steps_bar(meshes.len() * vs.len().max(1));
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    for mesh in meshes {
        let scene = bar.suspend(|| load(mesh))?;
        let name = file_name(mesh);
        if vs.is_empty() {
            bar.set_message(format!("{name}: rtmesh"));
            bench_own(
                name,
                &scene,
                kinds,
                thread_counts,
                size,
                runs,
                builds,
                json,
                &bar,
            )?;
            bar.inc(1);
            continue;
        }
        for reference in vs {
            bar.set_message(format!("{name}: rtmesh and {reference}"));
            for row in compare_with(reference, name, &scene, &compare_settings)? {
                let line = if json {
                    row.to_json().to_string()
                } else {
                    format!(
                        "{:<24} {:>8} {:>3} {:>8} {:>7} {:>11.2} {:>10.2} {:>6.2}x {:>9.3} {:>9.3} {:>7.3}%",
                        row.mesh, row.rays, row.threads, row.workload, row.other, row.rtmesh_mrays_per_s, row.other_mrays_per_s, row.ratio,
                        row.rtmesh_build_seconds, row.other_build_seconds, 100.0 * row.same_hits
                    )
                };
                bar.suspend(|| println!("{line}"));
            }
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    Ok(())
}

/// rtmesh alone: speed and work per ray for each thread count and workload.
#[allow(clippy::too_many_arguments)]
fn bench_own(
    name: &str,
    scene: &Scene,
    kinds: &[RayKind],
    thread_counts: &[usize],
    (width, height): (usize, usize),
    runs: usize,
    builds: usize,
    json: bool,
    bar: &ProgressBar,
) -> Result<()> {
    for &threads in thread_counts {
        workload::with_threads(threads, || -> Result<()> {
            let build_times: Vec<f64> = (0..builds.max(1))
                .map(|_| SceneAccel::build(scene, &BuildSettings::default()).build_seconds)
                .collect();
            let build_seconds = workload::median(&build_times);
            let accel = SceneAccel::build(scene, &BuildSettings::default());
            for &kind in kinds {
                let work = Workload::generate(kind, scene, &accel, width, height, 1);
                let run = workload::measure(&accel, &work, runs);
                let threads = rayon::current_num_threads();
                let line = if json {
                    let mut value = serde_json::to_value(&run)?;
                    value["mesh"] = serde_json::json!(name);
                    value["workload"] = serde_json::json!(kind.name());
                    value["threads"] = serde_json::json!(threads);
                    value["build_seconds"] = serde_json::json!(build_seconds);
                    value.to_string()
                } else {
                    format!(
                        "{name:<24} {:>8} {threads:>3} {:>8} {:>11.2} {:>8.2} {:>8.2} {:>9.3}",
                        run.rays,
                        kind.name(),
                        run.mrays_per_s,
                        run.box_tests_per_ray,
                        run.tri_tests_per_ray,
                        build_seconds
                    )
                };
                bar.suspend(|| println!("{line}"));
            }
            Ok(())
        })?;
    }
    Ok(())
}

/// Traces rays with one configuration's structure, counters off.
type TraceFn = Box<dyn Fn(&[rtmesh::Ray]) -> Vec<rtmesh::trace::Hit> + Sync>;

/// One configuration of `bench pairing`: unpaired triangles or one method's pairs.
struct PairingRow {
    method: String,
    pair_seconds: f64,
    pair_ratio: f64,
    accel: TraceFn,
    counted: Box<dyn Fn(&Workload) -> rtmesh::trace::TraceRun + Sync>,
}

fn bench_pairing(
    meshes: &[String],
    methods: &[PairMethod],
    kinds: &[RayKind],
    (width, height): (usize, usize),
    runs: usize,
    json: bool,
) -> Result<()> {
    use rtmesh::trace::workload::trace_closest;
    use rtmesh::trace::NoCounters;
    let mut all_methods = vec![PairMethod::Window(2)];
    all_methods.extend(methods.iter().filter(|&&m| m != PairMethod::Window(2)));
    if !json {
        println!(
            "{:<20} {:<14} {:<8} {:>9} {:>8} {:>8} {:>8} {:>9} {:>9} {:>8} {:>7} {:>7} {:>7} {:>7}",
            "mesh",
            "method",
            "workload",
            "pair s",
            "paired",
            "rays",
            "box/ray",
            "tri/ray",
            "pair/ray",
            "Mrays/s",
            "Δbox",
            "Δtests",
            "ΔMr/s",
            "same"
        );
    }
    for mesh_name in meshes {
        let mut scene = load(mesh_name)?;
        for mesh in &mut scene.meshes {
            *mesh = rtmesh::mesh::weld_exact(mesh).mesh;
        }
        let name = file_name(mesh_name).to_owned();
        let rounds = runs.max(1);
        // Pairing each method, then tracing each workload through each row (timed runs,
        // then one counted and one checked pass).
        let rows_count = all_methods.len() + 1;
        let bar = steps_bar(all_methods.len() * rounds + kinds.len() * rows_count * (rounds + 2));
        let triangles = std::sync::Arc::new(SceneAccel::build(&scene, &BuildSettings::default()));
        let mut rows = vec![{
            let (a, b) = (triangles.clone(), triangles.clone());
            PairingRow {
                method: "unpaired".into(),
                pair_seconds: 0.0,
                pair_ratio: 0.0,
                accel: Box::new(move |rays| trace_closest::<NoCounters>(&*a, rays).0),
                counted: Box::new(move |work| workload::measure(&*b, work, 1)),
            }
        }];
        for &method in &all_methods {
            let settings = PairSettings {
                method,
                prescan_threshold: None,
                ..PairSettings::default()
            };
            let mut seconds = Vec::new();
            let mut pairings = Vec::new();
            bar.set_message(format!("{name}: pairing {method}"));
            for _ in 0..rounds {
                let start = std::time::Instant::now();
                pairings = scene
                    .meshes
                    .iter()
                    .map(|m| rtmesh::pair::pair(m, &settings).0)
                    .collect();
                seconds.push(start.elapsed().as_secs_f64());
                bar.inc(1);
            }
            let paired: usize = pairings.iter().map(Pairing::paired_triangles).sum();
            let accel = std::sync::Arc::new(SceneAccel::build_paired(
                &scene,
                &pairings,
                &BuildSettings::default(),
            ));
            let (a, b) = (accel.clone(), accel);
            rows.push(PairingRow {
                method: method.to_string(),
                pair_seconds: workload::median(&seconds),
                pair_ratio: paired as f64 / scene.instanced_triangle_count().max(1) as f64,
                accel: Box::new(move |rays| trace_closest::<NoCounters>(&*a, rays).0),
                counted: Box::new(move |work| workload::measure(&*b, work, 1)),
            });
        }
        for &kind in kinds {
            bar.set_message(format!("{name}: tracing {} rays", kind.name()));
            let work = Workload::generate(kind, &scene, &*triangles, width, height, 1);
            let reference = (rows[0].accel)(&work.rays);
            let mut seconds = vec![Vec::new(); rows.len()];
            for _ in 0..rounds {
                for (row, times) in rows.iter().zip(&mut seconds) {
                    let start = std::time::Instant::now();
                    std::hint::black_box((row.accel)(&work.rays));
                    times.push(start.elapsed().as_secs_f64());
                    bar.inc(1);
                }
            }
            let results: Vec<(rtmesh::trace::TraceRun, f64, f64)> = rows
                .iter()
                .zip(&seconds)
                .map(|(row, times)| {
                    let hits = (row.accel)(&work.rays);
                    let same = hits
                        .iter()
                        .zip(&reference)
                        .filter(|(a, b)| a.triangle == b.triangle)
                        .count() as f64
                        / work.rays.len().max(1) as f64;
                    let median = workload::median(times);
                    let counted = (row.counted)(&work);
                    bar.inc(2);
                    (counted, work.rays.len() as f64 / median / 1e6, same)
                })
                .collect();
            let base = &results[1]; // window:2
            let tests = |r: &rtmesh::trace::TraceRun| r.tri_tests_per_ray + r.pair_tests_per_ray;
            let delta = |x: f64, y: f64| 100.0 * (x / y.max(1e-12) - 1.0);
            for (row, (run, mrays, same)) in rows.iter().zip(&results) {
                let d_box = delta(run.box_tests_per_ray, base.0.box_tests_per_ray);
                let d_tests = delta(tests(run), tests(&base.0));
                let d_mrays = delta(*mrays, base.1);
                let line = if json {
                    serde_json::json!({
                            "mesh": name, "method": row.method, "workload": kind.name(),
                            "rays": run.rays, "threads": rayon::current_num_threads(),
                            "pair_seconds": row.pair_seconds, "pair_ratio": row.pair_ratio,
                            "box_tests_per_ray": run.box_tests_per_ray,
                            "tri_tests_per_ray": run.tri_tests_per_ray,
                            "pair_tests_per_ray": run.pair_tests_per_ray,
                            "mrays_per_s": mrays, "delta_box_percent": d_box,
                            "delta_tests_percent": d_tests, "delta_mrays_percent": d_mrays,
                            "same_hits": same,
                    })
                    .to_string()
                } else {
                    format!(
                        "{:<20} {:<14} {:<8} {:>9.4} {:>7.2}% {:>8} {:>8.2} {:>9.3} {:>9.3} {:>8.2} {:>6.1}% {:>6.1}% {:>6.1}% {:>6.2}%",
                        name, row.method, kind.name(), row.pair_seconds, 100.0 * row.pair_ratio,
                        run.rays, run.box_tests_per_ray, run.tri_tests_per_ray, run.pair_tests_per_ray, mrays,
                        d_box, d_tests, d_mrays, 100.0 * same
                    )
                };
                bar.suspend(|| println!("{line}"));
            }
        }
        bar.finish_and_clear();
    }
    Ok(())
}

fn bench_intersect(
    meshes: &[String],
    (width, height): (usize, usize),
    side: usize,
    kinds: &[IntersectorKind],
    runs: usize,
    json: bool,
) -> Result<()> {
    use rtmesh::trace::intersect::measure_without_bvh;
    let kinds = if kinds.is_empty() {
        IntersectorKind::ALL.to_vec()
    } else {
        kinds.to_vec()
    };
    if !json {
        println!(
            "{:<22} {:>9} {:<14} {:<6} {:>9} {:>9} {:>10} {:>8} {:>8}",
            "mesh",
            "triangles",
            "intersector",
            "simd",
            "seconds",
            "Mrays/s",
            "Mtests/s",
            "speedup",
            "same"
        );
    }
    for mesh in meshes {
        let scene = load(mesh)?;
        let flat = scene.flatten();
        let soa = TriangleSoa::from_mesh(&flat);
        let camera = rtmesh::trace::Camera::default_for(&scene.bounds(), width, height);
        let (work, _) = Workload::primary_packets(&camera, width, height, side);
        let name = file_name(mesh);
        let packet = side * side;
        let (base_seconds, base_hits) = measure_without_bvh(
            IntersectorKind::MollerPre,
            Simd::Scalar,
            &soa,
            &work.rays,
            packet,
            runs,
        );
        let triangles = flat.triangle_count();
        for &kind in &kinds {
            for simd in Simd::available() {
                let (seconds, hits) = if kind == IntersectorKind::MollerPre && simd == Simd::Scalar
                {
                    (base_seconds, base_hits.clone())
                } else {
                    measure_without_bvh(kind, simd, &soa, &work.rays, packet, runs)
                };
                let same = hits
                    .iter()
                    .zip(&base_hits)
                    .filter(|(a, b)| a.triangle == b.triangle)
                    .count() as f64
                    / hits.len().max(1) as f64;
                let mrays = work.rays.len() as f64 / seconds / 1e6;
                let mtests = mrays * triangles as f64;
                let speedup = base_seconds / seconds;
                if json {
                    println!(
                        "{}",
                        serde_json::json!({
                            "mesh": name, "triangles": triangles, "rays": work.rays.len(),
                            "packet": format!("{side}x{side}"), "intersector": kind.name(),
                            "simd": simd.name(), "threads": rayon::current_num_threads(),
                            "seconds": seconds, "mrays_per_s": mrays, "mtests_per_s": mtests,
                            "speedup_over_scalar_moller_pre": speedup, "same_hits": same,
                        })
                    );
                } else {
                    println!(
                        "{name:<22} {triangles:>9} {:<14} {:<6} {seconds:>9.4} {mrays:>9.3} {mtests:>10.1} {speedup:>7.2}x {:>7.3}%",
                        kind.name(), simd.name(), 100.0 * same
                    );
                }
            }
        }
    }
    Ok(())
}

fn bench_packets(
    meshes: &[String],
    kinds: &[RayKind],
    sides: &[usize],
    intersector: IntersectorKind,
    (width, height): (usize, usize),
    runs: usize,
    json: bool,
) -> Result<()> {
    if !json {
        println!(
            "{:<22} {:<8} {:<22} {:>9} {:>8} {:>8} {:>9} {:>8} {:>5}",
            "mesh",
            "workload",
            "traversal",
            "Mrays/s",
            "box/ray",
            "tri/ray",
            "seconds",
            "speedup",
            "same"
        );
    }
    for mesh in meshes {
        let scene = load(mesh)?;
        let name = file_name(mesh);
        let accel = SceneAccel::build(&scene, &BuildSettings::default());
        for &kind in kinds {
            let work = Workload::generate(kind, &scene, &accel, width, height, 1);
            let grouped: Vec<(usize, Workload, Vec<u32>)> = sides
                .iter()
                .map(|&side| {
                    let (w, starts) = work.grouped(side);
                    (side, w, starts)
                })
                .collect();
            // Alternate configurations each round; runs = 1 per call, so every call
            // also counts once (untimed).
            let mut results: Vec<Vec<rtmesh::trace::TraceRun>> = vec![Vec::new(); sides.len() + 1];
            for _ in 0..runs.max(1) {
                results[0].push(workload::measure(&accel, &work, 1));
                for (k, (_, w, starts)) in grouped.iter().enumerate() {
                    results[k + 1].push(intersector.dispatch(MeasurePackets(&accel, w, starts, 1)));
                }
            }
            let median = |runs: &[rtmesh::trace::TraceRun]| {
                workload::median(&runs.iter().map(|r| r.seconds).collect::<Vec<_>>())
            };
            let base = median(&results[0]);
            let reference = results[0][0].hit_checksum;
            for (k, runs) in results.iter().enumerate() {
                let label = if k == 0 {
                    "single (builtin)".to_owned()
                } else {
                    let side = grouped[k - 1].0;
                    format!("{side}x{side} {}", intersector.name())
                };
                let seconds = median(runs);
                let run = &runs[0];
                let mrays = run.rays as f64 / seconds / 1e6;
                let same = run.hit_checksum == reference;
                if json {
                    println!(
                        "{}",
                        serde_json::json!({
                            "mesh": name, "workload": kind.name(), "traversal": label,
                            "rays": run.rays, "threads": rayon::current_num_threads(),
                            "seconds": seconds, "mrays_per_s": mrays,
                            "box_tests_per_ray": run.box_tests_per_ray,
                            "tri_tests_per_ray": run.tri_tests_per_ray,
                            "speedup": base / seconds, "same_hits_checksum": same,
                        })
                    );
                } else {
                    println!(
                        "{name:<22} {:<8} {label:<22} {mrays:>9.2} {:>8.2} {:>8.2} {seconds:>9.4} {:>7.2}x {:>5}",
                        kind.name(), run.box_tests_per_ray, run.tri_tests_per_ray, base / seconds,
                        if same { "yes" } else { "ties" }
                    );
                }
            }
        }
    }
    Ok(())
}

fn print_lint(name: &str, report: &LintReport) {
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

/// How many findings of one kind `rtmesh lint` prints (a scene of many geometries or
/// placements may have thousands).
const PRINTED_PER_KIND: usize = 10;

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

/// One workload traced through the input and the repaired scene.
#[derive(serde::Serialize)]
struct BeforeAfter {
    workload: &'static str,
    rays: usize,
    box_before: f64,
    box_after: f64,
    tri_before: f64,
    tri_after: f64,
    mrays_before: f64,
    mrays_after: f64,
}

/// Trace the same primary and diffuse rays through `before` and `after`, alternating
/// `runs` rounds; medians and counts per ray. Adds its steps (the builds, then each
/// round of each workload) to `bar` and moves it on through them.
fn measure_before_after(
    before: &Scene,
    after: &Scene,
    (width, height): (usize, usize),
    runs: usize,
    bar: &ProgressBar,
) -> Vec<BeforeAfter> {
    const WORKLOADS: [RayKind; 2] = [RayKind::Primary, RayKind::Diffuse];
    bar.inc_length((1 + WORKLOADS.len() * runs.max(1)) as u64);
    bar.set_message("building the BVHs before and after");
    let accel_before = SceneAccel::build(before, &BuildSettings::default());
    let accel_after = SceneAccel::build(after, &BuildSettings::default());
    bar.inc(1);
    WORKLOADS
        .into_iter()
        .map(|kind| {
            bar.set_message(format!("tracing {} rays before and after", kind.name()));
            let work = Workload::generate(kind, before, &accel_before, width, height, 1);
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for _ in 0..runs.max(1) {
                a.push(workload::measure(&accel_before, &work, 1));
                b.push(workload::measure(&accel_after, &work, 1));
                bar.inc(1);
            }
            let median = |runs: &[rtmesh::trace::TraceRun]| {
                workload::median(&runs.iter().map(|r| r.seconds).collect::<Vec<_>>())
            };
            let rays = work.rays.len();
            BeforeAfter {
                workload: kind.name(),
                rays,
                box_before: a[0].box_tests_per_ray,
                box_after: b[0].box_tests_per_ray,
                tri_before: a[0].tri_tests_per_ray,
                tri_after: b[0].tri_tests_per_ray,
                mrays_before: rays as f64 / median(&a) / 1e6,
                mrays_after: rays as f64 / median(&b) / 1e6,
            }
        })
        .collect()
}

//! `rtmesh dynamic`: an animated mesh traced frame by frame, with its BVH rebuilt,
//! refitted, or built over precomputed clusters.

use super::trace::Packets;
use crate::args::{load, parse_size, Rays};
use crate::output::{emit, json_line, steps_bar};
use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use rtmesh::animate::{Animation, Motion};
use rtmesh::bvh::BuildSettings;
use rtmesh::cluster::{
    ClusterFrames, ClusterMethod, Clusters, Grouping, Inside, MAX_FLAT_TRIANGLES,
};
use rtmesh::progress::Progress;
use rtmesh::trace::intersect::IntersectorKind;
use rtmesh::trace::measure::{measure, measure_packets_by_kind, median};
use rtmesh::trace::run::trace_closest;
use rtmesh::trace::{Hit, NoCounters, RayKind, SceneAccel, Workload};
use rtmesh::Scene;
use rtmesh_lab::harness::same_triangle_share;
use serde::Serialize;

/// How each frame's BVH is made.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Build {
    /// A full per-triangle binned-SAH build every frame.
    Rebuild,
    /// Frame 0's BVH, its boxes refitted to each frame.
    Refit,
    /// A BVH over the boxes of clusters found once on frame 0 (`rtmesh cluster`).
    Clusters,
    /// Embree rebuilding at RTC_BUILD_QUALITY_LOW every frame (`--features embree`).
    #[cfg(feature = "embree")]
    #[value(name = "embree-low")]
    #[serde(rename = "embree-low")]
    EmbreeLow,
    /// Embree rebuilding at RTC_BUILD_QUALITY_MEDIUM every frame.
    #[cfg(feature = "embree")]
    #[value(name = "embree-medium")]
    #[serde(rename = "embree-medium")]
    EmbreeMedium,
    /// Embree refitting frame 0's BVH (RTC_BUILD_QUALITY_REFIT).
    #[cfg(feature = "embree")]
    #[value(name = "embree-refit")]
    #[serde(rename = "embree-refit")]
    EmbreeRefit,
}

impl Build {
    /// The build's name on the command line.
    fn name(self) -> String {
        self.to_possible_value()
            .map_or_else(String::new, |v| v.get_name().to_owned())
    }

    /// The Embree quality this build stands for, if it is Embree's.
    #[cfg(feature = "embree")]
    fn embree(self) -> Option<rtmesh_lab::embree::Quality> {
        use rtmesh_lab::embree::Quality;
        match self {
            Build::EmbreeLow => Some(Quality::Low),
            Build::EmbreeMedium => Some(Quality::Medium),
            Build::EmbreeRefit => Some(Quality::Refit),
            _ => None,
        }
    }
}

/// What a cluster is inside the per-frame BVH.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum InsideArg {
    /// One leaf of all its triangles.
    Flat,
    /// An 8-wide node over its 4-triangle blocks.
    Node,
}

/// Animate a mesh and trace every frame: build ms, trace ms, Mrays/s, box and triangle
/// tests per ray, SAH cost and a hit checksum per frame, and their sums.
///
/// Motions: twist (about +Y, up to 90° at the top), bend (about X through the bottom),
/// wave (a sine along the longest axis), explode (pieces, or cells of a 10³ grid for one
/// piece, thrown out from the centre with a spin). Frame f of N is the motion at phase
/// f / (N − 1). With --motion gltf, frame f plays the animation at the time f / (N − 1)
/// of the way from its first key to its last.
///
/// Examples:
///   rtmesh dynamic dragon.ply --motion explode --frames 8 --build clusters
///   rtmesh dynamic BrainStem.glb --motion gltf --frames 16 --build rebuild --json
#[derive(clap::Args)]
pub struct Args {
    /// The mesh file, or builtin:NAME (its first geometry, placed once; with --motion
    /// gltf the whole scene in world space).
    mesh: String,
    /// twist, bend, wave, explode, or gltf / gltf:NAME (the file's first animation, or
    /// the one called or numbered NAME: skins, node channels and morph targets).
    #[arg(long)]
    motion: Motion,
    /// Frames, from the rest pose to the strongest motion.
    #[arg(long, default_value_t = 8)]
    frames: usize,
    /// rebuild, refit or clusters; with --features embree also embree-low, embree-medium
    /// and embree-refit (Embree 3 on the same rays; its SAH is not known: NaN). Several,
    /// comma separated, are run in turn for --rounds and compared with the first in one
    /// table of medians (JSON: one line a build).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "clusters")]
    build: Vec<Build>,
    /// With several builds: rounds of all of them in turn (medians are reported).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u64).range(1..=100))]
    rounds: u64,
    /// Clustering method: grow or contract (by Acc(k)), or meshopt (meshoptimizer's
    /// spatial clusters).
    #[arg(long, default_value = "grow")]
    method: ClusterMethod,
    /// MaxSize of the clusters.
    #[arg(long, default_value_t = rtmesh::cluster::DEFAULT_MAX_SIZE)]
    max_size: f32,
    /// MaxCount: most triangles per cluster (1..=256; at most 60 with --inside flat).
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=256))]
    max_count: u32,
    #[command(flatten)]
    refinement: super::cluster::Refinement,
    /// With --build clusters: flat (one leaf of all a cluster's triangles, as the
    /// slides) or node (8-wide nodes over the cluster's 4-triangle blocks, one level up
    /// to 32 triangles and two above, refitted each frame).
    #[arg(long, value_enum, default_value = "node")]
    inside: InsideArg,
    /// With --build clusters: how the top tree's leaves gather up to 8 clusters: once,
    /// over the rest pose (rest: each frame builds over an eighth as many boxes, and a
    /// group's clusters stay together however far they move apart), or by every
    /// frame's build (frame, as in the slides: traces up to 14% faster when the mesh
    /// comes apart, builds 1.6x slower).
    #[arg(long, default_value = "rest")]
    groups: Grouping,
    /// Ray packets of neighbouring pixels through rtmesh's builds (8x8 primary packets
    /// over the cluster BVH test the slides' point that packets survive clusters).
    /// Default none: every build, Embree's too, traces the same single rays; auto
    /// picks 8x8 for primary rays as `trace` does. Embree builds always trace single
    /// rays.
    #[arg(long, value_enum, default_value = "none")]
    packet: Packets,
    /// Which rays (primary or diffuse).
    #[arg(long, value_enum, default_value = "primary")]
    rays: Rays,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x1024", value_parser = parse_size)]
    size: (usize, usize),
    /// Timed trace runs per frame (median).
    #[arg(long, default_value_t = 3)]
    runs: usize,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// One frame's figures.
#[derive(Serialize)]
struct Frame {
    frame: usize,
    build_ms: f64,
    trace_ms: f64,
    mrays_per_s: f64,
    box_tests_per_ray: f64,
    tri_tests_per_ray: f64,
    sah_cost: f32,
    hit_checksum: u64,
}

/// Sums over the frames.
#[derive(Serialize)]
struct Total {
    build_ms: f64,
    trace_ms: f64,
}

/// The clusters' method and their place in the per-frame BVH.
#[derive(Clone, Copy, Serialize)]
struct Arrangement {
    method: ClusterMethod,
    max_count: u32,
    inside: Inside,
    groups: Grouping,
}

/// What `dynamic` measured.
#[derive(Serialize)]
pub struct Report {
    mesh: String,
    motion: Motion,
    build: Build,
    ray_kind: &'static str,
    /// `NxN` packets through rtmesh's builds, or `none`.
    packet: String,
    triangles: usize,
    /// Clusters (for `--build clusters`).
    clusters: Option<usize>,
    /// Milliseconds to find the clusters, once (for `--build clusters`).
    precompute_ms: Option<f64>,
    /// How the clusters were found and arranged (for `--build clusters`).
    arrangement: Option<Arrangement>,
    frames: Vec<Frame>,
    total: Total,
}

impl Frame {
    /// Frame `frame`'s row: its build time, the trace run and the BVH's SAH cost.
    fn of(frame: usize, build_ms: f64, run: &rtmesh::trace::TraceRun, sah_cost: f32) -> Self {
        Self {
            frame,
            build_ms,
            trace_ms: 1e3 * run.seconds,
            mrays_per_s: run.mrays_per_s,
            box_tests_per_ray: run.box_tests_per_ray,
            tri_tests_per_ray: run.tri_tests_per_ray,
            sah_cost,
            hit_checksum: run.hit_checksum,
        }
    }
}

/// Animate, build, trace, report; several builds are alternated over `--rounds`.
pub fn run(args: Args) -> Result<()> {
    let kind = RayKind::from(args.rays);
    if kind == RayKind::Shadow {
        bail!("--rays shadow is not measured by dynamic: use primary or diffuse");
    }
    if args.frames == 0 {
        bail!("--frames must be at least 1");
    }
    let side = args.packet.side(kind, true);
    let scene = load(&args.mesh)?;
    let (mesh, animation) = Animation::of(&scene, &args.motion)
        .with_context(|| format!("{}: --motion {}", args.mesh, args.motion))?;
    let settings = super::cluster::settings(args.max_count, args.max_size, &args.refinement);
    let inside = match args.inside {
        InsideArg::Flat => Inside::Flat,
        InsideArg::Node => Inside::Node,
    };
    if inside == Inside::Flat && args.max_count as usize > MAX_FLAT_TRIANGLES {
        bail!(
            "--inside flat holds at most {MAX_FLAT_TRIANGLES} triangles a cluster (one leaf of 15 blocks); --max-count is {}",
            args.max_count
        );
    }
    let (clusters, precompute_ms) = if args.build.contains(&Build::Clusters) {
        let start = std::time::Instant::now();
        let clusters = args.method.cluster(&mesh, &settings);
        (Some(clusters), Some(1e3 * start.elapsed().as_secs_f64()))
    } else {
        (None, None)
    };
    let rounds = if args.build.len() > 1 {
        args.rounds as usize
    } else {
        1
    };
    let bar = steps_bar(args.frames * args.build.len() * rounds);
    let play = Play {
        args: &args,
        kind,
        side,
        mesh: &mesh,
        animation: &animation,
        inside,
        bar: &bar,
    };
    let packet = match side {
        1 => "none".to_owned(),
        side => format!("{side}x{side}"),
    };
    // Each build's runs, a round each.
    let mut runs: Vec<Vec<Run>> = args.build.iter().map(|_| Vec::new()).collect();
    // With several builds: the first build's first-round hits, frame by frame.
    let mut reference: Option<Vec<Vec<Hit>>> = None;
    for _ in 0..rounds {
        for (b, &build) in args.build.iter().enumerate() {
            let (frames, hits) = play.frames(build, clusters.as_ref())?;
            let same_hits = match &reference {
                None => {
                    reference = Some(hits);
                    1.0
                }
                Some(first) => hits
                    .iter()
                    .zip(first)
                    .map(|(h, r)| same_triangle_share(h, r))
                    .fold(1.0, f64::min),
            };
            let is_clusters = build == Build::Clusters;
            let report = Report {
                mesh: args.mesh.clone(),
                motion: args.motion.clone(),
                build,
                ray_kind: kind.name(),
                packet: packet.clone(),
                triangles: mesh.triangle_count(),
                clusters: clusters.as_ref().filter(|_| is_clusters).map(|c| c.len()),
                precompute_ms: precompute_ms.filter(|_| is_clusters),
                arrangement: is_clusters.then_some(Arrangement {
                    method: args.method,
                    max_count: args.max_count,
                    inside,
                    groups: args.groups,
                }),
                total: Total {
                    build_ms: frames.iter().map(|f| f.build_ms).sum(),
                    trace_ms: frames.iter().map(|f| f.trace_ms).sum(),
                },
                frames,
            };
            runs[b].push(Run { report, same_hits });
        }
    }
    bar.0.finish_and_clear();
    if let [single] = &runs[..] {
        return emit(&single[0].report, args.json, print);
    }
    let sides = Side::of_all(&runs);
    if args.json {
        for side in &sides {
            println!("{}", json_line(side));
        }
    } else {
        print_sides(&runs[0][0].report, rounds, &sides);
    }
    Ok(())
}

/// What every build's frames share.
struct Play<'a> {
    args: &'a Args,
    kind: RayKind,
    side: usize,
    mesh: &'a rtmesh::TriMesh,
    animation: &'a Animation,
    inside: Inside,
    bar: &'a crate::output::Bar,
}

/// One build's report in one round, and the smallest share over its frames of rays
/// that hit the triangle the first build hit in its first round.
struct Run {
    report: Report,
    same_hits: f64,
}

impl Play<'_> {
    /// Whether builds are compared: then each frame's closest hits are kept.
    fn compares(&self) -> bool {
        self.args.build.len() > 1
    }

    /// Every frame built by `build` and traced, and (when it [`compares`](Self::compares)) each frame's
    /// closest hits, traced once more untimed.
    fn frames(
        &self,
        build: Build,
        clusters: Option<&Clusters>,
    ) -> Result<(Vec<Frame>, Vec<Vec<Hit>>)> {
        let args = self.args;
        let mut refitted: Option<SceneAccel> = None;
        let mut cluster_frames = clusters
            .filter(|_| build == Build::Clusters)
            .map(|c| ClusterFrames::new(c, self.inside, self.mesh).grouped(args.groups, self.mesh));
        #[cfg(feature = "embree")]
        let mut embree: Option<rtmesh_lab::embree::EmbreeScene> = None;
        let mut frames = Vec::with_capacity(args.frames);
        let mut hits = Vec::new();
        for f in 0..args.frames {
            self.bar.message(&format!("{}, frame {f}", build.name()));
            let mut frame = self.mesh.clone();
            frame.positions = self
                .animation
                .positions(f as f32 / (args.frames.max(2) - 1) as f32);
            let frame_scene = Scene::from_mesh(frame);
            #[cfg(feature = "embree")]
            if let Some(quality) = build.embree() {
                // Embree's own timing of its build or commit; SAH is not known for it.
                let build_ms = match embree.as_mut() {
                    Some(e) => 1e3 * e.update_positions(0, &frame_scene.meshes[0].positions)?,
                    None => {
                        let threads = rayon::current_num_threads();
                        let e = rtmesh_lab::embree::EmbreeScene::build_dynamic(
                            &frame_scene,
                            quality,
                            threads,
                        )?;
                        let ms = 1e3 * e.build_seconds;
                        embree = Some(e);
                        ms
                    }
                };
                let e = embree.as_ref().expect("built above");
                let (width, height) = args.size;
                let work = Workload::generate(self.kind, &frame_scene, e, width, height, 1);
                let run = measure(e, &work, args.runs);
                if self.compares() {
                    hits.push(trace_closest::<NoCounters>(e, &work.rays).0);
                }
                frames.push(Frame::of(f, build_ms, &run, f32::NAN));
                self.bar.advance(1);
                continue;
            }
            let start = std::time::Instant::now();
            let accel = match build {
                Build::Rebuild => SceneAccel::build(&frame_scene, &BuildSettings::default()),
                Build::Refit => {
                    let mut accel = refitted.take().unwrap_or_else(|| {
                        SceneAccel::build(&frame_scene, &BuildSettings::default())
                    });
                    accel.refit(&frame_scene);
                    accel
                }
                #[cfg(feature = "embree")]
                Build::EmbreeLow | Build::EmbreeMedium | Build::EmbreeRefit => {
                    unreachable!("traced above")
                }
                Build::Clusters => cluster_frames
                    .as_mut()
                    .expect("clusters were found")
                    .build(&frame_scene.meshes[0]),
            };
            let build_ms = 1e3 * start.elapsed().as_secs_f64();
            let (width, height) = args.size;
            let work = Workload::generate(self.kind, &frame_scene, &accel, width, height, 1);
            let run = if self.side > 1 {
                let (packed, starts) = work.grouped(self.side);
                let intersector = IntersectorKind::MollerPacket;
                measure_packets_by_kind(intersector, &accel, &packed, &starts, args.runs)
            } else {
                measure(&accel, &work, args.runs)
            };
            if self.compares() {
                hits.push(trace_closest::<NoCounters>(&accel, &work.rays).0);
            }
            frames.push(Frame::of(f, build_ms, &run, accel.stats().sah_cost));
            if build == Build::Refit {
                refitted = Some(accel);
            } else if let Some(frames) = cluster_frames.as_mut() {
                frames.recycle(accel);
            }
            self.bar.advance(1);
        }
        Ok((frames, hits))
    }
}

/// One build against the first one listed, medians over the rounds.
#[derive(Serialize)]
struct Side {
    mesh: String,
    motion: Motion,
    build: Build,
    rounds: usize,
    /// Build ms a frame: the median over the frames after the first (frame 0 is a full
    /// build for refits), then over the rounds.
    build_ms: f64,
    /// The first build's `build_ms` over this one's.
    build_speedup: f64,
    /// Trace ms of each frame, medians over the rounds.
    trace_ms: Vec<f64>,
    /// The first build's summed trace ms over this one's.
    trace_speedup: f64,
    /// The smallest share, over frames and rounds, of rays whose closest hit is the
    /// triangle the first build's hit in its first round (a ray that meets two
    /// triangles at one distance, on a shared edge, may name either).
    same_hits: f64,
}

impl Side {
    /// The sides of every build's runs (one a round).
    fn of_all(runs: &[Vec<Run>]) -> Vec<Side> {
        let build_ms = |runs: &[Run]| {
            let per_round: Vec<f64> = runs
                .iter()
                .map(|Run { report: r, .. }| {
                    let skip = usize::from(r.frames.len() > 1);
                    let later: Vec<f64> = r.frames.iter().skip(skip).map(|f| f.build_ms).collect();
                    median(&later)
                })
                .collect();
            median(&per_round)
        };
        let trace_ms = |runs: &[Run]| -> Vec<f64> {
            (0..runs[0].report.frames.len())
                .map(|f| {
                    let per_round: Vec<f64> =
                        runs.iter().map(|r| r.report.frames[f].trace_ms).collect();
                    median(&per_round)
                })
                .collect()
        };
        let first = &runs[0];
        let (first_build, first_trace) = (build_ms(first), trace_ms(first).iter().sum::<f64>());
        runs.iter()
            .map(|runs| {
                let r = &runs[0].report;
                let (build, trace) = (build_ms(runs), trace_ms(runs));
                Side {
                    mesh: r.mesh.clone(),
                    motion: r.motion.clone(),
                    build: r.build,
                    rounds: runs.len(),
                    build_ms: build,
                    build_speedup: first_build / build,
                    trace_speedup: first_trace / trace.iter().sum::<f64>(),
                    trace_ms: trace,
                    same_hits: runs.iter().map(|r| r.same_hits).fold(1.0, f64::min),
                }
            })
            .collect()
    }
}

fn print_sides(r: &Report, rounds: usize, sides: &[Side]) {
    println!(
        "{}: {} triangles, {} over {} frames, {} rays, packets {}, {} rounds of the builds in turn (medians; × is against {})",
        r.mesh,
        r.triangles,
        r.motion,
        r.frames.len(),
        r.ray_kind,
        r.packet,
        rounds,
        sides[0].build.name()
    );
    println!(
        "{:<14} {:>10} {:>8} {:>9} {:>10}  trace ms by frame",
        "build", "build ms", "×", "trace ×", "same hits"
    );
    for side in sides {
        let trace: Vec<String> = side.trace_ms.iter().map(|t| format!("{t:.2}")).collect();
        println!(
            "{:<14} {:>10.2} {:>8.2} {:>9.2} {:>10}  {}",
            side.build.name(),
            side.build_ms,
            side.build_speedup,
            side.trace_speedup,
            format!("{:.3}%", 100.0 * side.same_hits),
            trace.join(" ")
        );
    }
}

fn print(r: &Report) {
    println!(
        "{}: {} triangles, {} over {} frames, {:?}, {} rays, packets {}{}",
        r.mesh,
        r.triangles,
        r.motion,
        r.frames.len(),
        r.build,
        r.ray_kind,
        r.packet,
        match (r.clusters, r.precompute_ms, r.arrangement) {
            (Some(c), Some(ms), Some(a)) => format!(
                " ({c} clusters of up to {} by {} found in {ms:.1} ms; inside {}, groups {})",
                a.max_count,
                a.method.name(),
                a.inside.name(),
                a.groups.name()
            ),
            _ => String::new(),
        }
    );
    println!(
        "{:>6} {:>10} {:>10} {:>9} {:>9} {:>9} {:>8} {:>18}",
        "frame", "build ms", "trace ms", "Mrays/s", "box/ray", "tri/ray", "SAH", "hits"
    );
    for f in &r.frames {
        println!(
            "{:>6} {:>10.2} {:>10.2} {:>9.2} {:>9.2} {:>9.2} {:>8.2} {:>18x}",
            f.frame,
            f.build_ms,
            f.trace_ms,
            f.mrays_per_s,
            f.box_tests_per_ray,
            f.tri_tests_per_ray,
            f.sah_cost,
            f.hit_checksum
        );
    }
    println!(
        "{:>6} {:>10.2} {:>10.2}",
        "total", r.total.build_ms, r.total.trace_ms
    );
}

//! `rtmesh bench strips`: the thesis's Table 3.2 experiment (a rasterization
//! stripifier against Strip-RT on one representation), redone on these meshes, beside
//! triangles, pairs and Embree. Per mesh (flattened, welded exactly) and method:
//! indices per triangle, bytes per triangle (hierarchy + topology, and with the f32
//! positions), and the same rays through each structure in alternating rounds: box and
//! triangle tests per ray, Mrays/s, and the share of rays whose first hit is the same
//! input triangle as through triangle leaves.

use crate::harness::{alternate, median, same_triangle_share, seconds};
use rtmesh::bvh::BuildSettings;
use rtmesh::mesh::TooManyToFlatten;
use rtmesh::pair::PairMethod;
use rtmesh::progress::Progress;
use rtmesh::strip::{meshopt, sah, Strips};
use rtmesh::trace::measure::measure;
use rtmesh::trace::run::trace_closest;
use rtmesh::trace::strip::{Inside, StripAccel, MAX_TRACED_LENGTH};
use rtmesh::trace::{Hit, NoCounters, RayKind, SceneAccel, TraceRun, Tracer, Workload};
use rtmesh::{Ray, Scene, TriMesh};
use serde::Serialize;

/// One method on one workload.
#[derive(Clone, Debug, Serialize)]
pub struct StripRow {
    /// Mesh name.
    pub mesh: String,
    /// triangles, pairs, sah, meshopt, embree or embree-compact.
    pub method: String,
    /// Workload kind.
    pub workload: &'static str,
    /// Vertex indices per triangle (3 for triangles and Embree).
    pub indices_per_triangle: f64,
    /// Hierarchy and topology bytes per triangle, the vertex buffer not counted (for
    /// Embree, everything it allocated less the positions; triangle and pair leaves
    /// hold their own corners, so for them this is the whole structure).
    pub bytes_per_triangle: f64,
    /// With the f32 positions.
    pub total_bytes_per_triangle: f64,
    /// Median Mrays/s.
    pub mrays_per_s: f64,
    /// Box tests per ray (not counted for Embree).
    pub box_tests_per_ray: f64,
    /// Triangle tests per ray (pair tests count two).
    pub tri_tests_per_ray: f64,
    /// Share of rays with the same first hit as triangle leaves.
    pub same_hits: f64,
    /// Seconds to make the strips or pairs (0 for triangles and Embree).
    pub prepare_seconds: f64,
}

/// A structure to trace.
enum Leaves {
    Triangles(SceneAccel),
    Pairs(SceneAccel<rtmesh::trace::Pair4>),
    Strips(Box<StripAccel>),
    #[cfg(feature = "embree")]
    Embree(crate::embree::EmbreeScene),
}

impl Leaves {
    fn closest(&self, rays: &[Ray]) -> Vec<Hit> {
        fn go(t: &impl Tracer, rays: &[Ray]) -> Vec<Hit> {
            trace_closest::<NoCounters>(t, rays).0
        }
        match self {
            Leaves::Triangles(a) => go(a, rays),
            Leaves::Pairs(a) => go(a, rays),
            Leaves::Strips(a) => go(a.as_ref(), rays),
            #[cfg(feature = "embree")]
            Leaves::Embree(a) => go(a, rays),
        }
    }

    fn counted(&self, work: &Workload) -> TraceRun {
        match self {
            Leaves::Triangles(a) => measure(a, work, 1),
            Leaves::Pairs(a) => measure(a, work, 1),
            Leaves::Strips(a) => measure(a.as_ref(), work, 1),
            #[cfg(feature = "embree")]
            Leaves::Embree(a) => measure(a, work, 1),
        }
    }
}

struct Config {
    method: String,
    indices_per_triangle: f64,
    bytes: usize,
    total_bytes: usize,
    prepare_seconds: f64,
    leaves: Leaves,
}

/// Settings of the table.
#[derive(Clone, Debug)]
pub struct StripTable {
    /// Most triangles per strip (at most [`MAX_TRACED_LENGTH`]).
    pub max_length: usize,
    /// Most cuts of Strip-RT's tunnelling moves (`StripSettings::tunnel_cuts`).
    pub tunnel_cuts: usize,
    /// The partition of Strip-RT's ordering.
    pub partition: sah::PartitionMethod,
    /// Strips per BVH leaf.
    pub strips_per_leaf: usize,
    /// How a strip's triangles are tested.
    pub inside: Inside,
    /// Workloads.
    pub kinds: Vec<RayKind>,
    /// Image size.
    pub size: (usize, usize),
    /// Timed rounds.
    pub runs: usize,
}

fn strip_config(
    mesh: &TriMesh,
    method: &str,
    strips: Strips,
    seconds: f64,
    table: &StripTable,
) -> Config {
    let accel = StripAccel::build(
        &mesh.positions,
        &strips,
        table.strips_per_leaf,
        table.inside,
    )
    .expect("strips are cut at MAX_TRACED_LENGTH");
    Config {
        method: method.into(),
        indices_per_triangle: strips.indices_per_triangle(),
        bytes: accel.hierarchy_bytes() + accel.topology_bytes(),
        total_bytes: accel.hierarchy_bytes() + accel.topology_bytes() + accel.position_bytes(),
        prepare_seconds: seconds,
        leaves: Leaves::Strips(Box::new(accel)),
    }
}

/// The table's rows for `scene`.
pub fn strip_rows(
    name: &str,
    scene: &Scene,
    table: &StripTable,
    progress: &dyn Progress,
) -> Result<Vec<StripRow>, TooManyToFlatten> {
    let mesh = rtmesh::mesh::weld_exact(&scene.flatten()?).mesh;
    let flat = Scene::from_mesh(mesh.clone());
    let n = mesh.triangle_count().max(1) as f64;
    let max_length = table.max_length.clamp(1, MAX_TRACED_LENGTH);
    let rounds = table.runs.max(1);
    progress.message(&format!("{name}: building"));
    let mut configs = Vec::new();
    let triangles = SceneAccel::build(&flat, &BuildSettings::default());
    configs.push(Config {
        method: "triangles".into(),
        indices_per_triangle: 3.0,
        bytes: triangles.stats().bytes,
        total_bytes: triangles.stats().bytes,
        prepare_seconds: 0.0,
        leaves: Leaves::Triangles(triangles),
    });
    let mut pairings = Vec::new();
    let pair_seconds =
        seconds(|| pairings = rtmesh::pair::weld_and_pair(&flat, PairMethod::SahMax).1);
    let pairs = SceneAccel::build_paired(&flat, &pairings, &BuildSettings::default());
    let paired = pairings.iter().map(|p| p.paired_triangles()).sum::<usize>() as f64;
    configs.push(Config {
        method: "pairs".into(), // sah-max, optimize's default candidate
        indices_per_triangle: 3.0 * (n - paired / 2.0) / n + paired / 2.0 / n,
        bytes: pairs.stats().bytes,
        total_bytes: pairs.stats().bytes,
        prepare_seconds: pair_seconds,
        leaves: Leaves::Pairs(pairs),
    });
    let mut strips = Strips::default();
    let t = seconds(|| {
        strips = sah::stripify(
            &mesh,
            &sah::StripSettings {
                max_length,
                tunnel_cuts: table.tunnel_cuts,
                partition: table.partition,
            },
        )
    });
    configs.push(strip_config(&mesh, "sah", strips, t, table));
    let mut theirs = None;
    let t = seconds(|| theirs = Some(meshopt::stripify(&mesh, max_length)));
    let theirs = theirs.expect("just made");
    configs.push(strip_config(&mesh, "meshopt", theirs.strips, t, table));
    #[cfg(feature = "embree")]
    for (method, build) in [
        (
            "embree",
            crate::embree::EmbreeScene::build as fn(&Scene, usize) -> _,
        ),
        ("embree-compact", crate::embree::EmbreeScene::build_compact),
    ] {
        if let Ok(embree) = build(&flat, 1) {
            let positions = 12 * mesh.positions.len();
            configs.push(Config {
                method: method.into(),
                indices_per_triangle: 3.0,
                bytes: embree.bvh_bytes.saturating_sub(positions),
                total_bytes: embree.bvh_bytes,
                prepare_seconds: 0.0,
                leaves: Leaves::Embree(embree),
            });
        }
    }
    progress.add_steps((table.kinds.len() * configs.len() * (rounds + 2)) as u64);
    let mut rows = Vec::new();
    for &kind in &table.kinds {
        progress.message(&format!("{name}: tracing {} rays", kind.name()));
        let Leaves::Triangles(tri) = &configs[0].leaves else {
            unreachable!("triangle leaves come first")
        };
        let work = Workload::generate(kind, &flat, tri, table.size.0, table.size.1, 1);
        let reference = configs[0].leaves.closest(&work.rays);
        let times = alternate(rounds, &configs, |config| {
            let time = seconds(|| {
                std::hint::black_box(config.leaves.closest(&work.rays));
            });
            progress.advance(1);
            time
        });
        for (config, times) in configs.iter().zip(&times) {
            let hits = config.leaves.closest(&work.rays);
            let same = same_triangle_share(&hits, &reference);
            let counted = config.leaves.counted(&work);
            progress.advance(2);
            rows.push(StripRow {
                mesh: name.to_owned(),
                method: config.method.clone(),
                workload: kind.name(),
                indices_per_triangle: config.indices_per_triangle,
                bytes_per_triangle: config.bytes as f64 / n,
                total_bytes_per_triangle: config.total_bytes as f64 / n,
                mrays_per_s: work.rays.len() as f64 / median(times) / 1e6,
                box_tests_per_ray: counted.box_tests_per_ray,
                tri_tests_per_ray: counted.tri_tests_per_ray + 2.0 * counted.pair_tests_per_ray,
                same_hits: same,
                prepare_seconds: config.prepare_seconds,
            });
        }
    }
    Ok(rows)
}

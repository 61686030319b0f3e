//! `rtmesh::optimize`: the exact output on hand-built meshes, the map back to the input
//! (no triangle lost or duplicated), the hardware pairers' first-fit rules recovering
//! exactly rtmesh's pairs, the same first hits, on every real mesh in `RTMESH_DATA` and
//! on property-test meshes; and the checked-in JSON Schema of the report.

use glam::Vec3;
use proptest::prelude::*;
use rtmesh::data::mesh_data_dir;
use rtmesh::optimize::{
    optimize, optimize_mapped, MeasureOptions, OptimizeError, OptimizeOptions, Optimized, Target,
};
use rtmesh::pair::first_fit;
use rtmesh::{Scene, TriMesh};

fn no_measure() -> OptimizeOptions {
    OptimizeOptions {
        measure: None,
        ..OptimizeOptions::default()
    }
}

fn run(scene: &Scene, options: &OptimizeOptions) -> Optimized {
    optimize_mapped(scene, options, &()).unwrap_or_else(|e| panic!("{e}"))
}

/// Every output triangle maps to a distinct input triangle with the same corners
/// (world positions, possibly rotated, winding kept; bit for bit, attributes too, in
/// `attributes.rs`), and the ones missing are exactly as
/// many as the repairs removed.
fn assert_map_is_exact(input: &Scene, out: &Optimized, what: &str) {
    let mut seen = std::collections::HashSet::new();
    for (g, mesh) in out.scene.meshes.iter().enumerate() {
        for t in 0..mesh.triangle_count() {
            let (ig, it) = (
                out.input_geometry[g][t] as usize,
                out.input_triangle[g][t] as usize,
            );
            assert!(seen.insert((ig, it)), "{what}: input {ig}/{it} twice");
            // In world space, through each geometry's first instance: merged
            // geometries hold their parts' positions transformed.
            let o = world_corners(&out.scene, g, t);
            let i = world_corners(input, ig, it);
            let close = |a: Vec3, b: Vec3| (a - b).length() <= 1e-5 * (1.0 + a.length());
            assert!(
                (0..3).any(|r| (0..3).all(|k| close(o[k], i[(k + r) % 3]))),
                "{what}: geometry {g} triangle {t} is not input {ig}/{it}"
            );
        }
    }
    let r = &out.report.repairs;
    assert_eq!(
        seen.len() + r.removed_degenerate + r.removed_duplicates,
        input
            .meshes
            .iter()
            .map(TriMesh::triangle_count)
            .sum::<usize>(),
        "{what}: triangles lost"
    );
}

/// Corners of triangle `t` of geometry `g`, placed by the geometry's first instance
/// (as they are if it has none).
fn world_corners(scene: &Scene, g: usize, t: usize) -> [Vec3; 3] {
    let corners = scene.meshes[g].corners(t);
    match scene.instances.iter().find(|i| i.mesh == g) {
        Some(instance) => corners.map(|p| instance.transform.transform_point3(p)),
        None => corners,
    }
}

/// Embree's, HIPRT's and GPURT's first-fit rules find exactly the pairs written.
fn assert_first_fit_exact(out: &Optimized, what: &str) {
    let pairing = out.report.pairing.as_ref().expect("target pairs");
    assert!(pairing.first_fit.exact, "{what}: {:?}", pairing.first_fit);
    assert_eq!(
        pairing.first_fit.embree_window_32, out.report.pair_ratio,
        "{what}"
    );
    // Independently, on a geometry of one primitive: the oracles' pairs are 2k, 2k + 1.
    for (g, mesh) in out.scene.meshes.iter().enumerate() {
        if mesh.group_ids.iter().any(|&k| k != mesh.group_of(0))
            || mesh.material_ids.iter().any(|&m| m != mesh.material_ids[0])
        {
            continue;
        }
        let expected = out.pairing(g).pairs;
        assert_eq!(
            first_fit::embree_window(&mesh.triangles, 31).pairs,
            expected,
            "{what}"
        );
        assert_eq!(
            first_fit::waves(&mesh.triangles, 64).pairs,
            expected,
            "{what}"
        );
    }
}

/// `n` unit squares side by side, 2 apart, each as (b, b+1, b+2) and (b, b+2, b+3).
fn square_strip(n: usize) -> TriMesh {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for k in 0..n {
        let b = positions.len() as u32;
        for [x, y] in [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
            positions.push(Vec3::new(x + 2.0 * k as f32, y, 0.0));
        }
        triangles.push([b, b + 1, b + 2]);
        triangles.push([b, b + 2, b + 3]);
    }
    TriMesh::new(positions, triangles)
}

#[test]
fn hand_built_mesh_gives_the_exact_output() {
    // Two unit squares (four triangles), then an exact copy of triangle 1 and a
    // zero-area triangle: the copy and the sliver go, the squares pair in order.
    let mut mesh = square_strip(2);
    mesh.triangles.push([0, 2, 3]);
    mesh.triangles.push([0, 1, 1]);
    let mesh = TriMesh::new(mesh.positions, mesh.triangles);
    let scene = Scene::from_mesh(mesh);
    let out = run(&scene, &no_measure());
    assert_eq!(out.report.repairs.removed_duplicates, 1);
    assert_eq!(out.report.repairs.removed_degenerate, 1);
    assert_eq!(out.report.pair_ratio, 1.0);
    assert_eq!(out.pair_counts, vec![2]);
    // The quad convention: (v0, v1, v2) and (v2, v1, v3), the shared edge v1–v2.
    assert_eq!(
        out.scene.meshes[0].triangles,
        vec![[1, 2, 0], [0, 2, 3], [5, 6, 4], [4, 6, 7]]
    );
    assert_eq!(out.input_triangle, vec![vec![0, 1, 2, 3]]);
    assert_eq!(out.report.pairing.as_ref().unwrap().method, "input-order");
    assert_map_is_exact(&scene, &out, "squares");
    assert_first_fit_exact(&out, "squares");
}

#[test]
fn unpaired_neighbours_get_their_own_corners() {
    // Two triangles over one edge, the same way round (a flipped neighbour): rtmesh
    // does not pair them, a first-fit pairer would, so the second gets its own copies.
    let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.5)];
    let scene = Scene::from_mesh(TriMesh::new(positions, vec![[0, 1, 2], [0, 1, 3]]));
    let out = run(&scene, &no_measure());
    assert_eq!(out.report.pair_ratio, 0.0);
    let first_fit = &out.report.pairing.as_ref().unwrap().first_fit;
    assert_eq!(first_fit.vertices_copied, 3);
    assert!(first_fit.exact);
    assert_eq!(out.scene.meshes[0].triangles[1], [4, 5, 6]);
    assert_map_is_exact(&scene, &out, "flipped neighbour");
}

#[test]
fn nothing_to_trace_and_unbuilt_targets_are_errors() {
    let nan = Vec3::splat(f32::NAN);
    let scene = Scene::from_mesh(TriMesh::new(vec![nan, nan, nan], vec![[0, 1, 2]]));
    assert_eq!(
        optimize(&scene, &no_measure()).unwrap_err(),
        OptimizeError::NothingToTrace { triangles: 1 }
    );
}

/// The strips and clusters targets: every input triangle once (the map exact), the
/// same first hits, and the sequences back to back over each geometry's triangles, each
/// strip's triangles sharing an edge with the one before, each cluster within its
/// limit.
#[test]
fn strips_and_clusters_targets_order_triangles_exactly() {
    for target in [Target::Strips, Target::Clusters] {
        for name in rtmesh::scenes::NAMES {
            let scene = rtmesh::scenes::by_name(name).unwrap();
            let options = OptimizeOptions {
                target,
                measure: Some(MeasureOptions {
                    size: (64, 64),
                    runs: 1,
                    ..MeasureOptions::default()
                }),
                ..OptimizeOptions::default()
            };
            let out = run(&scene, &options);
            assert_eq!(
                out.report.same_hits.as_ref().unwrap().different,
                0,
                "{name} {target}"
            );
            assert_map_is_exact(&scene, &out, name);
            for (g, mesh) in out.scene.meshes.iter().enumerate() {
                let lengths = &out.sequences[g];
                assert_eq!(
                    lengths.iter().sum::<u32>() as usize,
                    mesh.triangle_count(),
                    "{name} {target}"
                );
                let mut first = 0;
                for &length in lengths {
                    let range = first..first + length as usize;
                    if target == Target::Clusters {
                        assert!(
                            length as usize
                                <= rtmesh::cluster::ClusterSettings::default().max_triangles
                        );
                    } else {
                        for t in range.clone().skip(1) {
                            let [a, b] = [mesh.triangles[t - 1], mesh.triangles[t]];
                            let shared = a.iter().filter(|v| b.contains(v)).count();
                            assert!(
                                shared >= 2,
                                "{name}: strip triangles {} and {t} share an edge",
                                t - 1
                            );
                        }
                    }
                    let key = |t: usize| {
                        (
                            mesh.group_of(t),
                            mesh.material_ids.get(t).copied().unwrap_or(0),
                        )
                    };
                    assert!(
                        range.clone().all(|t| key(t) == key(first)),
                        "{name}: one primitive"
                    );
                    first = range.end;
                }
            }
        }
    }
}

#[test]
fn the_same_rays_hit_the_same_input_triangles() {
    for name in rtmesh::scenes::NAMES {
        let scene = rtmesh::scenes::by_name(name).unwrap();
        let options = OptimizeOptions {
            measure: Some(MeasureOptions {
                size: (64, 64),
                runs: 1,
                ..MeasureOptions::default()
            }),
            ..OptimizeOptions::default()
        };
        let out = run(&scene, &options);
        let same = out.report.same_hits.as_ref().unwrap();
        assert_eq!(same.different, 0, "{name}: {same:?}");
        let (before, after) = (
            out.report.before.as_ref().unwrap(),
            out.report.after.as_ref().unwrap(),
        );
        // Every primary ray measured is checked: 64 × 64, or fewer where the time
        // budget shrank the image (it does on a loaded machine, whose pilots run slow).
        assert_eq!(same.rays, before.primary.rays, "{name}");
        assert!(same.rays > 0 && same.rays <= 64 * 64, "{name}: {same:?}");
        assert!(
            after.primary.pair_tests_per_ray > 0.0,
            "{name}: pair leaves traced"
        );
        assert!(before.bvh_bytes > 0 && after.bvh_bytes > 0);
        assert_map_is_exact(&scene, &out, name);
        assert_first_fit_exact(&out, name);
    }
}

#[test]
fn every_real_mesh_optimizes_exactly() {
    let Some(dir) = mesh_data_dir() else { return };
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .chain(std::fs::read_dir(dir.join("animated")).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.extension()
                .is_some_and(|e| ["obj", "ply", "glb", "gltf"].contains(&e.to_str().unwrap()))
        })
        .collect();
    files.sort();
    assert!(files.len() >= 28, "{} meshes", files.len());
    for path in files {
        let what = path.display().to_string();
        let scene = rtmesh::io::read(&path).unwrap_or_else(|e| panic!("{e}"));
        let out = run(&scene, &no_measure());
        assert_map_is_exact(&scene, &out, &what);
        assert_first_fit_exact(&out, &what);
        let candidates = &out.report.pairing.as_ref().unwrap().candidates;
        let best = candidates.iter().map(|c| c.pair_ratio).fold(0.0, f64::max);
        assert!(
            out.report.pair_ratio >= best - 1e-9 || candidates.len() > 1,
            "{what}"
        );
        // Never fewer pairs than the input order's own consecutive pairs.
        assert!(
            out.report.pair_ratio >= candidates[0].pair_ratio - 1e-9,
            "{what}"
        );
    }
}

/// A grid of `n` × `n` quads, its triangles shuffled and rotated by `seed`.
fn shuffled_grid(n: usize, seed: u64) -> TriMesh {
    let grid = rtmesh::scenes::quad_grid(n);
    let mut rng = rtmesh::random::SplitMix64::new(seed);
    let mut triangles = grid.triangles.clone();
    for i in (1..triangles.len()).rev() {
        triangles.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
    }
    for t in &mut triangles {
        t.rotate_left((rng.next_u64() % 3) as usize);
    }
    TriMesh::new(grid.positions, triangles)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Shuffled grids: every triangle kept once with its corners, the pairs written
    /// are exactly what the first-fit pairers find, and the default pairs at least as
    /// many triangles as each candidate.
    #[test]
    fn shuffled_grids_pair_for_first_fit(n in 1usize..12, seed in any::<u64>()) {
        let scene = Scene::from_mesh(shuffled_grid(n, seed));
        let out = run(&scene, &no_measure());
        assert_map_is_exact(&scene, &out, "grid");
        assert_first_fit_exact(&out, "grid");
        for c in &out.report.pairing.as_ref().unwrap().candidates {
            prop_assert!(out.report.pair_ratio >= c.pair_ratio - 1e-12);
        }
    }
}

/// The JSON Schema of the report, generated by schemars, is the one checked in
/// (`RTMESH_BLESS=1` rewrites it).
#[test]
fn the_report_schema_is_checked_in() {
    let schema = schemars::schema_for!(rtmesh::optimize::OptimizeReport);
    let text = serde_json::to_string_pretty(&schema).unwrap() + "\n";
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../docs/optimize-report.schema.json");
    if std::env::var("RTMESH_BLESS").is_ok_and(|v| v == "1") {
        std::fs::write(&path, &text).unwrap();
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        checked_in == text,
        "{} is not what schemars generates: run RTMESH_BLESS=1 cargo test --release -p rtmesh --test optimize",
        path.display()
    );
    // And a report validates against its keys: every required key is present.
    let report = optimize(&Scene::from_mesh(square_strip(2)), &no_measure())
        .unwrap()
        .1;
    let json = serde_json::to_value(&report).unwrap();
    for key in schema.as_value()["required"].as_array().unwrap() {
        assert!(json.get(key.as_str().unwrap()).is_some(), "{key}");
    }
}

//! rtmesh and Embree trace the very same rays and must hit the same triangles (ties on
//! shared edges aside). Needs `--features embree` and libembree-dev; CI runs it.
#![cfg(feature = "embree")]

use rtmesh::trace::RayKind;
use rtmesh::Scene;
use rtmesh_lab::embree::EmbreeScene;
use rtmesh_lab::reference::{compare, CompareSettings};

fn assert_agrees(name: &str, scene: &Scene) {
    let settings = CompareSettings {
        kinds: vec![RayKind::Primary, RayKind::Diffuse, RayKind::Shadow],
        size: (192, 192),
        thread_counts: vec![1, 2],
        runs: 1,
        builds: 1,
    };
    let rows = compare::<EmbreeScene>(name, scene, &settings).expect("Embree builds");
    assert_eq!(rows.len(), 6);
    for row in rows {
        assert!(row.rays > 0);
        assert!(
            row.same_hits >= 0.999,
            "{name} {} on {} threads: only {:.4} of rays agree",
            row.workload,
            row.threads,
            row.same_hits
        );
        assert!(row.rtmesh_mrays_per_s > 0.0 && row.other_mrays_per_s > 0.0);
    }
}

#[test]
fn embree_hits_the_same_triangles_on_procedural_scenes() {
    assert_agrees(
        "blob",
        &Scene::from_mesh(rtmesh::scenes::scan_blob(20_000, 2)),
    );
    assert_agrees("room", &rtmesh::scenes::room());
    assert_agrees(
        "cylinder",
        &Scene::from_mesh(rtmesh::scenes::fan_cylinder(128)),
    );
}

#[test]
fn embree_hits_the_same_triangles_on_real_meshes() {
    let Some(dir) = rtmesh::data::mesh_data_dir() else {
        return;
    };
    for file in [
        "stanford-bunny.obj",
        "dragon_vrip_res2.ply",
        "2CylinderEngine.glb",
    ] {
        let scene = rtmesh::io::read(&dir.join(file)).unwrap();
        assert_agrees(file, &scene);
    }
}

/// `optimize`'s pairs given to Embree as quads (one QUAD geometry, unpaired triangles as
/// degenerate quads) hit the same input triangles as Embree on the input's triangles,
/// in a smaller BVH, on every built-in scene (the room has instances and groups).
#[test]
fn embree_quads_hit_the_same_triangles_in_fewer_bytes() {
    use rtmesh::optimize::OptimizeOptions;
    use rtmesh_lab::embree::EmbreeScene;
    use rtmesh_lab::tables::quads::same_hits;
    for name in rtmesh::scenes::NAMES {
        let scene = rtmesh::scenes::by_name(name).unwrap();
        let options = OptimizeOptions {
            measure: None,
            ..OptimizeOptions::default()
        };
        let optimized = rtmesh::optimize::optimize_mapped(&scene, &options, &()).unwrap();
        let pairings = optimized.pairings();
        let triangles = EmbreeScene::build(&scene, 0).unwrap();
        let quads = EmbreeScene::build_quads(&optimized.scene, &pairings, 0).unwrap();
        let same = same_hits(&scene, &optimized, &triangles, &quads, (96, 96));
        assert!(same >= 0.999, "{name}: {same}");
        assert!(
            quads.bvh_bytes > 0 && quads.bvh_bytes < triangles.bvh_bytes,
            "{name}: {} quad bytes, {} triangle bytes",
            quads.bvh_bytes,
            triangles.bvh_bytes
        );
    }
}

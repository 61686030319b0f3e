//! Lint finds exactly the problems planted in hand-built meshes (repair's tests are in
//! `repair.rs`).

mod common;

use common::{fan, figure, finding, grid, kinds, with};
use glam::{Affine3A, Vec3};
use proptest::prelude::*;
use rtmesh::bvh::BuildSettings;
use rtmesh::lint::{lint, LintSettings};
use rtmesh::repair::{Degenerate, RepairSettings};
use rtmesh::trace::{SceneAccel, Workload};
use rtmesh::{Scene, TriMesh};
use std::collections::BTreeSet;

#[test]
fn a_clean_grid_has_no_findings() {
    assert!(kinds(&Scene::from_mesh(grid(10, Vec3::ZERO))).is_empty());
}

#[test]
fn one_sliver_is_found_and_nothing_else() {
    let sliver = [
        Vec3::new(0.0, 0.0, 5.0),
        Vec3::new(10.0, 10.0, 5.0),
        Vec3::new(10.0, 10.1, 5.0),
    ];
    let scene = Scene::from_mesh(with(grid(10, Vec3::ZERO), &[sliver]));
    assert_eq!(kinds(&scene), BTreeSet::from(["elongated-triangles"]));
    let found = finding(&scene, "elongated-triangles");
    assert_eq!((found.count, found.worst.clone()), (1, vec![200]));
    let share = figure(&found, "share_of_leaf_sah_cost");
    assert!(
        share > 0.3,
        "one sliver carries a third of 201 triangles' box area: {share}"
    );
}

#[test]
fn point_and_line_degenerates_are_found() {
    let point = [Vec3::new(3.0, 3.0, 1.0); 3];
    let line = [
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(2.0, 2.0, 2.0),
        Vec3::new(3.0, 3.0, 3.0),
    ];
    let mut mesh = with(grid(10, Vec3::ZERO), &[point, line]);
    // And one with a repeated index.
    mesh.triangles.push([0, 0, 1]);
    mesh.material_ids.push(0);
    mesh.alpha_tested.push(false);
    let scene = Scene::from_mesh(mesh);
    assert_eq!(kinds(&scene), BTreeSet::from(["degenerate-triangles"]));
    let found = finding(&scene, "degenerate-triangles");
    assert_eq!((found.count, found.worst.clone()), (3, vec![200, 201, 202]));
    let at_origin = Scene::from_mesh(with(grid(10, Vec3::ZERO), &[[Vec3::ZERO; 3]]));
    let found = finding(&at_origin, "degenerate-triangles");
    assert!(found.advice.contains("origin"), "{}", found.advice);
}

#[test]
fn a_nan_triangle_is_inactive() {
    let scene = Scene::from_mesh(with(
        grid(10, Vec3::ZERO),
        &[[Vec3::NAN, Vec3::ONE, Vec3::X]],
    ));
    assert_eq!(kinds(&scene), BTreeSet::from(["inactive-triangles"]));
    assert_eq!(finding(&scene, "inactive-triangles").worst, vec![200]);
}

#[test]
fn a_fan_is_found_at_its_centre() {
    let scene = Scene::from_mesh(fan(256));
    assert_eq!(
        kinds(&scene),
        BTreeSet::from(["elongated-triangles", "fans"])
    );
    let found = finding(&scene, "fans");
    assert_eq!((found.count, found.worst.clone()), (1, vec![0]));
}

#[test]
fn scattered_pieces_in_one_geometry_are_found() {
    let mut mesh = grid(16, Vec3::ZERO);
    let far = grid(16, Vec3::new(100.0, 100.0, 50.0));
    mesh.append(&far, &Affine3A::IDENTITY, 0);
    let scene = Scene::from_mesh(mesh);
    assert_eq!(kinds(&scene), BTreeSet::from(["scattered-geometry"]));
    assert_eq!(finding(&scene, "scattered-geometry").count, 2);
}

#[test]
fn splitting_a_scattered_geometry_around_another_lowers_the_two_level_estimate() {
    let mut scattered = grid(16, Vec3::ZERO);
    scattered.append(
        &grid(16, Vec3::new(100.0, 100.0, 50.0)),
        &Affine3A::IDENTITY,
        0,
    );
    let mut scene = Scene::from_mesh(scattered);
    scene.push_mesh(grid(16, Vec3::new(50.0, 50.0, 25.0)), Affine3A::IDENTITY);
    let found = finding(&scene, "scattered-geometry");
    let (before, after) = (
        figure(&found, "two_level_sah_before"),
        figure(&found, "two_level_sah_after"),
    );
    let accel = SceneAccel::build(&scene, &BuildSettings::default());
    assert_eq!(before, accel.two_level_sah_cost());
    // Before, rays towards the middle geometry also enter the scattered one's BLAS.
    assert!(after < before - 0.5, "{before} → {after}");
    let single = SceneAccel::build(
        &Scene::from_mesh(grid(16, Vec3::ZERO)),
        &BuildSettings::default(),
    );
    assert_eq!(
        single.two_level_sah_cost() as f32,
        single.stats().sah_cost,
        "one untransformed mesh: the BLAS's own cost"
    );
}

#[test]
fn overlapping_geometries_are_found() {
    let mut scene = Scene::from_mesh(rtmesh::scenes::box_mesh(Vec3::ZERO, Vec3::splat(10.0)));
    scene.push_mesh(grid(10, Vec3::new(0.0, 0.0, 5.0)), Affine3A::IDENTITY);
    assert_eq!(kinds(&scene), BTreeSet::from(["overlapping-geometries"]));
    let found = finding(&scene, "overlapping-geometries");
    assert_eq!(found.worst, vec![1]);
    let advice = found.advice;
    assert!(advice.contains("merge geometries"), "{advice}");
}

/// Overlapping placements of one geometry are found too, but merging them would copy
/// the geometry (and `repair --merge-overlapping` leaves them): the advice says so.
#[test]
fn overlapping_instances_of_one_geometry_are_not_advised_to_merge() {
    let mut scene = Scene::from_mesh(rtmesh::scenes::box_mesh(Vec3::ZERO, Vec3::splat(10.0)));
    scene.instances.push(rtmesh::Instance::new(
        0,
        Affine3A::from_translation(Vec3::new(1.0, 0.0, 0.0)),
    ));
    let found = finding(&scene, "overlapping-geometries");
    assert_eq!(found.worst, vec![1]);
    let advice = found.advice;
    assert!(advice.contains("instanced geometry"), "{advice}");
    assert!(!advice.contains("merge geometries"), "{advice}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The sweep finds exactly the pairs that comparing every two boxes finds, in order,
    /// among random placements (scaled, translated, some empty) that often overlap.
    #[test]
    fn overlapping_instances_are_those_of_the_quadratic_check(seed in 0u64..10_000, n in 0usize..60) {
        let mut rng = rtmesh::random::SplitMix64::new(seed);
        let mut scene = Scene::from_mesh(rtmesh::scenes::box_mesh(Vec3::ZERO, Vec3::ONE));
        scene.instances.clear();
        let empty = scene.meshes.len();
        scene.meshes.push(TriMesh::default());
        for _ in 0..n {
            let at = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0;
            let size = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0;
            let mesh = if rng.next_f32() < 0.1 { empty } else { 0 };
            let transform = Affine3A::from_scale_rotation_translation(size, Default::default(), at);
            scene.instances.push(rtmesh::Instance::new(mesh, transform));
        }
        let boxes: Vec<rtmesh::geom::Aabb> = scene
            .instances
            .iter()
            .map(|i| scene.meshes[i.mesh].bounds().transformed(&i.transform))
            .collect();
        let mut expected = Vec::new();
        for a in 0..n {
            for b in a + 1..n {
                let shared = boxes[a].intersection(boxes[b]);
                let smaller = boxes[a].half_area().min(boxes[b].half_area());
                let overlap = shared.half_area() / smaller.max(f32::MIN_POSITIVE);
                if !shared.is_empty() && overlap >= 0.5 {
                    expected.push((a, b, overlap));
                }
            }
        }
        prop_assert_eq!(rtmesh::analysis::overlapping_instances(&scene), expected);
    }
}

#[test]
fn mixed_alpha_is_found() {
    let mut mesh = grid(4, Vec3::ZERO);
    for t in 0..8 {
        mesh.alpha_tested[t] = true;
    }
    let scene = Scene::from_mesh(mesh);
    assert_eq!(kinds(&scene), BTreeSet::from(["mixed-alpha"]));
    assert_eq!(finding(&scene, "mixed-alpha").count, 8);
}

#[test]
fn refit_or_rebuild_advice_follows_the_deformation() {
    use rtmesh::lint::{lint_deforming, Severity};
    // 1024 small triangles on a 32 × 32 lattice.
    let cell = |k: usize| Vec3::new((k % 32) as f32, (k / 32) as f32, 0.0);
    let piece = [
        Vec3::ZERO,
        Vec3::new(0.3, 0.0, 0.0),
        Vec3::new(0.0, 0.3, 0.0),
    ];
    let lattice = |place: &dyn Fn(usize) -> usize| {
        let positions = (0..1024)
            .flat_map(|k| piece.map(|p| p + cell(place(k))))
            .collect();
        let triangles = (0..1024u32)
            .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
            .collect();
        TriMesh::new(positions, triangles)
    };
    let rest = lattice(&|k| k);
    let mut moved = rest.clone();
    for p in &mut moved.positions {
        *p += Vec3::new(3.0, -1.0, 2.0);
    }
    // Shuffled: every triangle jumps to another lattice cell (same topology).
    let scrambled = lattice(&|k| (k * 389) % 1024);
    let [rest, moved, scrambled] = [rest, moved, scrambled].map(Scene::from_mesh);
    let calm = lint_deforming(&rest, std::slice::from_ref(&moved)).unwrap();
    assert_eq!(
        (calm.severity, calm.worst.clone()),
        (Severity::Info, vec![])
    );
    let wild = lint_deforming(&rest, &[moved, scrambled]).unwrap();
    assert_eq!(
        (wild.severity, wild.worst.clone()),
        (Severity::Warning, vec![1])
    );
    assert!(wild.figures[0].1 > 2.0, "{:?}", wild.figures);
    let other = Scene::from_mesh(rtmesh::scenes::scan_blob(1_000, 2));
    assert!(lint_deforming(&rest, &[other]).is_err());
}

#[test]
fn stacked_alpha_layers_are_counted() {
    // An opaque floor under three alpha-tested sheets: camera rays cross all three.
    let floor = grid(8, Vec3::ZERO);
    let mut scene = Scene::from_mesh(floor);
    for z in [1.0, 2.0, 3.0] {
        let mut sheet = grid(8, Vec3::new(0.0, 0.0, z));
        sheet.alpha_tested = vec![true; sheet.triangle_count()];
        scene.push_mesh(sheet, Affine3A::IDENTITY);
    }
    let layers = rtmesh::lint::alpha_layers(&scene, 32, 32);
    assert_eq!(layers.iter().copied().max(), Some(3));
    let found = finding(&scene, "stacked-alpha");
    assert_eq!(found.severity, rtmesh::lint::Severity::Warning);
    // One alpha layer is not a stack.
    let mut single = grid(4, Vec3::ZERO);
    single.alpha_tested[0] = true;
    assert!(!kinds(&Scene::from_mesh(single)).contains("stacked-alpha"));
}

#[test]
fn stacked_layers_are_found_and_two_are_not() {
    // Copies of a grid 10⁻⁵ apart (the tolerance is 10⁻⁴ of the scene's diagonal):
    // every camera ray that meets the grid crosses them all at one depth.
    let layered = |layers: usize| {
        let mut mesh = grid(8, Vec3::ZERO);
        for k in 1..layers {
            let copy = grid(8, Vec3::new(0.0, 0.0, k as f32 * 1e-5));
            mesh.append(&copy, &Affine3A::IDENTITY, 0);
        }
        Scene::from_mesh(mesh)
    };
    let found = finding(&layered(4), "stacked-triangles");
    assert_eq!(found.severity, rtmesh::lint::Severity::Warning);
    assert_eq!(figure(&found, "most_layers_on_one_ray"), 4.0);
    assert_eq!(figure(&found, "mean_layers_per_stacked_ray"), 4.0);
    assert_eq!(found.count, 4 * 128, "every triangle of every layer");
    // The deepest stack: one triangle of each layer, the same place in each.
    assert_eq!(found.worst.len(), 4);
    let place: BTreeSet<u32> = found.worst.iter().map(|t| t % 128).collect();
    let layer: BTreeSet<u32> = found.worst.iter().map(|t| t / 128).collect();
    assert_eq!((place.len(), layer.len()), (1, 4), "{:?}", found.worst);
    // Two layers back to back are a thin shell or a decal, not a stack.
    assert!(!kinds(&layered(2)).contains("stacked-triangles"));
    // A sphere: rays near its outline cross it twice close together, never in three
    // layers; rays near its poles meet the fans' slivers at their shared corner.
    let sphere = Scene::from_mesh(rtmesh::scenes::uv_sphere(64, 256));
    assert!(!kinds(&sphere).contains("stacked-triangles"));
    // One geometry placed three times at one place: a stack across instances.
    let mut placed = Scene::from_mesh(grid(8, Vec3::ZERO));
    let again = rtmesh::Instance::new(0, Affine3A::IDENTITY);
    placed.instances.extend([again.clone(), again]);
    let found = finding(&placed, "stacked-triangles");
    assert_eq!(figure(&found, "most_layers_on_one_ray"), 3.0);
    assert_eq!(found.count, 128, "the one geometry's triangles");
    // Placed twice more sheared along x by z (the plane z = 0 stays put, but its normal
    // carried like an edge would tilt by 45°): still three parallel layers.
    let mut sheared = Scene::from_mesh(grid(8, Vec3::ZERO));
    for k in 1..3 {
        let shear = Affine3A::from_cols(
            Vec3::X.into(),
            Vec3::Y.into(),
            Vec3::new(1.0, 0.0, 1.0).into(),
            Vec3::new(0.0, 0.0, k as f32 * 1e-5).into(),
        );
        sheared.instances.push(rtmesh::Instance::new(0, shear));
    }
    let found = finding(&sheared, "stacked-triangles");
    assert_eq!(figure(&found, "most_layers_on_one_ray"), 3.0);
}

#[test]
fn stacks_crossed_at_their_edges_are_no_stacks() {
    // Two stacks of three tiny parallel triangles 10⁻⁵ apart, each under one probe ray
    // (they are far smaller than the rays' spacing). The ray crosses stack A 3·10⁻⁴
    // (barycentric) from an edge of every layer, inside the edge margin of 10⁻³, where
    // a ray meets a surface's neighbouring triangles at one depth; it crosses stack B
    // in the middle. A floor below and a speck above fix the scene's box, so the probe
    // rays do not depend on where the stacks go.
    let floor = grid(8, Vec3::new(0.0, 0.0, -4.0));
    let speck = [
        Vec3::Z,
        Vec3::new(0.01, 0.0, 1.0),
        Vec3::new(0.0, 0.01, 1.0),
    ];
    let bounds = with(floor.clone(), &[speck]).bounds();
    let camera = rtmesh::trace::Camera::default_for(&bounds, 128, 128);
    let rays = Workload::primary(&camera, 128, 128).rays;
    let at_z = |ray: &rtmesh::Ray, z: f32| {
        ray.origin + (z - ray.origin.z) / ray.direction.z * ray.direction
    };
    let ray_through = |lo: f32, hi: f32| {
        rays.iter()
            .find(|r| {
                let p = at_z(r, 0.0);
                (lo..hi).contains(&p.x) && (lo..hi).contains(&p.y)
            })
            .expect("a probe ray over the floor")
    };
    // Three layers, each placed so that `ray` crosses it at barycentrics (1 − u − v, u, v).
    let side = 0.01;
    let stack = |ray: &rtmesh::Ray, u: f32, v: f32| -> Vec<[Vec3; 3]> {
        (0..3)
            .map(|k| {
                let p = at_z(ray, k as f32 * 1e-5);
                let v0 = p - Vec3::new(u * side, v * side, 0.0);
                [v0, v0 + Vec3::X * side, v0 + Vec3::Y * side]
            })
            .collect()
    };
    let near_edge = stack(ray_through(2.0, 3.0), 0.5, 3e-4);
    let in_middle = stack(ray_through(5.0, 6.0), 1.0 / 3.0, 1.0 / 3.0);
    let first = floor.triangle_count() as u32 + 1;
    let mesh = with(with(with(floor, &[speck]), &near_edge), &in_middle);
    assert_eq!(mesh.bounds(), bounds, "the probe rays stay put");
    let found = finding(&Scene::from_mesh(mesh), "stacked-triangles");
    assert_eq!(found.count, 3, "stack B only: {:?}", found.worst);
    let mut worst = found.worst.clone();
    worst.sort_unstable();
    assert_eq!(worst, vec![first + 3, first + 4, first + 5]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Broken input (out-of-range indices, NaN and infinite corners, repeated indices,
    /// duplicate and degenerate triangles, several geometries) never makes lint or
    /// any repair panic, and every output triangle maps to an input triangle.
    #[test]
    fn lint_and_repair_survive_broken_meshes(seed in 0u64..10_000, geometries in 1usize..4) {
        let mut rng = rtmesh::random::SplitMix64::new(seed);
        let mut scene = Scene::default();
        for g in 0..geometries {
            let vertices = 3 + (rng.next_u64() % 30) as usize;
            let positions: Vec<Vec3> = (0..vertices)
                .map(|_| match rng.next_u64() % 20 {
                    0 => Vec3::NAN,
                    1 => Vec3::new(f32::INFINITY, 0.0, 0.0),
                    2 => Vec3::ZERO,
                    _ => Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0,
                })
                .collect();
            let triangles: Vec<[u32; 3]> = (0..1 + rng.next_u64() % 40)
                .map(|_| {
                    [0; 3].map(|_| (rng.next_u64() % (vertices as u64 + 2)) as u32)
                })
                .collect();
            let mut mesh = TriMesh::new(positions, triangles);
            for a in &mut mesh.alpha_tested {
                *a = rng.next_u64().is_multiple_of(3);
            }
            let transform = Affine3A::from_translation(Vec3::splat(g as f32));
            scene.push_mesh(mesh, transform);
        }
        let report = lint(&scene, &LintSettings::default());
        prop_assert_eq!(report.geometries, geometries);
        for degenerate in [Degenerate::Remove, Degenerate::Inactive, Degenerate::Keep] {
            let settings = RepairSettings {
                degenerate,
                split_elongated: true,
                // Forced splits once, measured ones twice.
                force_split: degenerate == Degenerate::Keep,
                split_scattered: true,
                split_alpha: true,
                merge_overlapping: true,
                ..RepairSettings::default()
            };
            let (out, map, _) = rtmesh::repair::repair(&scene, &settings);
            prop_assert_eq!(map.input_triangle.len(), out.meshes.len());
            for (g, mesh) in out.meshes.iter().enumerate() {
                prop_assert_eq!(map.input_triangle[g].len(), mesh.triangle_count());
                for (&input_g, &input_t) in map.input_geometry[g].iter().zip(&map.input_triangle[g]) {
                    prop_assert!((input_t as usize) < scene.meshes[input_g as usize].triangle_count());
                }
            }
        }
    }
}

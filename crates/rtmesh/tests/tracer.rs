//! The tracer against brute force: every ray against every triangle in double
//! precision. Closest hits must name the same input triangle except for ties (rays
//! through a shared edge or vertex, where either neighbour is right), which are counted
//! and bounded; any-hit answers must agree. Plus two levels against the flattened
//! scene, refit against rebuild, and the awkward rays.

use glam::Vec3;
use rtmesh::bvh::BuildSettings;
use rtmesh::pair::PairMethod;
use rtmesh::trace::intersect::reference_f64;
use rtmesh::trace::run::{trace_closest, trace_occluded};
use rtmesh::trace::{Hit, NoCounters, Pair4, RayCounters, RayKind, SceneAccel, Tracer, Workload};
use rtmesh::{Ray, Scene, TriMesh};

/// Double-precision Möller–Trumbore: (t, u, v) of a hit inside (t_min, t_max).
fn intersect_f64(ray: &Ray, corners: [Vec3; 3]) -> Option<(f64, f64, f64)> {
    reference_f64(ray, corners).filter(|&(t, u, v)| {
        u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > ray.t_min as f64 && t < ray.t_max as f64
    })
}

/// World-space triangles of a scene with their (instance, triangle) ids.
fn world_triangles(scene: &Scene) -> Vec<((u32, u32), [Vec3; 3])> {
    let mut out = Vec::new();
    for (i, instance) in scene.instances.iter().enumerate() {
        let mesh = &scene.meshes[instance.mesh];
        for t in 0..mesh.triangle_count() {
            let corners = mesh
                .corners(t)
                .map(|p| instance.transform.transform_point3(p));
            if corners.iter().all(|p| p.is_finite()) {
                out.push(((i as u32, t as u32), corners));
            }
        }
    }
    out
}

/// How far (in barycentric terms) a hit lies from its triangle's boundary.
fn edge_distance(ray: &Ray, corners: [Vec3; 3]) -> f64 {
    intersect_f64(
        &Ray {
            t_min: f32::NEG_INFINITY,
            t_max: f32::INFINITY,
            ..*ray
        },
        corners,
    )
    .map_or(0.0, |(_, u, v)| u.min(v).min(1.0 - u - v))
}

struct Agreement {
    rays: usize,
    ties: usize,
}

/// Compare closest hits with brute force; panics on any disagreement that is not a tie.
fn check_closest(scene: &Scene, rays: &[Ray], hits: &[Hit]) -> Agreement {
    let triangles = world_triangles(scene);
    let mut ties = 0;
    for (ray, hit) in rays.iter().zip(hits) {
        let best = triangles
            .iter()
            .filter_map(|(id, c)| intersect_f64(ray, *c).map(|(t, _, _)| (t, *id, *c)))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        match best {
            None => assert!(!hit.is_hit(), "ray {ray:?} hit {hit:?}, brute force misses"),
            Some((t, id, corners)) => {
                if !hit.is_hit() {
                    // A miss is a tie only when brute force grazes an edge.
                    assert!(
                        edge_distance(ray, corners) < 1e-5,
                        "ray {ray:?} missed; brute force hits {id:?} at {t}"
                    );
                    ties += 1;
                    continue;
                }
                assert!(
                    (hit.t as f64 - t).abs() <= 1e-4 * t.abs().max(1.0),
                    "ray {ray:?}: t {} vs {t}",
                    hit.t
                );
                if (hit.instance, hit.triangle) != id {
                    let ours = triangles
                        .iter()
                        .find(|(i, _)| *i == (hit.instance, hit.triangle))
                        .expect("hit exists")
                        .1;
                    let near_edge =
                        edge_distance(ray, corners) < 1e-4 || edge_distance(ray, ours) < 1e-4;
                    // Equal distances (coincident or touching triangles) are ties too.
                    let same_t = intersect_f64(ray, ours)
                        .is_some_and(|(t2, _, _)| (t2 - t).abs() <= 1e-6 * t.abs().max(1.0));
                    assert!(
                        near_edge || same_t,
                        "ray {ray:?}: hit {:?}, brute force {id:?}",
                        (hit.instance, hit.triangle)
                    );
                    ties += 1;
                }
            }
        }
    }
    Agreement {
        rays: rays.len(),
        ties,
    }
}

fn check_occluded(scene: &Scene, rays: &[Ray], occluded: &[bool]) -> usize {
    let triangles = world_triangles(scene);
    let mut ties = 0;
    for (ray, &o) in rays.iter().zip(occluded) {
        let hits: Vec<_> = triangles
            .iter()
            .filter(|(_, c)| intersect_f64(ray, *c).is_some())
            .collect();
        if o == hits.is_empty() {
            let grazing = hits.iter().all(|(_, c)| edge_distance(ray, *c) < 1e-5);
            assert!(
                grazing,
                "ray {ray:?}: occluded {o}, brute force {} hits",
                hits.len()
            );
            ties += 1;
        }
    }
    ties
}

fn check_all_workloads(name: &str, scene: &Scene, size: usize) {
    let accel = SceneAccel::build(scene, &BuildSettings::default());
    for blas in &accel.blas {
        blas.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    check_tracer(name, scene, size, &accel);
}

/// Every workload through `accel` (rays generated with triangle leaves) against brute
/// force.
fn check_tracer(name: &str, scene: &Scene, size: usize, accel: &impl Tracer) {
    let triangles = SceneAccel::build(scene, &BuildSettings::default());
    for kind in [RayKind::Primary, RayKind::Diffuse, RayKind::Shadow] {
        let work = Workload::generate(kind, scene, &triangles, size, size, 7);
        if kind == RayKind::Shadow {
            let (occluded, _) = trace_occluded::<NoCounters>(accel, &work.rays);
            let ties = check_occluded(scene, &work.rays, &occluded);
            assert!(
                ties * 1000 <= work.rays.len().max(1000),
                "{name} shadow: {ties} ties"
            );
        } else {
            let (hits, _) = trace_closest::<NoCounters>(accel, &work.rays);
            let agreement = check_closest(scene, &work.rays, &hits);
            assert!(
                agreement.ties * 200 <= agreement.rays.max(200),
                "{name} {kind:?}: {} ties of {}",
                agreement.ties,
                agreement.rays
            );
            if kind == RayKind::Primary {
                assert!(hits.iter().any(Hit::is_hit), "{name}: no primary ray hit");
            }
        }
    }
}

#[test]
fn procedural_scenes_match_brute_force() {
    check_all_workloads(
        "blob",
        &Scene::from_mesh(rtmesh::scenes::scan_blob(3_000, 3)),
        64,
    );
    check_all_workloads(
        "grid",
        &Scene::from_mesh(rtmesh::scenes::rotated_grid(24)),
        64,
    );
    check_all_workloads(
        "cylinder",
        &Scene::from_mesh(rtmesh::scenes::fan_cylinder(48)),
        64,
    );
    check_all_workloads("room", &rtmesh::scenes::room(), 48);
}

/// The scene welded, and its pair-leaf accel by `method`.
fn paired(scene: &Scene, method: PairMethod) -> (Scene, SceneAccel<Pair4>) {
    let (welded, pairings) = rtmesh::pair::weld_and_pair(scene, method);
    let accel = SceneAccel::build_paired(&welded, &pairings, &BuildSettings::default());
    (welded, accel)
}

#[test]
fn pair_leaves_match_brute_force() {
    let mut scenes = vec![
        (
            "blob",
            Scene::from_mesh(rtmesh::scenes::scan_blob(3_000, 3)),
        ),
        ("grid", Scene::from_mesh(rtmesh::scenes::rotated_grid(24))),
        (
            "cylinder",
            Scene::from_mesh(rtmesh::scenes::fan_cylinder(48)),
        ),
        ("room", rtmesh::scenes::room()),
    ];
    if let Some(dir) = rtmesh::data::mesh_data_dir() {
        for file in ["woody.obj", "suzanne.obj", "beetle.obj"] {
            scenes.push((file, rtmesh::io::read(&dir.join(file)).unwrap()));
        }
    }
    for (name, scene) in &scenes {
        for method in [PairMethod::Sah, PairMethod::Window(2), PairMethod::SahMax] {
            let (welded, accel) = paired(scene, method);
            for blas in &accel.blas {
                blas.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
            }
            check_tracer(&format!("{name} pairs {method}"), &welded, 48, &accel);
        }
    }
}

#[test]
fn paired_mesh_traces_the_same_input_triangles() {
    // The reordered output mesh, traced with triangle leaves and mapped back through
    // `input_triangle`, hits what the input hits (edge ties aside); so do pair leaves.
    let mesh = rtmesh::mesh::weld_exact(&rtmesh::scenes::scan_blob(20_000, 9)).mesh;
    let scene = Scene::from_mesh(mesh.clone());
    let pairing = rtmesh::pair::greedy::pair_sah(&mesh);
    let out = rtmesh::pair::reorder(&mesh, &mesh, &pairing);
    let output_scene = Scene::from_mesh(out.mesh.clone());
    let input = SceneAccel::build(&scene, &BuildSettings::default());
    let output = SceneAccel::build(&output_scene, &BuildSettings::default());
    let pairs = SceneAccel::build_paired(&scene, &[pairing], &BuildSettings::default());
    for kind in [RayKind::Primary, RayKind::Diffuse] {
        let work = Workload::generate(kind, &scene, &input, 128, 128, 3);
        let (expected, _) = trace_closest::<NoCounters>(&input, &work.rays);
        let (written, _) = trace_closest::<NoCounters>(&output, &work.rays);
        let (paired, _) = trace_closest::<NoCounters>(&pairs, &work.rays);
        let mut ties = 0;
        for (i, ray) in work.rays.iter().enumerate() {
            let mapped = written[i]
                .is_hit()
                .then(|| out.input_triangle[written[i].triangle as usize]);
            for got in [mapped, paired[i].is_hit().then_some(paired[i].triangle)] {
                let want = expected[i].is_hit().then_some(expected[i].triangle);
                if got != want {
                    let near_edge = [got, want]
                        .into_iter()
                        .flatten()
                        .any(|t| edge_distance(ray, mesh.corners(t as usize)) < 1e-4);
                    assert!(near_edge, "{kind:?} ray {i}: {got:?} vs {want:?}");
                    ties += 1;
                }
            }
        }
        assert!(ties * 1000 <= work.rays.len(), "{kind:?}: {ties} edge ties");
    }
}

#[test]
fn small_real_meshes_match_brute_force() {
    let Some(dir) = rtmesh::data::mesh_data_dir() else {
        return;
    };
    for file in ["woody.obj", "suzanne.obj", "beetle.obj"] {
        let scene = rtmesh::io::read(&dir.join(file)).unwrap();
        check_all_workloads(file, &scene, 48);
    }
}

#[test]
fn two_levels_equal_the_flattened_scene() {
    let room = rtmesh::scenes::room();
    let flat = Scene::from_mesh(room.flatten().unwrap());
    let two = SceneAccel::build(&room, &BuildSettings::default());
    let one = SceneAccel::build(&flat, &BuildSettings::default());
    assert!(two.tlas.is_some() && one.tlas.is_none());
    // Flattened triangle index of (instance, triangle).
    let mut offsets = vec![0u32];
    for instance in &room.instances {
        offsets.push(offsets.last().unwrap() + room.meshes[instance.mesh].triangle_count() as u32);
    }
    let work = Workload::generate(RayKind::Primary, &room, &two, 96, 96, 1);
    let (a, _) = trace_closest::<NoCounters>(&two, &work.rays);
    let (b, _) = trace_closest::<NoCounters>(&one, &work.rays);
    let mut differ = 0;
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.is_hit(), y.is_hit());
        if x.is_hit() {
            assert!((x.t - y.t).abs() <= 1e-4 * x.t.max(1.0), "{x:?} vs {y:?}");
            differ += usize::from(offsets[x.instance as usize] + x.triangle != y.triangle);
        }
    }
    assert!(
        differ * 200 <= a.len(),
        "{differ} rays hit different triangles"
    );
    let shadow = Workload::generate(RayKind::Shadow, &room, &two, 64, 64, 1);
    assert_eq!(
        trace_occluded::<NoCounters>(&two, &shadow.rays).0,
        trace_occluded::<NoCounters>(&one, &shadow.rays).0
    );
}

#[test]
fn refit_after_deformation_equals_rebuild() {
    let mut scene = Scene::from_mesh(rtmesh::scenes::scan_blob(5_000, 9));
    let mut accel = SceneAccel::build(&scene, &BuildSettings::default());
    for p in &mut scene.meshes[0].positions {
        *p += Vec3::new(0.3 * (p.y * 4.0).sin(), 0.0, 0.2 * p.x);
    }
    accel.refit(&scene);
    accel.blas[0].validate().unwrap();
    let rebuilt = SceneAccel::build(&scene, &BuildSettings::default());
    let work = Workload::generate(RayKind::Primary, &scene, &rebuilt, 64, 64, 1);
    let (a, _) = trace_closest::<NoCounters>(&accel, &work.rays);
    let (b, _) = trace_closest::<NoCounters>(&rebuilt, &work.rays);
    assert_eq!(a, b);
}

#[test]
fn awkward_rays_and_scenes() {
    // Empty scene, and a mesh whose only triangle is NaN (inactive): every ray misses.
    let rays = [
        Ray::new(Vec3::ZERO, Vec3::X),
        Ray::new(Vec3::splat(-1.0), Vec3::ONE),
    ];
    let empty = SceneAccel::build(&Scene::default(), &BuildSettings::default());
    let nan = Scene::from_mesh(TriMesh::new(
        vec![Vec3::NAN, Vec3::X, Vec3::Y],
        vec![[0, 1, 2]],
    ));
    let inactive = SceneAccel::build(&nan, &BuildSettings::default());
    for ray in &rays {
        assert!(!empty.intersect(ray, &mut NoCounters).is_hit());
        assert!(!empty.occluded(ray, &mut NoCounters));
        assert!(!inactive.intersect(ray, &mut NoCounters).is_hit());
    }

    // One triangle; axis-parallel rays (zero direction components) onto it.
    let one = Scene::from_mesh(TriMesh::new(
        vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        vec![[0, 1, 2]],
    ));
    let accel = SceneAccel::build(&one, &BuildSettings::default());
    let down = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z);
    let hit = accel.intersect(&down, &mut NoCounters);
    assert_eq!((hit.triangle, hit.t), (0, 1.0));
    assert!((hit.u - 0.25).abs() < 1e-6 && (hit.v - 0.25).abs() < 1e-6);
    // Rays in the triangle's plane, zero and NaN directions: misses, no panic.
    for ray in [
        Ray::new(Vec3::new(-1.0, 0.25, 0.0), Vec3::X),
        Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::ZERO),
        Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NAN),
        Ray::new(Vec3::NAN, Vec3::NEG_Z),
    ] {
        assert!(!accel.intersect(&ray, &mut NoCounters).is_hit(), "{ray:?}");
        assert!(!accel.occluded(&ray, &mut NoCounters), "{ray:?}");
    }

    // A unit cube: rays along its faces (on the planes of the root box's faces) and
    // axis-parallel rays from inside; all agree with brute force.
    let cube = Scene::from_mesh(rtmesh::scenes::box_mesh(Vec3::ZERO, Vec3::ONE));
    let accel = SceneAccel::build(&cube, &BuildSettings::default());
    let mut rays = Vec::new();
    for y in [0.0, 0.5, 1.0] {
        for z in [0.0, 0.25, 0.5, 1.0] {
            rays.push(Ray::new(Vec3::new(-1.0, y, z), Vec3::X));
            rays.push(Ray::new(Vec3::new(0.5, y, z), Vec3::NEG_X));
        }
    }
    for d in [
        Vec3::X,
        Vec3::Y,
        Vec3::Z,
        Vec3::NEG_X,
        Vec3::NEG_Y,
        Vec3::NEG_Z,
    ] {
        rays.push(Ray::new(Vec3::splat(0.3), d));
    }
    let (hits, _) = trace_closest::<NoCounters>(&accel, &rays);
    check_closest(&cube, &rays, &hits);
    for (ray, hit) in rays.iter().zip(&hits).skip(24) {
        assert!(hit.is_hit(), "from inside the cube, {ray:?} must hit");
    }
}

#[test]
fn rays_from_inside_a_closed_mesh_always_hit() {
    let blob = Scene::from_mesh(rtmesh::scenes::scan_blob(4_000, 5));
    let accel = SceneAccel::build(&blob, &BuildSettings::default());
    let mut rng = rtmesh::random::SplitMix64::new(3);
    let rays: Vec<Ray> = (0..2_000)
        .map(|_| {
            let d = Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            );
            Ray::new(Vec3::new(0.01, -0.02, 0.03), d)
        })
        .collect();
    let (hits, _) = trace_closest::<NoCounters>(&accel, &rays);
    let agreement = check_closest(&blob, &rays, &hits);
    assert!(agreement.ties <= 10, "{} ties", agreement.ties);
    assert!(
        hits.iter().all(Hit::is_hit),
        "a closed surface stops every ray from inside"
    );
}

#[test]
fn counters_count_and_cost_nothing_when_off() {
    let blob = Scene::from_mesh(rtmesh::scenes::scan_blob(2_000, 1));
    let accel = SceneAccel::build(&blob, &BuildSettings::default());
    let work = Workload::generate(RayKind::Primary, &blob, &accel, 32, 32, 1);
    let (counted_hits, counters) = trace_closest::<RayCounters>(&accel, &work.rays);
    let (plain_hits, _) = trace_closest::<NoCounters>(&accel, &work.rays);
    assert_eq!(counted_hits, plain_hits);
    assert_eq!(std::mem::size_of::<NoCounters>(), 0);
    let total: u64 = counters.iter().map(|c| c.box_tests).sum();
    assert!(
        total > work.rays.len() as u64,
        "every ray tests the root's children"
    );
    // A ray that hits tested at least one triangle.
    for (hit, c) in counted_hits.iter().zip(&counters) {
        if hit.is_hit() {
            assert!(c.triangle_tests >= 1 && c.nodes_visited >= 1);
        }
    }
}

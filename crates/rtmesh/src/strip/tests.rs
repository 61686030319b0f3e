use super::packed::PackedStrips;
use super::sah::{stripify, PartitionMethod, StripSettings};
use super::*;
use crate::scenes;
use proptest::prelude::*;

/// The default maximum strip length.
fn default_length() -> usize {
    StripSettings::default().max_length
}

/// Every input triangle exactly once, decoded as a rotation of itself (its winding),
/// strips within the maximum length, and the rasterization form decoding to the same.
fn assert_valid(mesh: &TriMesh, strips: &Strips, max_length: usize) {
    assert_eq!(strips.triangle_count(), mesh.triangle_count());
    let mut seen = vec![false; mesh.triangle_count()];
    let decoded = strips.decode();
    for (k, &t) in strips.triangle_source.iter().enumerate() {
        assert!(!std::mem::replace(&mut seen[t as usize], true), "{t} twice");
        assert!(
            same_winding(decoded[k], mesh.triangles[t as usize]),
            "triangle {t}: {:?} decoded as {:?}",
            mesh.triangles[t as usize],
            decoded[k]
        );
    }
    for s in 0..strips.len() {
        assert!(strips.triangles_of(s).len() <= max_length.max(1));
    }
    for (s, list) in strips.to_standard().iter().enumerate() {
        let expected: Vec<[u32; 3]> = strips
            .triangles_of(s)
            .map(|k| decoded[k])
            .filter(|&t| !crate::mesh::names_a_vertex_twice(t))
            .collect();
        let mut got = Vec::new();
        standard_triangles(list, &mut got);
        assert_eq!(got.len(), expected.len(), "strip {s}: {list:?}");
        for (g, e) in got.iter().zip(&expected) {
            assert!(same_winding(*g, *e), "strip {s}: {g:?} for {e:?}");
        }
    }
}

#[test]
fn a_quad_is_one_strip_of_four_indices() {
    let mesh = TriMesh::new(
        vec![
            glam::Vec3::ZERO,
            glam::Vec3::X,
            glam::Vec3::ONE,
            glam::Vec3::Y,
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let strips = stripify(&mesh, &StripSettings::default());
    assert_valid(&mesh, &strips, default_length());
    assert_eq!(strips.len(), 1);
    assert_eq!(strips.indices.len(), 4);
    // The first triangle is rotated to (v[s+2], v[s], v[s+1]) for its shared side s:
    // side 2, (2, 0), of [0, 1, 2], or side 0, (0, 2), of [0, 2, 3].
    assert!(
        strips.indices == [1, 2, 0, 3] || strips.indices == [3, 0, 2, 1],
        "{:?}",
        strips.indices
    );
}

#[test]
fn grid_strips_approach_one_index_per_triangle() {
    let mesh = scenes::quad_grid(40);
    let settings = StripSettings {
        max_length: 64,
        ..Default::default()
    };
    let strips = stripify(&mesh, &settings);
    assert_valid(&mesh, &strips, 64);
    let report = StripReport::of(&strips, 0.0);
    assert!(report.indices_per_triangle < 1.15, "{report:?}");
}

#[test]
fn a_morton_partition_strips_a_grid_as_well() {
    let mesh = scenes::quad_grid(40);
    let strips = |partition| {
        let settings = StripSettings {
            partition,
            ..Default::default()
        };
        let strips = stripify(&mesh, &settings);
        assert_valid(&mesh, &strips, default_length());
        StripReport::of(&strips, 0.0).indices_per_triangle
    };
    let (sah, morton) = (
        strips(PartitionMethod::Sah),
        strips(PartitionMethod::Morton),
    );
    assert!(
        morton < 1.15 && morton < sah * 1.05,
        "{morton} against {sah}"
    );
}

#[test]
fn fans_and_spheres_strip_validly() {
    for mesh in [scenes::fan_cylinder(48), scenes::uv_sphere(12, 24)] {
        for max_length in [1, 2, 7, 32] {
            let strips = stripify(
                &mesh,
                &StripSettings {
                    max_length,
                    ..Default::default()
                },
            );
            assert_valid(&mesh, &strips, max_length);
        }
    }
}

#[test]
fn meshopt_strips_are_valid_and_longer_in_indices() {
    let mesh = scenes::quad_grid(30);
    let ours = stripify(&mesh, &StripSettings::default());
    let theirs = meshopt::stripify(&mesh, 32);
    assert_valid(&mesh, &theirs.strips, 32);
    assert!(theirs.native_indices > mesh.triangle_count());
    assert!(ours.indices.len() <= theirs.strips.indices.len());
}

#[test]
fn inconsistent_winding_and_nonmanifold_edges_break_strips() {
    // Three triangles on edge (0, 1), and one flipped neighbour.
    let p = |x: f32, y: f32, z: f32| glam::Vec3::new(x, y, z);
    let mesh = TriMesh::new(
        vec![
            p(0., 0., 0.),
            p(1., 0., 0.),
            p(0., 1., 0.),
            p(0., -1., 0.),
            p(0., 0., 1.),
            p(1., 1., 0.),
        ],
        vec![[0, 1, 2], [1, 0, 3], [0, 1, 4], [1, 2, 5]],
    );
    let strips = stripify(&mesh, &StripSettings::default());
    assert_valid(&mesh, &strips, default_length());
    // Edge (0, 1) has three triangles and (1, 2) is the same way round in both: no
    // triangle has a strip neighbour.
    assert_eq!(strips.len(), 4);
}

/// Renumbered by first use and packed, the strips decode to the same triangles (in
/// the new numbering), corner by corner, and name the same positions.
fn assert_packs_losslessly(mesh: &TriMesh, strips: &Strips) {
    let mut renumbered = strips.clone();
    let old_of_new = renumbered.renumber_by_first_use(mesh.positions.len());
    let (packed, starts) = PackedStrips::pack(&renumbered).expect("numbered by first use");
    assert_eq!(starts.len(), strips.len());
    for (s, start) in starts.iter().enumerate() {
        let mut expected = Vec::new();
        renumbered.for_each_triangle(s, |k, t| expected.push((k, t)));
        let mut old = Vec::new();
        strips.for_each_triangle(s, |_, t| old.push(t));
        let mut decoded = Vec::new();
        packed.for_each_triangle(s, start, |k, t| decoded.push((k, t)));
        assert_eq!(decoded, expected, "strip {s}");
        for ((_, new), old) in decoded.iter().zip(&old) {
            assert_eq!(new.map(|v| old_of_new[v as usize]), *old, "strip {s}");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Random, non-manifold, disconnected meshes with repeated vertices: every triangle
    /// once, with its winding, for Strip-RT and for meshoptimizer's strips.
    #[test]
    fn random_meshes_strip_losslessly(
        mesh in scenes::arbitrary_mesh(),
        max_length in 1usize..40,
        tunnel_cuts in 0..=tunnel::MAX_CUTS,
        morton in proptest::bool::ANY,
    ) {
        let partition = if morton { PartitionMethod::Morton } else { PartitionMethod::Sah };
        let strips = stripify(&mesh, &StripSettings { max_length, tunnel_cuts, partition });
        assert_valid(&mesh, &strips, max_length);
        // Tunnelling only ever joins strips.
        let published = stripify(&mesh, &StripSettings { max_length, tunnel_cuts: 0, partition });
        prop_assert!(strips.len() <= published.len());
        let theirs = meshopt::stripify(&mesh, max_length);
        assert_valid(&mesh, &theirs.strips, max_length);
        assert_packs_losslessly(&mesh, &strips);
        assert_packs_losslessly(&mesh, &theirs.strips);
    }

    /// A grid with holes punched in it.
    #[test]
    fn grids_with_holes_strip_losslessly(holes in proptest::collection::vec(0usize..800, 0..100)) {
        let mesh = scenes::grid_with_holes(&holes);
        let strips = stripify(&mesh, &StripSettings::default());
        assert_valid(&mesh, &strips, default_length());
    }
}

#[test]
fn rts_files_round_trip_and_refuse_damage() {
    let mesh = scenes::uv_sphere(10, 20);
    let strips = stripify(&mesh, &StripSettings::default());
    let bytes = strips.to_rts(&mesh.positions);
    let (positions, back) = Strips::from_rts(&bytes).expect("valid");
    assert_eq!(positions, mesh.positions);
    assert_eq!(back, strips);
    assert!(Strips::from_rts(&bytes[..bytes.len() - 1]).is_err());
    assert!(Strips::from_rts(b"RTS1").is_err());
    let mut absurd = bytes.clone();
    absurd[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(Strips::from_rts(&absurd).is_err());
}

/// Traced through each `(inside, strips per leaf, strips)`, the strips of `mesh` hit
/// what its triangles hit on primary, diffuse and shadow rays, but for edge ties.
fn assert_traced_like_triangles(
    mesh: &TriMesh,
    configs: &[(crate::trace::strip::Inside, usize, &Strips)],
) {
    use crate::bvh::BuildSettings;
    use crate::trace::run::{trace_closest, trace_occluded};
    use crate::trace::strip::StripAccel;
    use crate::trace::{NoCounters, RayKind, SceneAccel, Workload};
    let scene = crate::Scene::from_mesh(mesh.clone());
    let triangles = SceneAccel::build(&scene, &BuildSettings::default());
    for kind in [RayKind::Primary, RayKind::Diffuse, RayKind::Shadow] {
        let work = Workload::generate(kind, &scene, &triangles, 64, 64, 1);
        let reference = trace_closest::<NoCounters>(&triangles, &work.rays).0;
        let reference_occluded = trace_occluded::<NoCounters>(&triangles, &work.rays).0;
        for &(inside, per_leaf, strips) in configs {
            let accel =
                StripAccel::build(&mesh.positions, strips, per_leaf, inside).expect("short strips");
            // Any-hit: occluded exactly where the triangles are, but for edge ties.
            let occluded = trace_occluded::<NoCounters>(&accel, &work.rays).0;
            let agree = occluded
                .iter()
                .zip(&reference_occluded)
                .filter(|(a, b)| a == b)
                .count();
            assert!(
                agree as f64 >= 0.999 * occluded.len() as f64,
                "{kind:?} {inside:?} occlusion: {agree}/{}",
                occluded.len()
            );
            assert_eq!(occluded.contains(&true), reference_occluded.contains(&true));
            let hits = trace_closest::<NoCounters>(&accel, &work.rays).0;
            let same = hits
                .iter()
                .zip(&reference)
                .filter(|(a, b)| a.triangle == b.triangle)
                .count();
            // Ties at equal distance on shared edges may go either way; nothing else.
            assert!(
                same as f64 >= 0.999 * hits.len() as f64,
                "{kind:?} {inside:?}: {same}/{}",
                hits.len()
            );
            for (a, b) in hits.iter().zip(&reference) {
                assert_eq!(a.is_hit(), b.is_hit());
                if a.is_hit() {
                    assert!(
                        (a.t - b.t).abs() <= 1e-4 * b.t.abs().max(1.0),
                        "{} vs {}",
                        a.t,
                        b.t
                    );
                }
            }
        }
    }
}

#[test]
fn traced_strips_hit_what_triangles_hit() {
    use crate::trace::strip::Inside;
    let mesh = scenes::scan_blob(20_000, 7);
    let strips = stripify(&mesh, &StripSettings::default());
    // Quantized boxes also in strips of up to 64 triangles (two 8-wide box tests).
    let long = stripify(
        &mesh,
        &StripSettings {
            max_length: 64,
            ..Default::default()
        },
    );
    assert!((0..long.len()).any(|s| long.triangles_of(s).len() > 32));
    assert_traced_like_triangles(
        &mesh,
        &[
            (Inside::Flat, 2, &strips),
            (Inside::Implicit, 2, &strips),
            (Inside::Quantized, 2, &strips),
            (Inside::Quantized, 1, &long),
        ],
    );
    // One strip: the top tree is one leaf, and the quantized boxes' frame is the
    // strip's own box.
    let quad = scenes::quad_grid(1);
    let one = stripify(&quad, &StripSettings::default());
    assert_eq!(one.len(), 1);
    assert_traced_like_triangles(&quad, &[(Inside::Quantized, 1, &one)]);
}

/// The triangles of `mesh` that name three vertices, each as its rotation starting at
/// its smallest index, sorted: the same surface with the same winding.
fn surface(mesh: &TriMesh) -> Vec<[u32; 3]> {
    let mut out: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .filter(|&&t| !crate::mesh::names_a_vertex_twice(t))
        .map(|&t| crate::mesh::smallest_first(t))
        .collect();
    out.sort_unstable();
    out
}

#[test]
fn strips_written_as_gltf_and_ply_read_back_as_the_same_surface() {
    let dir = std::env::temp_dir().join(format!("rtmesh-strip-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut scene = scenes::room();
    for mesh in &mut scene.meshes {
        *mesh = crate::mesh::weld_exact(mesh).mesh;
    }
    let strips: Vec<Strips> = scene
        .meshes
        .iter()
        .map(|m| stripify(m, &StripSettings::default()))
        .collect();
    for name in ["room.glb", "room.gltf"] {
        let path = dir.join(name);
        crate::io::write_gltf_strips(&scene, &strips, &path, &[]).unwrap();
        let back = crate::io::read(&path).unwrap();
        assert_eq!(back.meshes.len(), scene.meshes.len());
        for (a, b) in scene.meshes.iter().zip(&back.meshes) {
            assert_eq!(surface(a), surface(b), "{name}: {}", a.name);
            assert_eq!(a.positions, b.positions);
        }
        assert_eq!(back.instances.len(), scene.instances.len());
    }
    let flat = crate::mesh::weld_exact(&scene.flatten().unwrap()).mesh;
    let flat_strips = stripify(&flat, &StripSettings::default());
    let path = dir.join("room.ply");
    crate::io::write_ply_strips(&flat, &flat_strips.to_standard(), &path).unwrap();
    let back = crate::io::read(&path).unwrap();
    assert_eq!(surface(&flat), surface(&back.meshes[0]));
    std::fs::remove_dir_all(&dir).ok();
}

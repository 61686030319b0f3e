use super::*;
use base64::Engine;
use glam::{Mat4, Quat};
use serde_json::json;

/// A glTF of two meshes, built by hand so that every frame's positions are known
/// exactly:
/// - mesh 0, skinned to joints 1 (the root, rotated about Z from 0° to 90°, LINEAR) and
///   2 (its child at +2 Y, moved to +3 Y at t = 0.5, STEP); vertex 0 follows joint 1,
///   vertex 1 joint 2, vertex 2 half each;
/// - mesh 1 at node 3, unskinned, with one morph target (+1 Z, weight 0 → 1 LINEAR)
///   and a CUBICSPLINE translation from 0 to +2 X with out-tangent +4 Y at the first
///   key.
fn hand_built() -> Scene {
    hand_built_with(|_| {}).expect("the hand-built glTF reads")
}

/// [`hand_built`]'s document changed by `edit` before it is read.
fn hand_built_with(
    edit: impl FnOnce(&mut serde_json::Value),
) -> Result<Scene, crate::io::MeshError> {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut push = |floats: &[f32], kind: &str, count: usize| {
        let offset = bin.len();
        bin.extend(floats.iter().flat_map(|f| f.to_le_bytes()));
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": 4 * floats.len()}));
        let mut accessor = json!({"bufferView": views.len() - 1, "componentType": 5126, "count": count, "type": kind});
        if kind == "VEC3" {
            // glTF asks for the bounds of POSITION accessors.
            let corner = |pick: fn(f32, f32) -> f32| {
                (0..3)
                    .map(|c| {
                        floats
                            .iter()
                            .skip(c)
                            .step_by(3)
                            .copied()
                            .reduce(pick)
                            .unwrap()
                    })
                    .collect::<Vec<f32>>()
            };
            accessor["min"] = json!(corner(f32::min));
            accessor["max"] = json!(corner(f32::max));
        }
        accessors.push(accessor);
        accessors.len() - 1
    };
    let p0 = push(&[1., 0., 0., 0., 1., 0., 0., 0., 1.], "VEC3", 3);
    let w0 = push(
        &[1., 0., 0., 0., 1., 0., 0., 0., 0.5, 0.5, 0., 0.],
        "VEC4",
        3,
    );
    let p1 = push(&[0., 0., 0., 1., 0., 0., 0., 1., 0.], "VEC3", 3);
    let d1 = push(&[0., 0., 1., 0., 0., 1., 0., 0., 1.], "VEC3", 3);
    let mut ibm = Mat4::IDENTITY.to_cols_array().to_vec();
    ibm.extend(Mat4::from_translation(Vec3::new(0., -2., 0.)).to_cols_array());
    let ibm = push(&ibm, "MAT4", 2);
    let t01 = push(&[0., 1.], "SCALAR", 2);
    let t0h = push(&[0., 0.5], "SCALAR", 2);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let rot = push(&[0., 0., 0., 1., 0., 0., s, s], "VEC4", 2);
    let step = push(&[0., 2., 0., 0., 3., 0.], "VEC3", 2);
    #[rustfmt::skip]
    let cubic = push(&[0., 0., 0.,  0., 0., 0.,  0., 4., 0.,   0., 0., 0.,  2., 0., 0.,  0., 0., 0.], "VEC3", 6);
    let weights = push(&[0., 1.], "SCALAR", 2);
    // Joints as u8 VEC4, a view of their own.
    let joints_offset = bin.len();
    bin.extend([0u8, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0]);
    views.push(json!({"buffer": 0, "byteOffset": joints_offset, "byteLength": 12}));
    accessors.push(
        json!({"bufferView": views.len() - 1, "componentType": 5121, "count": 3, "type": "VEC4"}),
    );
    let j0 = accessors.len() - 1;
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    let mut document = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 3]}],
        "nodes": [
            {"mesh": 0, "skin": 0},
            {"children": [2]},
            {"translation": [0., 2., 0.]},
            {"mesh": 1},
        ],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": p0, "JOINTS_0": j0, "WEIGHTS_0": w0}}]},
            {"primitives": [{"attributes": {"POSITION": p1}, "targets": [{"POSITION": d1}]}], "weights": [0.0]},
        ],
        "skins": [{"joints": [1, 2], "inverseBindMatrices": ibm}],
        "animations": [{
            "name": "hand",
            "samplers": [
                {"input": t01, "output": rot, "interpolation": "LINEAR"},
                {"input": t0h, "output": step, "interpolation": "STEP"},
                {"input": t01, "output": cubic, "interpolation": "CUBICSPLINE"},
                {"input": t01, "output": weights, "interpolation": "LINEAR"},
            ],
            "channels": [
                {"sampler": 0, "target": {"node": 1, "path": "rotation"}},
                {"sampler": 1, "target": {"node": 2, "path": "translation"}},
                {"sampler": 2, "target": {"node": 3, "path": "translation"}},
                {"sampler": 3, "target": {"node": 3, "path": "weights"}},
            ],
        }],
        "buffers": [{"byteLength": bin.len(), "uri": uri}],
        "bufferViews": views,
        "accessors": accessors,
    });
    edit(&mut document);
    crate::io::read_bytes(
        std::path::Path::new("hand.gltf"),
        document.to_string().as_bytes(),
    )
}

fn assert_near(got: &[Vec3], expected: &[Vec3]) {
    assert_eq!(got.len(), expected.len());
    for (v, (g, e)) in got.iter().zip(expected).enumerate() {
        assert!((*g - *e).length() < 1e-5, "vertex {v}: {g} != {e}");
    }
}

#[test]
fn gltf_skin_channels_and_morphs_give_the_exact_positions() {
    let scene = hand_built();
    let (mesh, animation) = Animation::of(&scene, &Motion::Gltf(None)).unwrap();
    assert_eq!(animation.name(), "hand");
    assert_eq!(mesh.triangle_count(), 2);
    assert!(
        mesh.attributes
            .iter()
            .all(|a| a.name != "JOINTS_0" && a.semantic() != Semantic::MorphDelta),
        "a frame has the skin and morphs applied"
    );
    // t = 0: the rest pose (joint 2's bind pose undone by its inverse bind matrix).
    assert_near(
        &animation.positions(0.0),
        &[Vec3::X, Vec3::Y, Vec3::Z, Vec3::ZERO, Vec3::X, Vec3::Y],
    );
    // t = 0.5: joint 1 at 45°, joint 2 stepped to +3 Y; morph weight 0.5; the spline at
    // s = 0.5 gives x = 1 and y = 4 · (s³ − 2s² + s) = 0.5.
    let r = Quat::from_rotation_z(std::f32::consts::FRAC_PI_4);
    assert_near(
        &animation.positions(0.5),
        &[
            r * Vec3::X,
            r * Vec3::new(0., 2., 0.),
            r * Vec3::new(0., 0.5, 1.),
            Vec3::new(1., 0.5, 0.5),
            Vec3::new(2., 0.5, 0.5),
            Vec3::new(1., 1.5, 0.5),
        ],
    );
    // t = 1: 90°, after the last keys.
    assert_near(
        &animation.positions(1.0),
        &[
            Vec3::Y,
            Vec3::new(-2., 0., 0.),
            Vec3::new(-0.5, 0., 1.),
            Vec3::new(2., 0., 1.),
            Vec3::new(3., 0., 1.),
            Vec3::new(2., 1., 1.),
        ],
    );
}

#[test]
fn gltf_motion_names_what_is_wrong() {
    let scene = hand_built();
    let err = Animation::of(&scene, &Motion::Gltf(Some("walk".into())))
        .err()
        .unwrap();
    assert_eq!(
        err.to_string(),
        "no animation is called or numbered `walk`; the file has: hand"
    );
    assert!(Animation::of(&scene, &Motion::Gltf(Some("0".into()))).is_ok());
    let plain = Scene::from_mesh(crate::scenes::scan_blob(100, 1));
    assert!(matches!(
        Animation::of(&plain, &Motion::Gltf(None)),
        Err(AnimationError::NotGltf)
    ));
    assert_eq!(
        "gltf:Run".parse::<Motion>(),
        Ok(Motion::Gltf(Some("Run".into())))
    );
    assert_eq!(
        "twist".parse::<Motion>(),
        Ok(Motion::Procedural(Procedural::Twist))
    );
    assert!("gltf:".parse::<Motion>().is_err());
    assert_eq!(Motion::Gltf(Some("Run".into())).to_string(), "gltf:Run");
}

/// Lying animation data is an error naming what is wrong, never a panic.
#[test]
fn malformed_animation_data_is_refused() {
    type Edit = fn(&mut serde_json::Value);
    let cases: [(Edit, &str); 5] = [
        // Two rotations are too few for two CUBICSPLINE keys (3 each).
        (
            |d| d["animations"][0]["samplers"][0]["interpolation"] = json!("CUBICSPLINE"),
            "8 output values for 2 keys of 12",
        ),
        (|d| d["skins"][0]["joints"] = json!([1]), "names joint 1"),
        (
            |d| d["animations"][0]["samplers"][0]["output"] = json!(0),
            "expected Vec4",
        ),
        (|d| d["accessors"][4]["count"] = json!(200), "runs past"),
        (
            |d| d["meshes"][0]["primitives"][0]["attributes"] = json!({"POSITION": 0}),
            "no JOINTS_0",
        ),
    ];
    for (k, (edit, expected)) in cases.into_iter().enumerate() {
        let message = match hand_built_with(edit) {
            Err(e) => e.to_string(),
            Ok(scene) => match Animation::of(&scene, &Motion::Gltf(None)) {
                Err(e) => e.to_string(),
                Ok(_) => panic!("case {k} was accepted"),
            },
        };
        assert!(message.contains(expected), "case {k}: {message}");
    }
}

/// [`hand_built`] with directions: mesh 0 (skinned) has normals along X and tangents
/// along Y with w = −1, mesh 1 a normal along Z whose morph target adds +1 X. Every
/// joint turns 90° about Z by t = 1, so the skinned normals end along Y and the
/// tangents along −X (w kept); the morphed normal is (w, 0, 1) normalized at weight w.
#[test]
fn gltf_frames_turn_normals_and_tangents_with_skins_and_morphs() {
    let scene = hand_built_with(|d| {
        let floats: [f32; 9 + 12 + 9 + 9] = [
            1., 0., 0., 1., 0., 0., 1., 0., 0., // mesh 0 normals
            0., 1., 0., -1., 0., 1., 0., -1., 0., 1., 0., -1., // mesh 0 tangents
            0., 0., 1., 0., 0., 1., 0., 0., 1., // mesh 1 normals
            1., 0., 0., 1., 0., 0., 1., 0., 0., // mesh 1 normal deltas
        ];
        let bin: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bin)
        );
        d["buffers"]
            .as_array_mut()
            .unwrap()
            .push(json!({"byteLength": bin.len(), "uri": uri}));
        let mut add = |offset: usize, floats: usize, kind: &str| {
            let views = d["bufferViews"].as_array_mut().unwrap();
            views.push(json!({"buffer": 1, "byteOffset": 4 * offset, "byteLength": 4 * floats}));
            let view = views.len() - 1;
            let accessors = d["accessors"].as_array_mut().unwrap();
            accessors
                .push(json!({"bufferView": view, "componentType": 5126, "count": 3, "type": kind}));
            accessors.len() - 1
        };
        let (n0, t0, n1, dn1) = (
            add(0, 9, "VEC3"),
            add(9, 12, "VEC4"),
            add(21, 9, "VEC3"),
            add(30, 9, "VEC3"),
        );
        let meshes = &mut d["meshes"];
        meshes[0]["primitives"][0]["attributes"]["NORMAL"] = json!(n0);
        meshes[0]["primitives"][0]["attributes"]["TANGENT"] = json!(t0);
        meshes[1]["primitives"][0]["attributes"]["NORMAL"] = json!(n1);
        meshes[1]["primitives"][0]["targets"][0]["NORMAL"] = json!(dn1);
    })
    .unwrap();
    let (mut mesh, animation) = Animation::of(&scene, &Motion::Gltf(None)).unwrap();
    let stream = |mesh: &TriMesh, name: &str| {
        let a = mesh.attribute(name).unwrap();
        (0..a.vertex_count())
            .map(|v| a.vertex(v))
            .collect::<Vec<_>>()
    };
    for (phase, weight) in [(0.0f32, 0.0f64), (0.5, 0.5), (1.0, 1.0)] {
        animation.pose(phase, &mut mesh);
        let turn = (f64::from(phase) * std::f64::consts::FRAC_PI_2).sin_cos();
        let morphed = [weight, 0.0, 1.0].map(|c| c / (weight * weight + 1.0).sqrt());
        let (normals, tangents) = (stream(&mesh, "NORMAL"), stream(&mesh, "TANGENT"));
        let expected_normals = [[turn.1, turn.0, 0.0]; 3].into_iter().chain([morphed; 3]);
        for (v, (got, expected)) in normals.iter().zip(expected_normals).enumerate() {
            let close = got.iter().zip(expected).all(|(g, e)| (g - e).abs() < 1e-6);
            assert!(
                close,
                "phase {phase}, vertex {v}: normal {got:?}, expected {expected:?}"
            );
        }
        // Mesh 1 has no tangents: zeros, as flattening fills them.
        let expected_tangents = [[-turn.0, turn.1, 0.0, -1.0]; 3]
            .into_iter()
            .chain([[0.0; 4]; 3]);
        for (v, (got, expected)) in tangents.iter().zip(expected_tangents).enumerate() {
            let close = got.iter().zip(expected).all(|(g, e)| (g - e).abs() < 1e-6);
            assert!(
                close,
                "phase {phase}, vertex {v}: tangent {got:?}, expected {expected:?}"
            );
        }
    }
}

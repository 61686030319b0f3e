//! Hostile assets: references that leave the asset's folder are refused, naming the
//! asset and the reference, and nothing outside the folder is read (a canary file
//! beside the folder must never show up in what is read).

use std::path::{Path, PathBuf};

/// A fresh folder `root/asset/` with a canary file at `root/canary.bin` beside it.
fn sandbox(name: &str) -> (PathBuf, PathBuf) {
    let root = std::env::temp_dir().join(format!("rtmesh-hostile-{}-{name}", std::process::id()));
    let asset = root.join("asset");
    std::fs::create_dir_all(&asset).unwrap();
    // 36 bytes: three float VEC3 positions, if anyone reads it as a buffer.
    std::fs::write(root.join("canary.bin"), [0x41u8; 36]).unwrap();
    std::fs::write(root.join("canary.mtl"), "newmtl stolen\nd 0.5\n").unwrap();
    (root, asset)
}

/// A glTF of one triangle whose buffer is `uri`.
fn gltf_with_buffer(uri: &str) -> String {
    gltf(uri, r#"[{"mesh":0}]"#, "[0]", "")
}

/// A glTF of one triangle whose buffer is `uri`, with the nodes, scene roots and extra
/// buffer view fields given.
fn gltf(uri: &str, nodes: &str, roots: &str, view_extra: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"uri":"{uri}","byteLength":36}}],
        "bufferViews":[{{"buffer":0,"byteLength":36{view_extra}}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "nodes":{nodes},"scenes":[{{"nodes":{roots}}}],"scene":0}}"#
    )
}

fn error_reading(path: &Path) -> String {
    match rtmesh::io::read(path) {
        Ok(scene) => panic!("{}: read {} meshes", path.display(), scene.meshes.len()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn obj_material_libraries_outside_the_folder_are_refused() {
    let (root, asset) = sandbox("obj");
    for (name, mtllib) in [
        ("absolute.obj", "/etc/passwd".to_owned()),
        ("climbs.obj", "../canary.mtl".to_owned()),
        ("device.obj", "/dev/zero".to_owned()),
    ] {
        let obj = asset.join(name);
        std::fs::write(
            &obj,
            format!("mtllib {mtllib}\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
        )
        .unwrap();
        let message = error_reading(&obj);
        assert!(
            message.contains(name) && message.contains(&format!("refers to '{mtllib}'")),
            "{message}"
        );
    }
    // Inside the folder, and missing: both fine.
    std::fs::write(asset.join("ok.mtl"), "newmtl glass\nd 0.5\n").unwrap();
    let obj = asset.join("ok.obj");
    std::fs::write(
        &obj,
        "mtllib ok.mtl\nmtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl glass\nf 1 2 3\n",
    )
    .unwrap();
    let scene = rtmesh::io::read(&obj).unwrap();
    assert!(scene
        .materials
        .iter()
        .any(|m| m.name == "glass" && m.alpha_tested));
    std::fs::remove_dir_all(&root).ok();
}

#[test]
fn gltf_buffers_outside_the_folder_are_refused() {
    let (root, asset) = sandbox("gltf");
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(root.join("canary.bin"), asset.join("link.bin")).unwrap();
        std::os::unix::fs::symlink("/dev/zero", asset.join("zero.bin")).unwrap();
    }
    for (name, uri, says) in [
        ("climbs.gltf", "../canary.bin", "climbs out"),
        ("escaped.gltf", "%2e%2e/canary.bin", "climbs out"),
        ("absolute.gltf", "/dev/zero", "absolute"),
        ("scheme.gltf", "file:///etc/passwd", "absolute"),
        #[cfg(unix)]
        ("link.gltf", "link.bin", "through a link"),
        #[cfg(unix)]
        ("zero.gltf", "zero.bin", "not a regular file"),
    ] {
        let file = asset.join(name);
        std::fs::write(&file, gltf_with_buffer(uri)).unwrap();
        let message = error_reading(&file);
        assert!(
            message.contains(name) && message.contains("refers to '") && message.contains(says),
            "{name}: {message}"
        );
    }
    std::fs::remove_dir_all(&root).ok();
}

#[test]
fn gltf_buffers_beside_the_file_and_data_uris_read() {
    let (root, asset) = sandbox("fine");
    let corners: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    std::fs::write(asset.join("tri angle.bin"), &corners).unwrap();
    let file = asset.join("beside.gltf");
    std::fs::write(&file, gltf_with_buffer("tri%20angle.bin")).unwrap();
    let scene = rtmesh::io::read(&file).unwrap();
    assert_eq!(scene.meshes[0].positions[1], glam::Vec3::X);
    // A data: URI (base64 of the same 36 bytes).
    let file = asset.join("inline.gltf");
    std::fs::write(&file, gltf_with(r#"[{"mesh":0}]"#, "[0]", "")).unwrap();
    let scene = rtmesh::io::read(&file).unwrap();
    assert_eq!(scene.meshes[0].positions[2], glam::Vec3::Y);
    std::fs::remove_dir_all(&root).ok();
}

/// The 36 bytes of the triangle (0,0,0), (1,0,0), (0,1,0), base64.
const TRIANGLE_BASE64: &str = "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA";

/// A glTF of one triangle in a data: URI, with the nodes and buffer view given.
fn gltf_with(nodes: &str, roots: &str, view_extra: &str) -> Vec<u8> {
    let uri = format!("data:application/octet-stream;base64,{TRIANGLE_BASE64}");
    gltf(&uri, nodes, roots, view_extra).into_bytes()
}

/// Reading `bytes` as `name` fails with a message that starts with `prefix`.
fn assert_error(name: &str, bytes: &[u8], prefix: &str) {
    let message = error_of(name, bytes);
    assert!(message.starts_with(prefix), "{message}");
}

fn error_of(name: &str, bytes: &[u8]) -> String {
    match rtmesh::io::read_bytes(Path::new(name), bytes) {
        Ok(scene) => panic!("{name}: read {} instances", scene.instances.len()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn node_graphs_with_cycles_are_errors_and_deep_chains_are_exact() {
    assert_error(
        "twice.gltf",
        &gltf_with(r#"[{"mesh":0,"children":[0,0]}]"#, "[0]", ""),
        "twice.gltf: node 0 is listed as a child of node 0",
    );
    let own = error_of(
        "own.gltf",
        &gltf_with(r#"[{"mesh":0,"children":[1]},{"children":[0]}]"#, "[0]", ""),
    );
    assert!(
        own.contains("node 0 is listed as a child of node 1") || own.contains("cycle"),
        "{own}"
    );
    assert_error(
        "self.gltf",
        &gltf_with(r#"[{"mesh":0,"children":[0]}]"#, "[0]", ""),
        "self.gltf: node 0 is reached twice",
    );
    // 10,000 nested nodes, each one unit along x: one instance at x = 10,000.
    let depth = 10_000;
    let nodes: Vec<String> = (0..depth)
        .map(|i| {
            if i + 1 < depth {
                format!(r#"{{"translation":[1,0,0],"children":[{}]}}"#, i + 1)
            } else {
                r#"{"translation":[1,0,0],"mesh":0}"#.to_owned()
            }
        })
        .collect();
    let scene = rtmesh::io::read_bytes(
        Path::new("deep.gltf"),
        &gltf_with(&format!("[{}]", nodes.join(",")), "[0]", ""),
    )
    .unwrap();
    assert_eq!(scene.instances.len(), 1);
    assert_eq!(scene.instances[0].transform.translation.x, depth as f32);
    assert_eq!(scene.bounds().max.x, depth as f32 + 1.0);
}

#[test]
fn odd_strides_are_errors_not_panics() {
    // 7 and 256 the gltf crate's own validation refuses; 8 is valid glTF but shorter than a
    // 12-byte element, which rtmesh refuses before the crate reads it.
    for (stride, says) in [(7, "byteStride"), (8, "byteStride 8"), (256, "byteStride")] {
        let bytes = gltf_with(
            r#"[{"mesh":0}]"#,
            "[0]",
            &format!(r#","byteStride":{stride}"#),
        );
        let message = error_of("stride.gltf", &bytes);
        assert!(
            message.starts_with("stride.gltf: ") && message.contains(says),
            "{message}"
        );
    }
}

#[test]
fn an_asset_root_above_the_folder_lets_references_climb_to_it_and_no_further() {
    let (root, asset) = sandbox("root");
    let file = asset.join("climbs.gltf");
    std::fs::write(&file, gltf_with_buffer("../canary.bin")).unwrap();
    let options = |dir: &Path| rtmesh::io::ReadOptions {
        asset_root: Some(dir.to_owned()),
    };
    let scene = rtmesh::io::read_with(&file, &options(&root), &mut |_, _| {}).unwrap();
    assert_eq!(scene.meshes[0].positions.len(), 3);
    let message = rtmesh::io::read_with(&file, &options(&asset), &mut |_, _| {})
        .unwrap_err()
        .to_string();
    assert!(message.contains("refers to '../canary.bin'"), "{message}");
    std::fs::remove_dir_all(&root).ok();
}

/// A glTF in `asset` whose buffer `name.bin` holds `data`, with the views, accessors,
/// meshes and extra top-level fields given; its path.
fn gltf_file(asset: &Path, name: &str, data: &[u8], body: &str) -> PathBuf {
    std::fs::write(asset.join(format!("{name}.bin")), data).unwrap();
    let path = asset.join(format!("{name}.gltf"));
    let doc = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"uri":"{name}.bin","byteLength":{}}}],
        "nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0,{body}}}"#,
        data.len()
    );
    std::fs::write(&path, doc).unwrap();
    path
}

/// Primitives that name one accessor read it again each time: a few do (a file may read
/// twice its buffers, plus 16 MiB), two hundred of a 30,000-vertex soup (24 MB of
/// corners from a 360 kB buffer) are refused, naming the primitive.
#[test]
fn one_accessor_named_by_many_primitives_is_refused_past_the_read_budget() {
    let (root, asset) = sandbox("amp-primitives");
    let n = 30_000;
    let soup: Vec<u8> = (0..n)
        .flat_map(|k| {
            [
                k as f32 * 1e-3 + (k % 3 == 1) as u8 as f32,
                (k % 3 == 2) as u8 as f32,
                0.0,
            ]
        })
        .flat_map(f32::to_le_bytes)
        .collect();
    let with = |primitives: usize| {
        let primitive = r#"{"attributes":{"POSITION":0}}"#;
        let body = format!(
            r#""bufferViews":[{{"buffer":0,"byteLength":{}}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":{n},"type":"VEC3","min":[0,0,0],"max":[31,1,0]}}],
            "meshes":[{{"primitives":[{}]}}]"#,
            soup.len(),
            vec![primitive; primitives].join(",")
        );
        gltf_file(&asset, &format!("soup{primitives}"), &soup, &body)
    };
    let few = rtmesh::io::read(&with(4)).unwrap();
    assert_eq!(few.meshes[0].triangle_count(), 4 * n / 3);
    let message = error_reading(&with(200));
    assert!(
        message.contains("soup200.gltf")
            && message.contains("primitive")
            && message.contains("over and over"),
        "{message}"
    );
    std::fs::remove_dir_all(root).ok();
}

/// Channels that share one sampler's 100,000 key times read them once; their outputs
/// count each time. 14 channels read 17 MB of a 20 MB budget (22 MB if the shared times
/// counted each time); 20 are refused, naming the channel.
#[test]
fn animation_channels_share_key_times_and_are_refused_past_the_read_budget() {
    use rtmesh::animate::{Animation, Motion};
    let (root, asset) = sandbox("amp-channels");
    let keys = 100_000;
    let mut data: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .into_iter()
        .chain((0..keys).map(|k| k as f32 / 30.0))
        .flat_map(f32::to_le_bytes)
        .collect();
    data.resize(36 + 16 * keys, 0);
    let with = |channels: usize| {
        let channel = r#"{"sampler":0,"target":{"node":0,"path":"translation"}}"#;
        let body = format!(
            r#""bufferViews":[{{"buffer":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":{}}},{{"buffer":0,"byteOffset":{},"byteLength":{}}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
              {{"bufferView":1,"componentType":5126,"count":{keys},"type":"SCALAR","min":[0],"max":[{}]}},
              {{"bufferView":2,"componentType":5126,"count":{keys},"type":"VEC3"}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
            "animations":[{{"samplers":[{{"input":1,"output":2}}],"channels":[{}]}}]"#,
            4 * keys,
            36 + 4 * keys,
            12 * keys,
            (keys - 1) as f32 / 30.0,
            vec![channel; channels].join(",")
        );
        let path = gltf_file(&asset, &format!("channels{channels}"), &data, &body);
        let scene = rtmesh::io::read(&path).unwrap();
        Animation::of(&scene, &Motion::Gltf(None)).map(|_| ())
    };
    assert!(with(14).is_ok());
    let message = with(20).unwrap_err().to_string();
    assert!(
        message.contains("channel") && message.contains("over and over"),
        "{message}"
    );
    std::fs::remove_dir_all(root).ok();
}

/// An OBJ reads each material library once however often `mtllib` names it, and all
/// its libraries together within MAX_MATERIAL_LIBRARY_BYTES: 2,000 `mtllib` lines of
/// one 2 MB library give its 100,000 materials once; ten spellings of its path are
/// refused, naming the OBJ.
#[test]
fn material_libraries_are_read_once_and_within_a_budget() {
    let (root, asset) = sandbox("amp-mtllib");
    let library: String = (0..100_000)
        .map(|k| format!("newmtl m{k}\nKd 1 0 0\n"))
        .collect();
    std::fs::write(asset.join("library.mtl"), &library).unwrap();
    let triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m5\nf 1 2 3\n";
    let repeated = asset.join("repeated.obj");
    std::fs::write(&repeated, "mtllib library.mtl\n".repeat(2000) + triangle).unwrap();
    let scene = rtmesh::io::read(&repeated).unwrap();
    // The library's materials once, and the default for faces without one.
    assert!(
        scene.materials.len() <= 100_001,
        "{}",
        scene.materials.len()
    );
    let used = scene.meshes[0].material_ids[0] as usize;
    assert_eq!(scene.materials[used].name, "m5");
    assert!(library.len() as u64 * 10 > rtmesh::io::MAX_MATERIAL_LIBRARY_BYTES);
    let respelled = asset.join("respelled.obj");
    let lines: String = (0..10)
        .map(|k| format!("mtllib {}library.mtl\n", "./".repeat(k)))
        .collect();
    std::fs::write(&respelled, lines + triangle).unwrap();
    let message = error_reading(&respelled);
    assert!(
        message.contains("respelled.obj") && message.contains("material libraries hold over"),
        "{message}"
    );
    std::fs::remove_dir_all(root).ok();
}

/// tobj 4.0.5 panics on a colour of fewer than three numbers (found by fuzzing
/// `obj_side_files`: `Ke 0`). One number is MTL's grey (`Kd r` is `Kd r r r`), and is
/// read so; none or two are an error at the library's line.
#[test]
fn mtl_colours_of_one_number_are_grey_and_of_none_or_two_are_errors() {
    let (root, asset) = sandbox("mtl-colours");
    let triangle = "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n";
    std::fs::write(asset.join("a.obj"), triangle).unwrap();
    std::fs::write(asset.join("a.mtl"), "newmtl m\nKd 0.5\nKe 0.25\nKs 1 0 0").unwrap();
    let scene = rtmesh::io::read(&asset.join("a.obj")).unwrap();
    let m = scene.materials.iter().find(|m| m.name == "m").unwrap();
    let look = m.mtl.as_ref().unwrap();
    assert_eq!((look.diffuse, look.emissive), ([0.5; 3], [0.25; 3]));
    for (colours, line, count) in [("Kd 1 1 1\nKe", 3, 0), ("Ka 0 0", 2, 2)] {
        std::fs::write(asset.join("a.mtl"), format!("newmtl m\n{colours}\n")).unwrap();
        let message = error_reading(&asset.join("a.obj"));
        let expected = format!("a.mtl:{line}: '");
        assert!(message.contains(&expected), "{message}");
        assert!(message.contains(&format!("not {count}")), "{message}");
    }
    std::fs::remove_dir_all(root).ok();
}

/// A missing library's stand-in materials are made only for the `usemtl` names no
/// found library defines, in either order of the `mtllib` lines (before, a missing
/// library named after the found one replaced its cut-out `leaf` with a plain one).
#[test]
fn a_missing_library_never_replaces_a_found_librarys_materials() {
    let (root, asset) = sandbox("mtl-stand-ins");
    std::fs::write(asset.join("real.mtl"), "newmtl leaf\nd 0.5\n").unwrap();
    let triangles = "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl leaf\nf 1 2 3\nusemtl bark\nf 1 3 2\n";
    for libraries in [
        "mtllib real.mtl\nmtllib gone.mtl\n",
        "mtllib gone.mtl\nmtllib real.mtl\n",
    ] {
        std::fs::write(asset.join("a.obj"), format!("{libraries}{triangles}")).unwrap();
        let scene = rtmesh::io::read(&asset.join("a.obj")).unwrap();
        let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(
            names.iter().filter(|&&n| n == "leaf").count(),
            1,
            "{names:?}"
        );
        assert!(names.contains(&"bark"), "{names:?}");
        assert_eq!(scene.meshes[0].alpha_tested, [true, false], "{libraries}");
    }
    std::fs::remove_dir_all(root).ok();
}

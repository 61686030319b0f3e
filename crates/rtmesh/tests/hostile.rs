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

//! The files an output refers to and does not hold (an OBJ's material libraries and
//! their textures, a glTF's image files) are copied beside an output in another folder,
//! byte for byte at the same relative paths, and only by the rule for references: a
//! crafted reference copies nothing from outside the input's folder.

use rtmesh::io::{copy_side_files, ReadOptions, SideFiles};
use std::path::{Path, PathBuf};

/// A fresh folder with `in/` and `out/`, and a canary file beside `in/`.
fn sandbox(name: &str) -> (PathBuf, PathBuf) {
    let root = std::env::temp_dir().join(format!("rtmesh-side-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(root.join("in/tex")).unwrap();
    std::fs::create_dir_all(root.join("out")).unwrap();
    std::fs::write(root.join("canary.png"), "secret").unwrap();
    (root.join("in"), root.join("out"))
}

const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nusemtl glass\nf 1 2 3\nf 2 4 3\n";

/// Read `input`, write it to `output` and copy its side files.
fn convert(input: &Path, output: &Path, options: &ReadOptions) -> SideFiles {
    let scene = rtmesh::io::read_with(input, options, &mut |_, _| {}).unwrap();
    let copies = copy_side_files(input, &scene, output, options).unwrap();
    rtmesh::io::write(&scene, output).unwrap();
    copies
}

#[test]
fn an_obj_written_elsewhere_keeps_its_materials_and_textures() {
    let (input, out) = sandbox("obj");
    std::fs::write(
        input.join("a.obj"),
        format!("mtllib a.mtl\nmtllib a.mtl\n{QUAD}"),
    )
    .unwrap();
    let library = "newmtl glass\nd 0.5\nmap_Kd -s 2 2 1 tex/diffuse.png\nbump tex/n.png\nmap_Ks tex/diffuse.png\n";
    std::fs::write(input.join("a.mtl"), library).unwrap();
    std::fs::write(input.join("tex/diffuse.png"), [1u8, 2, 3]).unwrap();
    std::fs::write(input.join("tex/n.png"), [4u8]).unwrap();

    let copies = convert(
        &input.join("a.obj"),
        &out.join("a.obj"),
        &ReadOptions::default(),
    );
    assert_eq!(
        copies.copied,
        [
            out.join("a.mtl"),
            out.join("tex/diffuse.png"),
            out.join("tex/n.png")
        ]
    );
    assert!(copies.missing.is_empty() && copies.outside.is_empty() && copies.refused.is_empty());
    assert_eq!(std::fs::read_to_string(out.join("a.mtl")).unwrap(), library);
    assert_eq!(
        std::fs::read(out.join("tex/diffuse.png")).unwrap(),
        [1, 2, 3]
    );
    // The output, read where it is, still finds its material: the glass is cut-out.
    let back = rtmesh::io::read(&out.join("a.obj")).unwrap();
    let glass = back.materials.iter().find(|m| m.name == "glass").unwrap();
    assert!(glass.alpha_tested);

    // Again: the same bytes are there, so nothing is in the way.
    let again = convert(
        &input.join("a.obj"),
        &out.join("a.obj"),
        &ReadOptions::default(),
    );
    assert_eq!(again, copies);
    // A different file in the way is an error, and it is left as it was.
    std::fs::write(out.join("tex/n.png"), "mine").unwrap();
    let scene = rtmesh::io::read(&input.join("a.obj")).unwrap();
    let error = copy_side_files(
        &input.join("a.obj"),
        &scene,
        &out.join("a.obj"),
        &Default::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(error.contains("n.png: exists and differs"), "{error}");
    assert_eq!(
        std::fs::read_to_string(out.join("tex/n.png")).unwrap(),
        "mine"
    );
}

#[test]
fn nothing_is_copied_into_the_input_folder_or_for_a_format_without_the_reference() {
    let (input, out) = sandbox("same");
    std::fs::write(input.join("a.obj"), format!("mtllib a.mtl\n{QUAD}")).unwrap();
    std::fs::write(input.join("a.mtl"), "newmtl glass\n").unwrap();
    let same = convert(
        &input.join("a.obj"),
        &input.join("b.obj"),
        &ReadOptions::default(),
    );
    assert_eq!(same, SideFiles::default());
    // A glTF written from an OBJ has materials of its own, no `mtllib`.
    let gltf = convert(
        &input.join("a.obj"),
        &out.join("a.glb"),
        &ReadOptions::default(),
    );
    assert_eq!(gltf, SideFiles::default());
    assert!(!out.join("a.mtl").exists());
}

#[test]
fn a_gltf_written_elsewhere_keeps_its_image_files_and_crafted_uris_copy_nothing() {
    let (input, out) = sandbox("gltf");
    // One triangle in a data: buffer, five images: a %-escaped name, the same file
    // again, a data: image, a missing file, two that break the rule.
    let buffer =
        "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA";
    let document = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"uri":"{buffer}","byteLength":36}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
        "images":[{{"uri":"tex/base%20colour.png"}},{{"uri":"tex/base colour.png"}},
                  {{"uri":"data:image/png;base64,AAAA"}},{{"uri":"tex/gone.png"}},
                  {{"uri":"../canary.png"}},{{"uri":"/etc/passwd"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#
    );
    std::fs::write(input.join("a.gltf"), document).unwrap();
    std::fs::write(input.join("tex/base colour.png"), [9u8; 5]).unwrap();

    // What `info` reports of the input: one file there (named twice), one missing, two
    // refused.
    let scene = rtmesh::io::read(&input.join("a.gltf")).unwrap();
    let check = rtmesh::io::check_side_files(&input.join("a.gltf"), &scene, &Default::default());
    let real = input.join("tex/base colour.png").canonicalize().unwrap();
    assert_eq!(check.present, [real]);
    assert_eq!(check.missing, ["tex/gone.png"]);
    assert_eq!(check.refused.len(), 2);

    let copies = convert(
        &input.join("a.gltf"),
        &out.join("a.glb"),
        &ReadOptions::default(),
    );
    assert_eq!(copies.copied, [out.join("tex/base colour.png")]);
    assert_eq!(
        std::fs::read(out.join("tex/base colour.png")).unwrap(),
        [9; 5]
    );
    assert_eq!(copies.missing, ["tex/gone.png"]);
    assert_eq!(copies.refused.len(), 2, "{:?}", copies.refused);
    assert!(
        copies.refused[0].contains("'../canary.png'"),
        "{:?}",
        copies.refused
    );
    let parent = out.parent().unwrap();
    let files: Vec<_> = std::fs::read_dir(parent)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(files.len(), 3, "only in/, out/ and the canary: {files:?}");
    assert!(!out.join("canary.png").exists() && !out.join("etc").exists());
}

#[test]
fn a_library_above_the_input_folder_is_reported_not_copied_out_of_the_output_folder() {
    let (input, out) = sandbox("root");
    let root = input.parent().unwrap().to_owned();
    std::fs::create_dir_all(input.join("obj")).unwrap();
    std::fs::write(input.join("obj/a.obj"), format!("mtllib ../a.mtl\n{QUAD}")).unwrap();
    std::fs::write(input.join("a.mtl"), "newmtl glass\nmap_Kd tex/d.png\n").unwrap();
    std::fs::create_dir_all(out.join("obj")).unwrap();
    let options = ReadOptions {
        asset_root: Some(root.clone()),
    };
    let copies = convert(&input.join("obj/a.obj"), &out.join("obj/a.obj"), &options);
    assert!(copies.copied.is_empty());
    assert_eq!(copies.outside, ["../a.mtl", "tex/d.png"]);
    assert!(!out.join("a.mtl").exists());
}

/// The glTF document of a .gltf file.
/// The first geometry's texture coordinates, corner by corner.
fn corner_uvs(scene: &rtmesh::Scene) -> Vec<[f32; 2]> {
    let mesh = &scene.meshes[0];
    let stream = mesh
        .attributes
        .iter()
        .find(|a| a.name == "TEXCOORD_0")
        .unwrap();
    let rtmesh::mesh::AttributeValues::F32(values) = &stream.values else {
        panic!("float coordinates")
    };
    let corners = mesh.triangles.iter().flatten();
    corners
        .map(|&v| [values[2 * v as usize], values[2 * v as usize + 1]])
        .collect()
}

fn document(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn an_obj_written_as_gltf_keeps_its_mtl_colours_and_textures() {
    let (input, out) = sandbox("obj-to-gltf");
    std::fs::create_dir_all(input.join("mat/tex")).unwrap();
    let obj =
        "mtllib mat/a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\n\
               usemtl painted\nf 1/1 2/2 3/3\nusemtl glass\nf 2/2 4/4 3/3\n";
    std::fs::write(input.join("a.obj"), obj).unwrap();
    // The library is in a subfolder and names its textures relative to itself.
    let library = "newmtl painted\nKd 1 0 0\nmap_Kd -s 1 1 1 tex/paint.png\nbump tex/n.png\n\
                   newmtl glass\nKd 0.25 0.5 0.75\nd 0.5\nKe 0.125 0 0\n";
    std::fs::write(input.join("mat/a.mtl"), library).unwrap();
    std::fs::write(input.join("mat/tex/paint.png"), [1u8]).unwrap();
    std::fs::write(input.join("mat/tex/n.png"), [2u8]).unwrap();

    let copies = convert(
        &input.join("a.obj"),
        &out.join("a.gltf"),
        &ReadOptions::default(),
    );
    assert_eq!(
        copies.copied,
        [out.join("mat/tex/paint.png"), out.join("mat/tex/n.png")]
    );
    let gltf = document(&out.join("a.gltf"));
    let flip =
        serde_json::json!({"KHR_texture_transform": {"offset": [0.0, 1.0], "scale": [1.0, -1.0]}});
    assert_eq!(
        gltf["extensionsUsed"],
        serde_json::json!(["KHR_texture_transform"])
    );
    assert_eq!(
        gltf["images"],
        serde_json::json!([{"uri": "mat/tex/paint.png"}, {"uri": "mat/tex/n.png"}])
    );
    let painted = &gltf["materials"][0];
    assert_eq!(painted["name"], "painted");
    assert_eq!(painted["alphaMode"], "OPAQUE");
    let pbr = &painted["pbrMetallicRoughness"];
    // Under a map_Kd the texture holds the colour; the surface is a rough dielectric.
    assert_eq!(
        pbr["baseColorFactor"],
        serde_json::json!([1.0, 1.0, 1.0, 1.0])
    );
    assert_eq!(pbr["metallicFactor"], 0.0);
    assert_eq!(pbr["roughnessFactor"], 1.0);
    let base = &gltf["textures"][pbr["baseColorTexture"]["index"].as_u64().unwrap() as usize];
    assert_eq!(base["source"], 0);
    assert_eq!(pbr["baseColorTexture"]["extensions"], flip);
    assert_eq!(painted["normalTexture"]["index"], 1);
    assert_eq!(painted["normalTexture"]["extensions"], flip);
    let glass = &gltf["materials"][1];
    assert_eq!(glass["alphaMode"], "BLEND");
    assert_eq!(
        glass["pbrMetallicRoughness"]["baseColorFactor"],
        serde_json::json!([0.25, 0.5, 0.75, 0.5])
    );
    assert_eq!(
        glass["emissiveFactor"],
        serde_json::json!([0.125, 0.0, 0.0])
    );
    assert!(glass["pbrMetallicRoughness"]
        .get("baseColorTexture")
        .is_none());
    // The coordinates themselves are written as read: the texture takes the flip.
    let back = rtmesh::io::read(&out.join("a.gltf")).unwrap();
    let before = rtmesh::io::read(&input.join("a.obj")).unwrap();
    assert_eq!(corner_uvs(&back), corner_uvs(&before));
}

/// A hand-made glTF: a quad of two primitives on one buffer file, an image stored in
/// the buffer and one stored as a file, two materials between them.
fn gltf_with_materials(input: &Path) {
    let mut bin = Vec::new();
    for p in [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ] {
        bin.extend(p.iter().flat_map(|x| x.to_le_bytes()));
    }
    for uv in [[0.25f32, 0.5], [1.0, 0.125], [0.0, 1.0], [0.75, 0.375]] {
        bin.extend(uv.iter().flat_map(|x| x.to_le_bytes()));
    }
    for i in [0u16, 1, 2, 1, 3, 2] {
        bin.extend(i.to_le_bytes());
    }
    bin.extend(PNG);
    std::fs::write(input.join("a.bin"), &bin).unwrap();
    std::fs::write(input.join("tex/n.png"), [7u8]).unwrap();
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_texture_transform", "KHR_materials_emissive_strength"],
        "buffers": [{"uri": "a.bin", "byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 32},
            {"buffer": 0, "byteOffset": 80, "byteLength": 12},
            {"buffer": 0, "byteOffset": 92, "byteLength": 8}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 3, "type": "SCALAR"},
            {"bufferView": 2, "byteOffset": 6, "componentType": 5123, "count": 3, "type": "SCALAR"}
        ],
        "images": [{"bufferView": 3, "mimeType": "image/png"}, {"uri": "tex/n.png"}],
        "textures": [{"source": 0}, {"source": 1}],
        "materials": [
            {"name": "painted metal", "alphaMode": "MASK", "alphaCutoff": 0.25,
             "pbrMetallicRoughness": {
                "baseColorFactor": [1, 1, 1, 0.5],
                "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform":
                    {"offset": [0.5, 0.25], "scale": [2, 4]}}},
                "metallicFactor": 0.75, "roughnessFactor": 0.25,
                "metallicRoughnessTexture": {"index": 1}},
             "normalTexture": {"index": 1, "scale": 0.5},
             "occlusionTexture": {"index": 1},
             "emissiveFactor": [0.5, 0, 0],
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2}}},
            {"alphaMode": "BLEND", "pbrMetallicRoughness": {"baseColorFactor": [0.25, 0.5, 0.75, 0.5]}}
        ],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0},
            {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 3, "material": 1}
        ]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    std::fs::write(input.join("a.gltf"), gltf.to_string()).unwrap();
}

const PNG: [u8; 8] = [137, 80, 78, 71, 13, 10, 26, 10];

#[test]
fn a_gltf_written_as_obj_gets_its_materials_as_an_mtl_library() {
    let (input, out) = sandbox("gltf-to-obj");
    gltf_with_materials(&input);
    let options = ReadOptions::default();
    let scene = rtmesh::io::read_with(&input.join("a.gltf"), &options, &mut |_, _| {}).unwrap();
    let copies = copy_side_files(&input.join("a.gltf"), &scene, &out.join("a.obj"), &options);
    assert_eq!(copies.unwrap().copied, [out.join("tex/n.png")]);
    let notes = rtmesh::io::write(&scene, &out.join("a.obj")).unwrap();
    assert_eq!(
        notes.written_beside,
        [out.join("a.mtl"), out.join("a_image0.png")]
    );
    assert_eq!(
        notes.not_held,
        [
            "material 'painted_metal': its occlusion texture",
            "material 'painted_metal': its alphaCutoff"
        ]
    );
    // glTF's (offset, scale) (0.5, 0.25), (2, 4) from the top-left corner is MTL's
    // uv·(2, −4) + (0.5, 0.75) from the bottom-left; untransformed maps take the flip.
    let flip = "-s 1 -1 1 -o 0 1 0";
    let expected = format!(
        "# written by rtmesh {} from a glTF document's materials\n\n\
         newmtl painted_metal\nKd 1 1 1\nd 0.5\nPm 0.75\nPr 0.25\nKe 1 0 0\n\
         map_Kd -s 2 -4 1 -o 0.5 0.75 0 a_image0.png\n\
         map_d -s 2 -4 1 -o 0.5 0.75 0 a_image0.png\n\
         map_Pm -imfchan b {flip} tex/n.png\nmap_Pr -imfchan g {flip} tex/n.png\n\
         norm -bm 0.5 {flip} tex/n.png\n\n\
         newmtl material1\nKd 0.25 0.5 0.75\nd 0.5\nPm 1\nPr 1\n\n\
         newmtl material2\nKd 1 1 1\nd 1\nPm 1\nPr 1\n",
        env!("CARGO_PKG_VERSION")
    );
    assert_eq!(
        std::fs::read_to_string(out.join("a.mtl")).unwrap(),
        expected
    );
    assert_eq!(std::fs::read(out.join("a_image0.png")).unwrap(), PNG);
    let obj = std::fs::read_to_string(out.join("a.obj")).unwrap();
    assert!(obj.contains("mtllib a.mtl\n"));
    assert_eq!(
        obj.lines()
            .filter(|l| l.starts_with("usemtl"))
            .collect::<Vec<_>>(),
        ["usemtl painted_metal", "usemtl material1"]
    );

    // Back to glTF: the same look, and each corner samples the same place of the image
    // (the same coordinates under the same transform).
    let back = rtmesh::io::read(&out.join("a.obj")).unwrap();
    assert_eq!(corner_uvs(&back), corner_uvs(&scene));
    assert_eq!(
        back.materials
            .iter()
            .map(|m| m.alpha_tested)
            .collect::<Vec<_>>(),
        [true, true, false]
    );
    rtmesh::io::write(&back, &out.join("b.gltf")).unwrap();
    let gltf = document(&out.join("b.gltf"));
    let painted = &gltf["materials"][0];
    let pbr = &painted["pbrMetallicRoughness"];
    assert_eq!(
        pbr["baseColorTexture"]["extensions"],
        serde_json::json!({"KHR_texture_transform": {"offset": [0.5, 0.25], "scale": [2.0, 4.0]}})
    );
    assert!(pbr["metallicRoughnessTexture"].get("extensions").is_none());
    assert_eq!(pbr["metallicFactor"], 0.75);
    assert_eq!(pbr["roughnessFactor"], 0.25);
    assert_eq!(
        painted["emissiveFactor"],
        serde_json::json!([1.0, 0.0, 0.0])
    );
    assert_eq!(painted["alphaMode"], "MASK");
    let image = |info: &serde_json::Value| {
        let texture = info["index"].as_u64().unwrap() as usize;
        let source = gltf["textures"][texture]["source"].as_u64().unwrap() as usize;
        gltf["images"][source]["uri"].clone()
    };
    assert_eq!(image(&pbr["baseColorTexture"]), "a_image0.png");
    assert_eq!(image(&painted["normalTexture"]), "tex/n.png");
    assert_eq!(
        gltf["materials"][1]["pbrMetallicRoughness"]["baseColorFactor"],
        serde_json::json!([0.25, 0.5, 0.75, 0.5])
    );
}

#[test]
fn a_different_library_in_the_way_stops_the_obj_before_it_is_written() {
    let (input, out) = sandbox("gltf-to-obj-in-the-way");
    gltf_with_materials(&input);
    std::fs::write(out.join("a.mtl"), "newmtl mine\n").unwrap();
    let scene = rtmesh::io::read(&input.join("a.gltf")).unwrap();
    let error = rtmesh::io::write(&scene, &out.join("a.obj")).unwrap_err();
    assert!(error.to_string().contains("exists and differs"), "{error}");
    assert_eq!(
        std::fs::read_to_string(out.join("a.mtl")).unwrap(),
        "newmtl mine\n"
    );
    assert!(!out.join("a.obj").exists() && !out.join("a_image0.png").exists());
}

#[test]
fn what_a_format_cannot_hold_is_named() {
    let (input, out) = sandbox("not-held");
    gltf_with_materials(&input);
    let scene = rtmesh::io::read(&input.join("a.gltf")).unwrap();
    let not_held = |file: &str| rtmesh::io::write(&scene, &out.join(file)).unwrap().not_held;
    assert_eq!(
        not_held("a.stl"),
        [
            "vertex attributes TEXCOORD_0",
            "materials: 2 (the format holds none)"
        ]
    );
    assert_eq!(not_held("a.ply"), ["materials: 2 (the format holds none)"]);
    assert!(not_held("a.glb").is_empty());
    // One unnamed node at the identity loses nothing in OBJ; a name or a transform does.
    let nodes = |notes: &[String]| notes.iter().filter(|n| n.starts_with("nodes")).count();
    assert_eq!(nodes(&not_held("a.obj")), 0);
    let gltf = std::fs::read_to_string(input.join("a.gltf")).unwrap();
    let named = gltf.replace(r#"{"mesh":0}"#, r#"{"mesh":0,"name":"lid"}"#);
    assert_ne!(named, gltf);
    std::fs::write(input.join("a.gltf"), named).unwrap();
    let scene = rtmesh::io::read(&input.join("a.gltf")).unwrap();
    let notes = rtmesh::io::write(&scene, &out.join("b.obj"))
        .unwrap()
        .not_held;
    assert_eq!(nodes(&notes), 1);
    assert!(notes.contains(
        &"nodes: 1 (their tree, names and transforms; the geometry is written in world space)"
            .to_owned()
    ));
}

#[test]
fn a_one_mesh_format_names_the_geometries_it_merges() {
    let (input, out) = sandbox("not-held-geometries");
    let two_groups = "v 0 0 0\nv 1 0 0\nv 0 1 0\ng lid\nf 1 2 3\ng base\nf 1 3 2\n";
    std::fs::write(input.join("a.obj"), two_groups).unwrap();
    let scene = rtmesh::io::read(&input.join("a.obj")).unwrap();
    assert_eq!(scene.instances.len(), 2);
    let merged = ["geometries: 2 (merged into one mesh, their names with them)"];
    for file in ["a.ply", "a.stl"] {
        assert_eq!(
            rtmesh::io::write(&scene, &out.join(file)).unwrap().not_held,
            merged
        );
    }
    assert!(rtmesh::io::write(&scene, &out.join("a.obj"))
        .unwrap()
        .not_held
        .is_empty());
}

#[test]
fn a_glb_from_an_obj_stores_its_png_and_jpeg_textures_and_copies_the_rest() {
    let (input, out) = sandbox("obj-to-glb");
    std::fs::write(input.join("a.obj"), format!("mtllib a.mtl\nvt 0 0\n{QUAD}")).unwrap();
    let library = "newmtl glass\nmap_Kd tex/d.png\nnorm tex/n.jpg\nmap_Ke tex/e.webp\n";
    std::fs::write(input.join("a.mtl"), library).unwrap();
    let jpeg = [0xffu8, 0xd8, 0xff, 0xe0, 1, 2];
    std::fs::write(input.join("tex/d.png"), PNG).unwrap();
    std::fs::write(input.join("tex/n.jpg"), jpeg).unwrap();
    std::fs::write(input.join("tex/e.webp"), b"RIFF....WEBP").unwrap();
    for (output, copied) in [
        (out.join("a.glb"), vec![out.join("tex/e.webp")]),
        // In the input's folder nothing is copied, and the images are still stored.
        (input.join("b.glb"), vec![]),
    ] {
        let options = ReadOptions::default();
        let scene = rtmesh::io::read_with(&input.join("a.obj"), &options, &mut |_, _| {}).unwrap();
        let copies = copy_side_files(&input.join("a.obj"), &scene, &output, &options).unwrap();
        assert_eq!(copies.copied, copied);
        assert_eq!(
            copies.embedded,
            [input.join("tex/d.png"), input.join("tex/n.jpg")]
        );
        let options = rtmesh::io::WriteOptions {
            images: &copies.images,
            ..Default::default()
        };
        rtmesh::io::write_with(&scene, &output, options).unwrap();
        let gltf = gltf::Gltf::open(&output).unwrap();
        let blob = gltf.blob.clone().unwrap();
        let stored: Vec<(Option<String>, Option<Vec<u8>>)> = gltf
            .images()
            .map(|image| match image.source() {
                gltf::image::Source::View { view, mime_type } => {
                    let bytes = &blob[view.offset()..view.offset() + view.length()];
                    (Some(mime_type.to_owned()), Some(bytes.to_vec()))
                }
                gltf::image::Source::Uri { uri, .. } => (Some(uri.to_owned()), None),
            })
            .collect();
        assert_eq!(
            stored,
            [
                (Some("image/png".to_owned()), Some(PNG.to_vec())),
                (Some("image/jpeg".to_owned()), Some(jpeg.to_vec())),
                (Some("tex/e.webp".to_owned()), None),
            ]
        );
    }
}

#[test]
fn a_texture_file_name_with_spaces_is_copied_whole() {
    let (input, out) = sandbox("spaces");
    std::fs::write(input.join("a.obj"), format!("mtllib a.mtl\n{QUAD}")).unwrap();
    let library = "newmtl glass\nmap_Kd -s 1 1 1 tex/my texture.png\n";
    std::fs::write(input.join("a.mtl"), library).unwrap();
    std::fs::write(input.join("tex/my texture.png"), PNG).unwrap();
    let copies = convert(
        &input.join("a.obj"),
        &out.join("a.obj"),
        &ReadOptions::default(),
    );
    assert_eq!(
        copies.copied,
        [out.join("a.mtl"), out.join("tex/my texture.png")]
    );
    assert!(copies.missing.is_empty(), "{copies:?}");
}

#[test]
fn a_glb_from_a_gltf_stores_its_image_files() {
    let (input, out) = sandbox("gltf-to-glb");
    gltf_with_materials(&input);
    std::fs::write(input.join("tex/n.png"), PNG).unwrap();
    let options = ReadOptions::default();
    let scene = rtmesh::io::read_with(&input.join("a.gltf"), &options, &mut |_, _| {}).unwrap();
    let copies = copy_side_files(&input.join("a.gltf"), &scene, &out.join("a.glb"), &options);
    let copies = copies.unwrap();
    assert!(copies.copied.is_empty(), "{copies:?}");
    assert_eq!(copies.embedded, [input.join("tex/n.png")]);
    let options = rtmesh::io::WriteOptions {
        images: &copies.images,
        ..Default::default()
    };
    rtmesh::io::write_with(&scene, &out.join("a.glb"), options).unwrap();
    let gltf = gltf::Gltf::open(out.join("a.glb")).unwrap();
    let blob = gltf.blob.clone().unwrap();
    for image in gltf.images() {
        let gltf::image::Source::View { view, mime_type } = image.source() else {
            panic!("image {} is not stored", image.index())
        };
        assert_eq!(mime_type, "image/png");
        assert_eq!(&blob[view.offset()..view.offset() + view.length()], PNG);
    }
    assert_eq!(gltf.images().count(), 2);
}

#[test]
fn what_a_reader_leaves_unread_is_named_for_every_output() {
    let (input, out) = sandbox("not-read");
    let lines = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nl 1 2 3\nl 2 3\np 1\n";
    std::fs::write(input.join("a.obj"), lines).unwrap();
    let scene = rtmesh::io::read(&input.join("a.obj")).unwrap();
    for file in ["b.obj", "b.ply", "b.stl", "b.glb"] {
        assert_eq!(
            rtmesh::io::write(&scene, &out.join(file)).unwrap().not_read,
            [
                "OBJ line (`l`) statements: 2 (not triangles)",
                "OBJ point (`p`) statements: 1 (not triangles)"
            ],
            "{file}"
        );
    }
    // A glTF's primitives of lines and points are kept in glTF and named elsewhere.
    rtmesh::io::write(&scene, &out.join("c.gltf")).unwrap();
    let text = std::fs::read_to_string(out.join("c.gltf")).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let primitives = json["meshes"][0]["primitives"].as_array_mut().unwrap();
    let mut points = primitives[0].clone();
    points["mode"] = 0.into();
    points.as_object_mut().unwrap().remove("indices");
    primitives.push(points);
    std::fs::write(out.join("c.gltf"), json.to_string()).unwrap();
    let document = rtmesh::io::read(&out.join("c.gltf")).unwrap();
    assert_eq!(document.meshes[0].triangle_count(), 1);
    let notes = rtmesh::io::write(&document, &out.join("d.gltf")).unwrap();
    assert!(notes.not_held.is_empty(), "{:?}", notes.not_held);
    let text = std::fs::read_to_string(out.join("d.gltf")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let modes: Vec<i64> = (json["meshes"][0]["primitives"].as_array().unwrap().iter())
        .map(|p| p["mode"].as_i64().unwrap_or(4))
        .collect();
    assert_eq!(modes, [4, 0]);
    let notes = rtmesh::io::write(&document, &out.join("c.ply")).unwrap();
    assert!(
        notes
            .not_held
            .contains(&"primitives of lines or points: 1".to_owned()),
        "{:?}",
        notes.not_held
    );
}

/// A MeshLab PLY: two textures named by `comment TextureFile`, faces choosing one by
/// `texnumber` (the last names none), and texture coordinates per corner, which differ
/// across the diagonal the two triangles of the quad share (a seam).
const MESHLAB_PLY: &str = "ply\nformat ascii 1.0\ncomment VCGLIB generated\n\
comment TextureFile tex/a.png\ncomment TextureFile b.png\nelement vertex 5\n\
property float x\nproperty float y\nproperty float z\nelement face 3\n\
property list uchar int vertex_indices\nproperty list uchar float texcoord\nproperty int texnumber\nend_header\n\
0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0 0\n\
3 0 1 2 6 0 0 1 0 1 1 0\n3 0 2 3 6 0.5 0.5 0.25 0.25 0 1 1\n3 1 4 2 6 1 0 2 0 1 1 7\n";

#[test]
fn a_meshlab_ply_keeps_its_textures_in_every_format() {
    let (input, out) = sandbox("meshlab");
    std::fs::write(input.join("scan.ply"), MESHLAB_PLY).unwrap();
    std::fs::write(input.join("tex/a.png"), PNG).unwrap();
    std::fs::write(input.join("b.png"), PNG).unwrap();
    let scene = rtmesh::io::read(&input.join("scan.ply")).unwrap();
    // Vertices 0 and 2 are copied for the second triangle's other coordinates.
    assert_eq!(scene.meshes[0].positions.len(), 7);
    let uvs = corner_uvs(&scene);
    assert_eq!(
        uvs,
        [
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.5, 0.5],
            [0.25, 0.25],
            [0.0, 1.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [1.0, 1.0]
        ]
    );
    let maps: Vec<Option<&str>> = (scene.materials.iter())
        .map(|m| Some(m.mtl.as_ref()?.diffuse_map.as_ref()?.file.as_str()))
        .collect();
    assert_eq!(maps, [Some("tex/a.png"), Some("b.png"), None]);
    assert_eq!(scene.meshes[0].material_ids, [0, 1, 2]);
    let options = ReadOptions::default();
    // PLY to PLY elsewhere: the comments, the numbers and the textures come along.
    let copies = convert(&input.join("scan.ply"), &out.join("scan.ply"), &options);
    assert_eq!(copies.copied, [out.join("tex/a.png"), out.join("b.png")]);
    let again = rtmesh::io::read(&out.join("scan.ply")).unwrap();
    assert_eq!(corner_uvs(&again), uvs);
    assert_eq!(again.materials, scene.materials);
    assert_eq!(again.meshes[0].material_ids, [0, 1, 2]);
    // To OBJ: an MTL library of the two maps, read back to the same corners and maps.
    convert(&input.join("scan.ply"), &out.join("scan.obj"), &options);
    let library = std::fs::read_to_string(out.join("scan.mtl")).unwrap();
    assert!(
        library.contains("newmtl a\n") && library.contains("map_Kd -s 1 1 1 -o 0 0 0 tex/a.png\n"),
        "{library}"
    );
    let obj = rtmesh::io::read(&out.join("scan.obj")).unwrap();
    assert_eq!(corner_uvs(&obj), uvs);
    let obj_maps: Vec<Option<&str>> = (obj.materials.iter())
        .map(|m| Some(m.mtl.as_ref()?.diffuse_map.as_ref()?.file.as_str()))
        .collect();
    assert_eq!(obj_maps, maps);
    // To GLB: both images stored in it.
    let copies = copy_side_files(
        &input.join("scan.ply"),
        &scene,
        &out.join("scan.glb"),
        &options,
    )
    .unwrap();
    assert_eq!(copies.embedded.len(), 2);
    // A face whose coordinates are not two a corner is an error naming it.
    let bad = MESHLAB_PLY.replace("6 1 0 2 0 1 1 7", "5 1 0 2 0 1 7");
    std::fs::write(input.join("bad.ply"), bad).unwrap();
    let error = rtmesh::io::read(&input.join("bad.ply"))
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("bad.ply")
            && error.contains("face 2 has 3 vertices but 5 numbers in 'texcoord'"),
        "{error}"
    );
}

#[test]
fn nodes_of_scenes_not_traced_keep_their_meshes() {
    let (input, out) = sandbox("scenes");
    let mut bin = Vec::new();
    for x in [
        0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 5.0, 0.0, 0.0, 6.0, 0.0, 0.0, 5.0, 1.0, 0.0,
    ] {
        bin.extend(x.to_le_bytes());
    }
    std::fs::write(input.join("s.bin"), &bin).unwrap();
    let accessor = |view: u32, x: f32| {
        serde_json::json!({"bufferView": view, "componentType": 5126, "count": 3, "type": "VEC3",
            "min": [x, 0, 0], "max": [x + 1.0, 1, 0]})
    };
    // Scene 0 places mesh 0; scene 1 places mesh 1 by node 1; node 2 is in no scene.
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"}, "scene": 0,
        "scenes": [{"nodes": [0]}, {"nodes": [1]}],
        "nodes": [{"mesh": 0, "name": "a"}, {"mesh": 1, "name": "b"}, {"mesh": 1, "name": "spare"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}, {"primitives": [{"attributes": {"POSITION": 1}}]}],
        "buffers": [{"uri": "s.bin", "byteLength": bin.len()}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 36}],
        "accessors": [accessor(0, 0.0), accessor(1, 5.0)],
    });
    std::fs::write(input.join("s.gltf"), gltf.to_string()).unwrap();
    let scene = rtmesh::io::read(&input.join("s.gltf")).unwrap();
    assert_eq!(scene.instances.len(), 1, "only the default scene is traced");
    let options = rtmesh::optimize::OptimizeOptions {
        measure: None,
        ..Default::default()
    };
    let optimized = rtmesh::optimize::optimize_mapped(&scene, &options, &())
        .unwrap()
        .scene;
    for (name, written) in [("convert.gltf", &scene), ("optimize.gltf", &optimized)] {
        rtmesh::io::write(written, &out.join(name)).unwrap();
        let text = std::fs::read_to_string(out.join(name)).unwrap();
        let json: serde_json::Value = serde_json::from_str(&text).unwrap();
        let nodes = json["nodes"].as_array().unwrap();
        // Each node places a mesh whose positions start where its source mesh's did.
        for (n, x) in [(0, 0.0), (1, 5.0), (2, 5.0)] {
            let mesh = nodes[n]["mesh"]
                .as_u64()
                .unwrap_or_else(|| panic!("{name}: node {n} lost its mesh"));
            let position = json["meshes"][mesh as usize]["primitives"][0]["attributes"]["POSITION"]
                .as_u64()
                .unwrap();
            assert_eq!(
                json["accessors"][position as usize]["min"][0].as_f64(),
                Some(x),
                "{name}: node {n}"
            );
        }
    }
    let notes = rtmesh::io::write(&scene, &out.join("flat.obj")).unwrap();
    assert!(
        notes.not_held.contains(
            &"scenes: 2 (the default one is written; the others' geometry is not)".to_owned()
        ),
        "{:?}",
        notes.not_held
    );
}

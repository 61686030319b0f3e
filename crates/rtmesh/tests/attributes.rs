//! Nothing lost: through the map from output to input triangles, every output corner
//! has the position and attribute values of its input corner, bit for bit, after
//! `convert` (write and read back), pairing, repair, and the glTF document's other
//! parts come out equal; every output triangle has its input triangle's own attribute
//! values (a PLY face's properties). Real files from `RTMESH_DATA` (skipped without it, unless
//! `RTMESH_REQUIRE_DATA=1`), hand-built meshes, and property-test meshes.

use glam::Vec3;
use proptest::prelude::*;
use rtmesh::data::mesh_data_dir;
use rtmesh::io::{read, write, Document};
use rtmesh::mesh::VertexAttribute;
use rtmesh::pair::{pair_scene_mapped, PairSettings};
use rtmesh::repair::{repair, RepairSettings};
use rtmesh::{Scene, TriMesh};
use std::path::Path;

/// A corner as bits: the position, then every attribute's values by name.
type Corner = ([u32; 3], Vec<(String, Vec<u64>)>);

fn corner(mesh: &TriMesh, v: u32) -> Corner {
    let p = mesh.positions[v as usize];
    let mut attributes: Vec<(String, Vec<u64>)> = mesh
        .attributes
        .iter()
        .map(|a| {
            let values = a.vertex(v as usize).iter().map(|x| x.to_bits()).collect();
            (a.name.clone(), values)
        })
        .collect();
    attributes.sort();
    (p.to_array().map(f32::to_bits), attributes)
}

/// Triangle `t`'s own attribute values as bits, by name (each stream holding one
/// value per triangle).
fn triangle_values(mesh: &TriMesh, t: usize) -> Vec<(String, Vec<u64>)> {
    for a in &mesh.triangle_attributes {
        assert_eq!(
            a.vertex_count(),
            mesh.triangle_count(),
            "{}'s values",
            a.name
        );
    }
    let mut values: Vec<(String, Vec<u64>)> = (mesh.triangle_attributes.iter())
        .map(|a| {
            (
                a.name.clone(),
                a.vertex(t).iter().map(|x| x.to_bits()).collect(),
            )
        })
        .collect();
    values.sort();
    values
}

/// Triangle `t` of `out` has the corners of triangle `u` of `input`, in the same
/// winding (possibly rotated, as pairing does), and its own attribute values.
fn same_corners(out: &TriMesh, t: usize, input: &TriMesh, u: usize) -> bool {
    let o = out.triangles[t].map(|v| corner(out, v));
    let i = input.triangles[u].map(|v| corner(input, v));
    triangle_values(out, t) == triangle_values(input, u)
        && (0..3).any(|r| (0..3).all(|k| o[k] == i[(k + r) % 3]))
}

/// The triangles of `out` (flattened) are those of `input` (flattened), corner for
/// corner, each once: in the same order for OBJ and PLY; glTF groups each primitive's
/// triangles, so there the lists are compared sorted (each triangle rotated to start
/// at its least corner, winding kept).
fn assert_same_flat(out: &Scene, input: &Scene, what: &str) {
    let (o, i) = (out.flatten().unwrap(), input.flatten().unwrap());
    assert_eq!(o.triangle_count(), i.triangle_count(), "{what}: triangles");
    let mut names: Vec<&str> = o.attributes.iter().map(|a| a.name.as_str()).collect();
    let mut theirs: Vec<&str> = i.attributes.iter().map(|a| a.name.as_str()).collect();
    names.sort();
    theirs.sort();
    assert_eq!(names, theirs, "{what}: attribute names");
    let in_order = (0..o.triangle_count()).all(|t| same_corners(&o, t, &i, t));
    if in_order {
        return;
    }
    assert!(
        what.contains("gl"),
        "{what}: triangle order or corners changed"
    );
    type Canonical = ([Corner; 3], Vec<(String, Vec<u64>)>);
    let canonical = |m: &TriMesh| {
        let mut all: Vec<Canonical> = (0..m.triangle_count())
            .map(|t| {
                let c = m.triangles[t].map(|v| corner(m, v));
                let r = (0..3).min_by(|&a, &b| c[a].cmp(&c[b])).unwrap();
                let corners = [c[r].clone(), c[(r + 1) % 3].clone(), c[(r + 2) % 3].clone()];
                (corners, triangle_values(m, t))
            })
            .collect();
        all.sort();
        all
    };
    assert!(
        canonical(&o) == canonical(&i),
        "{what}: triangles whose corners differ"
    );
}

/// A fresh folder, removed when it is dropped.
fn temp_dir() -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix("rtmesh-attributes-")
        .tempdir()
        .unwrap()
}

/// Write `scene` as `name` into a fresh folder and read it back; with glTF, which asks
/// for unit normals, also `scene` with its normals as the writer normalizes them (the
/// oracle: those more than 1e-4 from unit length, renormalized).
fn written(scene: &Scene, name: &str) -> Scene {
    let dir = temp_dir();
    let path = dir.path().join(name);
    write(scene, &path).unwrap_or_else(|e| panic!("{e}"));
    read(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// `scene` as a format without values per triangle holds it: PLY alone keeps them.
fn as_format_holds(scene: &Scene, format: &str) -> Scene {
    let mut out = match format.starts_with("gl") {
        true => with_unit_normals(scene),
        false => scene.clone(),
    };
    if format != "ply" {
        for mesh in &mut out.meshes {
            mesh.triangle_attributes.clear();
        }
    }
    out
}

fn with_unit_normals(scene: &Scene) -> Scene {
    let mut out = scene.clone();
    for mesh in &mut out.meshes {
        for attribute in mesh.attributes.iter_mut().filter(|a| a.name == "NORMAL") {
            if let rtmesh::mesh::AttributeValues::F32(values) = &mut attribute.values {
                for n in values.chunks_exact_mut(3) {
                    let v = Vec3::from_slice(n);
                    if !v.is_finite() || (v.length() - 1.0).abs() > 1e-4 {
                        let fixed = Vec3::from_slice(n).try_normalize().unwrap_or(Vec3::Z);
                        n.copy_from_slice(&fixed.to_array());
                    }
                }
            }
        }
    }
    out
}

/// Pairing keeps every triangle once and every corner, in every geometry.
fn assert_pairing_keeps_corners(scene: &Scene, what: &str) -> Scene {
    let mut paired = scene.clone();
    let (_, maps) = pair_scene_mapped(&mut paired, &PairSettings::default());
    for (m, map) in maps.iter().enumerate() {
        let mut sorted = map.clone();
        sorted.sort_unstable();
        assert!(
            sorted.iter().copied().eq(0..map.len() as u32),
            "{what}: mesh {m} is a permutation"
        );
        let (out, input) = (&paired.meshes[m], &scene.meshes[m]);
        let bad = (0..map.len())
            .filter(|&t| !same_corners(out, t, input, map[t] as usize))
            .count();
        assert_eq!(
            bad, 0,
            "{what}: paired triangles of mesh {m} whose corners differ"
        );
    }
    paired
}

/// Default repair keeps every kept triangle's corners.
fn assert_repair_keeps_corners(scene: &Scene, what: &str) -> Scene {
    let (out, map, _) = repair(scene, &RepairSettings::default());
    for (g, mesh) in out.meshes.iter().enumerate() {
        for t in 0..mesh.triangle_count() {
            let input = &scene.meshes[map.input_geometry[g][t] as usize];
            assert!(
                same_corners(mesh, t, input, map.input_triangle[g][t] as usize),
                "{what}: repaired geometry {g} triangle {t}"
            );
        }
    }
    out
}

/// `optimize` (without merging, which moves positions into a shared space) keeps every
/// kept triangle's corners, copied vertices included.
fn assert_optimize_keeps_corners(scene: &Scene, what: &str) -> Scene {
    let mut options = rtmesh::optimize::OptimizeOptions {
        measure: None,
        ..Default::default()
    };
    options.repair.merge_overlapping = false;
    let out = rtmesh::optimize::optimize_mapped(scene, &options, &()).unwrap();
    for (g, mesh) in out.scene.meshes.iter().enumerate() {
        for t in 0..mesh.triangle_count() {
            let input = &scene.meshes[out.input_geometry[g][t] as usize];
            assert!(
                same_corners(mesh, t, input, out.input_triangle[g][t] as usize),
                "{what}: optimized geometry {g} triangle {t}"
            );
        }
    }
    out.scene
}

/// The whole chain on one file: convert to each format, pair, repair, optimize, and
/// the written forms of the paired, repaired and optimized scenes.
fn check_file(path: &Path, formats: &[&str]) -> Scene {
    let what = path.display().to_string();
    let scene = read(path).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        !scene.meshes.iter().all(|m| m.attributes.is_empty()),
        "{what} has attributes"
    );
    for format in formats {
        let back = written(&scene, &format!("convert.{format}"));
        let expected = as_format_holds(&scene, format);
        assert_same_flat(&back, &expected, &format!("{what} -> {format}"));
    }
    let paired = assert_pairing_keeps_corners(&scene, &what);
    let repaired = assert_repair_keeps_corners(&scene, &what);
    let optimized = assert_optimize_keeps_corners(&scene, &what);
    for format in formats {
        let unit = |s: &Scene| as_format_holds(s, format);
        let back = written(&paired, &format!("pair.{format}"));
        assert_same_flat(&back, &unit(&paired), &format!("{what} paired -> {format}"));
        let back = written(&repaired, &format!("repair.{format}"));
        assert_same_flat(
            &back,
            &unit(&repaired),
            &format!("{what} repaired -> {format}"),
        );
        let back = written(&optimized, &format!("optimize.{format}"));
        assert_same_flat(
            &back,
            &unit(&optimized),
            &format!("{what} optimized -> {format}"),
        );
    }
    scene
}

#[test]
fn spot_keeps_its_uvs() {
    let Some(dir) = mesh_data_dir() else { return };
    let scene = check_file(&dir.join("spot.obj"), &["obj", "glb", "ply"]);
    assert!(scene.meshes[0].attribute("TEXCOORD_0").is_some());
}

#[test]
fn sponza_keeps_uvs_normals_and_groups() {
    let Some(dir) = mesh_data_dir() else { return };
    let scene = check_file(&dir.join("sponza_dabrovic.obj"), &["obj", "gltf"]);
    let back = written(&scene, "groups.obj");
    let names = |s: &Scene| s.meshes.iter().map(|m| m.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(&back), names(&scene));
}

/// The JSON of `part` of a glTF document.
fn json_of<T: serde::Serialize>(part: &T) -> serde_json::Value {
    serde_json::to_value(part).unwrap()
}

/// The bytes of accessor `index`'s elements, tightly packed.
fn accessor_data(document: &rtmesh::io::GltfDocument, index: usize) -> Vec<u8> {
    let root = document.root();
    let accessor = &root.accessors[index];
    let view = &root.buffer_views[accessor.buffer_view.unwrap().value()];
    let component = match accessor.component_type.as_ref().unwrap().0 {
        gltf::json::accessor::ComponentType::I8 | gltf::json::accessor::ComponentType::U8 => 1,
        gltf::json::accessor::ComponentType::I16 | gltf::json::accessor::ComponentType::U16 => 2,
        _ => 4,
    };
    let element = component * accessor.type_.as_ref().unwrap().multiplicity();
    let stride = view.byte_stride.map_or(element, |s| s.0);
    let start = view.byte_offset.map_or(0, |o| o.0) as usize
        + accessor.byte_offset.map_or(0, |o| o.0) as usize;
    let data = &document.buffers()[view.buffer.value()];
    (0..accessor.count.0 as usize)
        .flat_map(|i| {
            data[start + i * stride..start + i * stride + element]
                .iter()
                .copied()
        })
        .collect()
}

fn document(scene: &Scene) -> &rtmesh::io::GltfDocument {
    match scene.document.as_deref() {
        Some(Document::Gltf(document)) => document,
        _ => panic!("a glTF document"),
    }
}

/// Materials, nodes, skins and animations equal, resolved through their accessors.
fn assert_document_parts_equal(out: &Scene, input: &Scene, what: &str) {
    let (a, b) = (document(out), document(input));
    let (ra, rb) = (a.root(), b.root());
    assert_eq!(
        json_of(&ra.materials),
        json_of(&rb.materials),
        "{what}: materials"
    );
    assert_eq!(json_of(&ra.nodes), json_of(&rb.nodes), "{what}: nodes");
    assert_eq!(
        json_of(&ra.textures),
        json_of(&rb.textures),
        "{what}: textures"
    );
    assert_eq!(
        json_of(&ra.samplers),
        json_of(&rb.samplers),
        "{what}: samplers"
    );
    assert_eq!(ra.skins.len(), rb.skins.len(), "{what}: skins");
    for (sa, sb) in ra.skins.iter().zip(&rb.skins) {
        assert_eq!(
            json_of(&sa.joints),
            json_of(&sb.joints),
            "{what}: skin joints"
        );
        assert_eq!(sa.skeleton, sb.skeleton, "{what}: skin skeleton");
        let matrices =
            |d, s: &gltf::json::Skin| s.inverse_bind_matrices.map(|i| accessor_data(d, i.value()));
        assert_eq!(
            matrices(a, sa),
            matrices(b, sb),
            "{what}: inverse bind matrices"
        );
    }
    assert_eq!(
        ra.animations.len(),
        rb.animations.len(),
        "{what}: animations"
    );
    for (aa, ab) in ra.animations.iter().zip(&rb.animations) {
        assert_eq!(
            json_of(&aa.channels),
            json_of(&ab.channels),
            "{what}: channels"
        );
        assert_eq!(aa.samplers.len(), ab.samplers.len());
        for (sa, sb) in aa.samplers.iter().zip(&ab.samplers) {
            assert_eq!(
                accessor_data(a, sa.input.value()),
                accessor_data(b, sb.input.value()),
                "{what}: sampler input"
            );
            assert_eq!(
                accessor_data(a, sa.output.value()),
                accessor_data(b, sb.output.value()),
                "{what}: sampler output"
            );
        }
    }
    for (ia, ib) in ra.images.iter().zip(&rb.images) {
        let bytes = |d: &rtmesh::io::GltfDocument, i: &gltf::json::Image| {
            i.buffer_view.map(|v| {
                let view = &d.root().buffer_views[v.value()];
                let start = view.byte_offset.map_or(0, |o| o.0) as usize;
                d.buffers()[view.buffer.value()][start..start + view.byte_length.0 as usize]
                    .to_vec()
            })
        };
        assert_eq!(bytes(a, ia), bytes(b, ib), "{what}: image data");
        assert_eq!(ia.uri, ib.uri, "{what}: image uri");
    }
}

#[test]
fn engine_keeps_normals_meshes_and_instances() {
    let Some(dir) = mesh_data_dir() else { return };
    let path = dir.join("2CylinderEngine.glb");
    let scene = check_file(&path, &["glb", "gltf"]);
    assert_eq!(scene.meshes.len(), 29);
    assert!(scene.meshes.iter().all(|m| m.attribute("NORMAL").is_some()));
    let back = written(&scene, "engine.glb");
    assert_document_parts_equal(&back, &scene, "2CylinderEngine");
    assert_eq!(back.instances.len(), scene.instances.len());
}

#[test]
fn skinned_models_keep_joints_weights_and_animations() {
    let Some(dir) = mesh_data_dir() else { return };
    let animated = dir.join("animated");
    let mut checked = 0;
    for entry in std::fs::read_dir(&animated).expect("animated/") {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "glb") {
            continue;
        }
        let scene = read(&path).unwrap();
        let what = path.display().to_string();
        assert!(
            scene
                .meshes
                .iter()
                .any(|m| m.attribute("JOINTS_0").is_some() && m.attribute("WEIGHTS_0").is_some()),
            "{what}: joints and weights"
        );
        // Files from other tools may carry weights that do not sum to one, which the
        // writer must normalize (counted); compare those that do.
        let dir = temp_dir();
        let out = dir.path().join("skinned.glb");
        let notes = write(&scene, &out).unwrap();
        let back = read(&out).unwrap();
        assert_document_parts_equal(&back, &scene, &what);
        if notes.weights_renormalized == 0 {
            assert_same_flat(&back, &scene, &what);
        }
        let paired = assert_pairing_keeps_corners(&scene, &what);
        let back = written(&paired, "skinned-paired.glb");
        assert_document_parts_equal(&back, &scene, &what);
        checked += 1;
    }
    assert!(checked >= 6, "{checked} skinned models");
}

/// A sliver plane with linear UVs in two charts that meet at a seam (x = 5), and a
/// normal per vertex: bisection's new vertices must lie on the charts' linear maps.
/// A linear map from positions to UVs.
type Chart = fn(Vec3) -> [f32; 2];

fn seamed_slivers() -> (TriMesh, [Chart; 2]) {
    fn left(p: Vec3) -> [f32; 2] {
        [0.1 * p.x + 0.3 * p.y, 0.7 * p.x - 0.2 * p.y]
    }
    fn right(p: Vec3) -> [f32; 2] {
        [0.5 - 0.05 * p.x, 0.25 * p.y + 0.01 * p.x]
    }
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    let mut triangles = Vec::new();
    // Each chart: a strip of quads 5 long and 0.2 high, split into slivers.
    for (chart, map) in [left as fn(Vec3) -> [f32; 2], right]
        .into_iter()
        .enumerate()
    {
        let x0 = 5.0 * chart as f32;
        let base = positions.len() as u32;
        for row in 0..=4 {
            for col in 0..=1 {
                // Sheared, so that the slivers lie diagonal and their boxes are empty.
                let x = x0 + 5.0 * col as f32;
                let p = Vec3::new(x, 0.2 * row as f32 + 0.5 * x, 0.0);
                positions.push(p);
                uvs.push(map(p));
            }
        }
        for row in 0..4u32 {
            let v = base + 2 * row;
            triangles.push([v, v + 1, v + 3]);
            triangles.push([v, v + 3, v + 2]);
        }
    }
    let mut mesh = TriMesh::new(positions, triangles);
    let normals = vec![[0.0, 0.0, 1.0]; mesh.positions.len()];
    mesh.attributes
        .push(VertexAttribute::from_f32("TEXCOORD_0", &uvs));
    mesh.attributes
        .push(VertexAttribute::from_f32("NORMAL", &normals));
    (mesh, [left, right])
}

#[test]
fn bisection_interpolates_on_each_side_of_a_seam() {
    let (mesh, maps) = seamed_slivers();
    let scene = Scene::from_mesh(mesh.clone());
    let settings = RepairSettings {
        split_elongated: true,
        force_split: true,
        ..RepairSettings::default()
    };
    let (out, map, report) = repair(&scene, &settings);
    assert!(report.split_edges > 0, "the slivers split");
    let out_mesh = &out.meshes[0];
    assert!(out_mesh.triangle_count() > mesh.triangle_count());
    let uv = out_mesh.attribute("TEXCOORD_0").unwrap();
    let normal = out_mesh.attribute("NORMAL").unwrap();
    for t in 0..out_mesh.triangle_count() {
        let chart = (map.input_triangle[0][t] as usize) / 8;
        for v in out_mesh.triangles[t] {
            let p = out_mesh.positions[v as usize];
            let expected = maps[chart](p);
            for (c, want) in expected.into_iter().enumerate() {
                let got = uv.get(v as usize, c) as f32;
                assert!(
                    (got - want).abs() < 1e-5,
                    "triangle {t} corner at {p}: uv {got} vs {want}"
                );
            }
            assert_eq!(normal.vertex(v as usize), vec![0.0, 0.0, 1.0]);
        }
    }
    // The seam's two sides kept apart: a vertex on x = 5 of each chart.
    let on_seam = (0..out_mesh.positions.len())
        .filter(|&v| out_mesh.positions[v].x == 5.0)
        .count();
    let seam_positions = {
        let mut ys: Vec<u32> = (0..out_mesh.positions.len())
            .filter(|&v| out_mesh.positions[v].x == 5.0)
            .map(|v| out_mesh.positions[v].y.to_bits())
            .collect();
        ys.sort_unstable();
        ys.dedup();
        ys.len()
    };
    assert_eq!(
        on_seam,
        2 * seam_positions,
        "each seam position twice, once per chart"
    );
    // And it survives the writers.
    for format in ["glb", "ply", "obj"] {
        let back = written(&out, &format!("split.{format}"));
        assert_same_flat(&back, &out, format);
    }
}

/// A grid with random UVs and colours, a label per triangle, and a seam: its left and
/// right halves do not share vertices along the middle column, and the two copies
/// differ in UV.
fn random_seamed_grid(n: usize, uv_seed: &[f32], colours: &[u8]) -> TriMesh {
    let side = n + 1;
    let mut positions = Vec::new();
    for y in 0..side {
        for x in 0..side {
            positions.push(Vec3::new(
                x as f32,
                y as f32,
                ((x * 7 + y * 3) % 5) as f32 * 0.1,
            ));
        }
    }
    let copies: Vec<u32> = (0..side)
        .map(|y| {
            positions.push(positions[y * side + n / 2]);
            (positions.len() - 1) as u32
        })
        .collect();
    let mut triangles = Vec::new();
    for y in 0..n {
        for x in 0..n {
            // Quads right of the middle column use its copies.
            let right = x >= n / 2;
            let at = |cx: usize, cy: usize| {
                if right && cx == n / 2 {
                    copies[cy]
                } else {
                    (cy * side + cx) as u32
                }
            };
            let (a, b, c, d) = (at(x, y), at(x + 1, y), at(x + 1, y + 1), at(x, y + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    let count = positions.len();
    let mut mesh = TriMesh::new(positions, triangles);
    let uvs: Vec<[f32; 2]> = (0..count)
        .map(|v| [uv_seed[v % uv_seed.len()], v as f32 * 0.5])
        .collect();
    mesh.attributes
        .push(VertexAttribute::from_f32("TEXCOORD_0", &uvs));
    mesh.attributes.push(VertexAttribute {
        name: "COLOR_0".into(),
        components: 4,
        normalized: true,
        values: rtmesh::mesh::AttributeValues::U8(
            (0..count * 4).map(|i| colours[i % colours.len()]).collect(),
        ),
        component_names: Vec::new(),
    });
    let triangles = mesh.triangle_count();
    mesh.triangle_attributes.push(VertexAttribute {
        name: "label".into(),
        components: 1,
        normalized: false,
        values: rtmesh::mesh::AttributeValues::U16(
            (0..triangles)
                .map(|t| colours[t % colours.len()] as u16 * 257 + t as u16)
                .collect(),
        ),
        component_names: vec!["label".into()],
    });
    mesh
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn random_meshes_keep_every_corner(
        n in 2usize..7,
        uv_seed in prop::collection::vec(-4.0f32..4.0, 1..9),
        colours in prop::collection::vec(any::<u8>(), 1..9),
    ) {
        let scene = Scene::from_mesh(random_seamed_grid(n, &uv_seed, &colours));
        for format in ["glb", "ply"] {
            let back = written(&scene, &format!("random.{format}"));
            assert_same_flat(&back, &as_format_holds(&scene, format), format);
        }
        let paired = assert_pairing_keeps_corners(&scene, "random grid");
        // Pairs cross the seam: the topology is by position.
        let topology_pairs = rtmesh::pair::pair(&scene.meshes[0].topology(), &PairSettings::default()).1.paired_triangles;
        let mut welded_only = scene.meshes[0].clone();
        welded_only.attributes.clear();
        prop_assert_eq!(topology_pairs, rtmesh::pair::pair(&welded_only.topology(), &PairSettings::default()).1.paired_triangles);
        let back = written(&paired, "random-paired.glb");
        assert_same_flat(&back, &as_format_holds(&paired, "glb"), "paired glb");
        let back = written(&paired, "random-paired.ply");
        assert_same_flat(&back, &paired, "paired ply");
        assert_repair_keeps_corners(&scene, "random grid");
    }
}

#[test]
fn morph_targets_weights_and_extras_survive_writing_and_splitting() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/morph-quad.gltf");
    let scene = read(&path).unwrap();
    let delta = scene.meshes[0]
        .attribute("target0:POSITION")
        .expect("the morph target");
    assert_eq!(delta.vertex(0), vec![0.0, 0.0, 0.5]);
    for format in ["glb", "gltf"] {
        let back = written(&scene, &format!("morph.{format}"));
        assert_same_flat(&back, &scene, format);
        assert_document_parts_equal(&back, &scene, format);
        let (a, b) = (document(&back).root(), document(&scene).root());
        assert_eq!(json_of(&a.meshes[0].weights), json_of(&b.meshes[0].weights));
        assert_eq!(json_of(&a.meshes[0].extras), json_of(&b.meshes[0].extras));
        assert_eq!(
            json_of(&a.meshes[0].primitives[0].extras),
            json_of(&b.meshes[0].primitives[0].extras)
        );
        assert_eq!(json_of(&a.asset), json_of(&b.asset));
    }
    // A split vertex's delta is the midpoint of its ends' deltas.
    let settings = RepairSettings {
        split_elongated: true,
        force_split: true,
        lint: rtmesh::lint::LintSettings {
            empty_space: 0.0,
            ..Default::default()
        },
        ..RepairSettings::default()
    };
    let (split, _, report) = repair(&scene, &settings);
    assert!(report.split_edges > 0);
    let mesh = &split.meshes[0];
    let delta = mesh.attribute("target0:POSITION").unwrap();
    let input = &scene.meshes[0];
    let input_delta = input.attribute("target0:POSITION").unwrap();
    let mut checked = 0;
    for v in input.positions.len()..mesh.positions.len() {
        let p = mesh.positions[v];
        // A vertex halfway between two input vertices has the mean of their deltas
        // (the quad's centre is halfway along both diagonals).
        let n = input.positions.len();
        let means: Vec<f64> = (0..n)
            .flat_map(|a| (a + 1..n).map(move |b| (a, b)))
            .filter(|&(a, b)| (input.positions[a] + input.positions[b]) * 0.5 == p)
            .map(|(a, b)| 0.5 * (input_delta.get(a, 2) + input_delta.get(b, 2)))
            .collect();
        if !means.is_empty() {
            let got = delta.get(v, 2);
            assert!(
                means.iter().any(|m| (got - m).abs() < 1e-6),
                "vertex {v} at {p}: {got} not in {means:?}"
            );
            checked += 1;
        }
    }
    assert!(checked > 0, "a split vertex between two input vertices");
    let back = written(&split, "morph-split.glb");
    assert_same_flat(&back, &split, "split glb");
}

#[test]
fn pairs_stay_within_one_material_and_primitive() {
    // A grid whose two triangles of a quad differ in material, and whose rows of quads
    // alternate group: the pairing the grid wants (each quad's diagonal) crosses keys.
    let mut mesh = rtmesh::scenes::quad_grid(6);
    let n = mesh.triangle_count();
    mesh.material_ids = (0..n).map(|t| (t % 2) as u32).collect();
    mesh.group_ids = (0..n).map(|t| ((t / 12) % 2) as u32).collect();
    let mut scene = Scene::from_mesh(mesh.clone());
    scene.materials.push(rtmesh::mesh::Material::default());
    let (report, maps) = pair_scene_mapped(&mut scene, &PairSettings::default());
    let key = |t: u32| (mesh.material_ids[t as usize], mesh.group_ids[t as usize]);
    for pair in maps[0][..report.paired_triangles].chunks_exact(2) {
        assert_eq!(key(pair[0]), key(pair[1]), "pair {pair:?} spans two keys");
    }
    // On the plain topology the same mesh pairs across the keys: the test can fail.
    let (free, _) = rtmesh::pair::pair(&mesh.topology(), &PairSettings::default());
    let crossing = free
        .pairs
        .iter()
        .filter(|[a, b]| key(*a) != key(*b))
        .count();
    assert!(crossing > 0, "the grid would pair across keys");
}

/// The accessor of `semantic` on mesh 0's first primitive: its component type and
/// `normalized`, and its elements' bytes.
fn primitive_accessor(scene: &Scene, semantic: &str) -> (u32, bool, Vec<u8>) {
    let document = document(scene);
    let primitive = &document.root().meshes[0].primitives[0];
    let (_, index) = (primitive.attributes.iter())
        .find(|(s, _)| json_of(s) == semantic)
        .unwrap_or_else(|| panic!("{semantic}"));
    let accessor = &document.root().accessors[index.value()];
    let component = json_of(&accessor.component_type).as_u64().unwrap() as u32;
    (
        component,
        accessor.normalized,
        accessor_data(document, index.value()),
    )
}

#[test]
fn a_quantized_gltf_is_read_as_its_numbers_and_written_back_in_its_types() {
    // KHR_mesh_quantization as gltfpack writes it: u16 positions scaled by the node,
    // normalized i8 normals, normalized u16 texture coordinates, i16 morph deltas.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/quantized-quad.gltf");
    let scene = read(&path).unwrap();
    let mesh = &scene.meshes[0];
    assert_eq!(mesh.positions[3], Vec3::new(1000.0, 1000.0, 0.0));
    let world = scene.instances[0]
        .transform
        .transform_point3(mesh.positions[3]);
    assert!((world - Vec3::new(2.0, 1.0, 0.0)).length() < 1e-6);
    let normal = mesh.attribute("NORMAL").unwrap();
    assert_eq!(
        (normal.vertex(2), normal.value(2, 1)),
        (vec![0.0, 90.0, 90.0], 90.0 / 127.0)
    );
    for format in ["glb", "gltf"] {
        let back = written(&scene, &format!("quantized.{format}"));
        assert_same_flat(&back, &scene, format);
        assert_eq!(
            document(&back).root().extensions_required,
            ["KHR_mesh_quantization"]
        );
        for semantic in ["POSITION", "NORMAL", "TEXCOORD_0"] {
            assert_eq!(
                primitive_accessor(&back, semantic),
                primitive_accessor(&scene, semantic),
                "{format} {semantic}: the same type and bytes"
            );
        }
    }
    // Positions moved off the integers are written as f32, not rounded.
    let mut moved = scene.clone();
    moved.meshes[0].positions[1].x = 999.5;
    let back = written(&moved, "moved.glb");
    assert_eq!(primitive_accessor(&back, "POSITION").0, 5126);
    assert_eq!(back.meshes[0].positions, moved.meshes[0].positions);
    // Formats with no `normalized` flag get the numbers: OBJ's vn and vt, in world space.
    let dir = temp_dir();
    write(&scene, &dir.path().join("q.obj")).unwrap();
    let obj = std::fs::read_to_string(dir.path().join("q.obj")).unwrap();
    for line in [
        "v 2 1 0",
        "vn 0 0 1",
        "vn 0 0.70710677 0.70710677",
        "vt 1 0.5000076",
    ] {
        assert!(obj.lines().any(|l| l == line), "{line} in\n{obj}");
    }
}

#[test]
fn attributes_a_format_cannot_type_are_written_as_their_numbers() {
    let typed =
        |name: &str, normalized: bool, values: rtmesh::mesh::AttributeValues| VertexAttribute {
            name: name.into(),
            components: 1,
            normalized,
            values,
            component_names: Vec::new(),
        };
    use rtmesh::mesh::AttributeValues as V;
    let mut mesh = TriMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
    mesh.attributes = vec![
        VertexAttribute {
            components: 2,
            ..typed("TEXCOORD_0", true, V::U16(vec![0, 0, 65535, 0, 0, 32768]))
        },
        VertexAttribute {
            components: 4,
            ..typed(
                "COLOR_0",
                true,
                V::U8(vec![255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 128, 255]),
            )
        },
        typed("_ID", false, V::U32(vec![7, 1 << 20, 3])),
    ];
    let scene = Scene::from_mesh(mesh);
    // The numbers as f32, as the formats without `normalized` hold them.
    let numbers = |scene: &Scene, name: &str| -> Vec<f32> {
        let a = scene.meshes[0].attribute(name).unwrap();
        let k = a.components;
        (0..a.vertex_count() * k)
            .map(|i| a.value(i / k, i % k) as f32)
            .collect()
    };
    // PLY: integer colours stay (PLY readers take them for [0, 1]); other normalized
    // integers become the f32 numbers they stand for.
    let ply = written(&scene, "typed.ply");
    let uv = ply.meshes[0].attribute("TEXCOORD_0").unwrap();
    assert!(matches!(uv.values, V::F32(_)) && !uv.normalized);
    assert!(matches!(
        ply.meshes[0].attribute("COLOR_0").unwrap().values,
        V::U8(_)
    ));
    // glTF keeps u32 for indices: the id is written as f32 (exact below 2^24).
    let gltf = written(&scene, "typed.gltf");
    assert_eq!(primitive_accessor(&gltf, "_ID").0, 5126);
    assert_eq!(primitive_accessor(&gltf, "TEXCOORD_0").0, 5123);
    // (PLY names the custom stream `id`, glTF `_ID`.)
    for (back, id) in [(&ply, "id"), (&gltf, "_ID")] {
        for (name, source) in [
            ("TEXCOORD_0", "TEXCOORD_0"),
            ("COLOR_0", "COLOR_0"),
            (id, "_ID"),
        ] {
            assert_eq!(numbers(back, name), numbers(&scene, source), "{name}");
        }
    }
}

#[test]
fn a_required_extension_that_changes_geometry_is_named_and_one_that_does_not_is_read() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/quantized-quad.gltf");
    let text = std::fs::read_to_string(&path).unwrap();
    let dir = temp_dir();
    for (required, readable) in [
        ("KHR_draco_mesh_compression", false),
        ("EXT_mesh_gpu_instancing", false),
        ("KHR_materials_variants", true),
        ("KHR_texture_basisu", true),
    ] {
        let edited = text.replace(
            r#""extensionsRequired": [
  "KHR_mesh_quantization"
 ]"#,
            &format!(r#""extensionsRequired": ["KHR_mesh_quantization", "{required}"]"#),
        );
        assert_ne!(edited, text);
        let file = dir.path().join(format!("{required}.gltf"));
        std::fs::write(&file, edited).unwrap();
        match read(&file) {
            Ok(scene) => {
                assert!(readable, "{required} read");
                let back = written(&scene, "back.gltf");
                assert!(document(&back)
                    .root()
                    .extensions_required
                    .contains(&required.to_owned()));
            }
            Err(e) => {
                assert!(!readable, "{required}: {e}");
                assert!(
                    e.to_string()
                        .contains(&format!("requires the extension {required}")),
                    "{e}"
                );
            }
        }
    }
}

/// A triangle whose POSITION is sparse over a base view (vertex 2 lifted to z = 0.25)
/// and whose morph target is sparse over zeros (vertex 1 moved by 0.5 in z), as
/// Blender writes shape keys; `sparse_index` is the morph target's one index.
fn sparse_gltf(dir: &Path, sparse_index: u16) -> std::path::PathBuf {
    let mut bin: Vec<u8> = Vec::new();
    for x in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bin.extend(x.to_le_bytes());
    }
    // 36: the indices of both substitutions (u16, padded), 40: POSITION's value,
    // 52: the target's value.
    bin.extend([2u16, sparse_index].iter().flat_map(|i| i.to_le_bytes()));
    for x in [0.0f32, 1.0, 0.25, 0.0, 0.0, 0.5] {
        bin.extend(x.to_le_bytes());
    }
    std::fs::write(dir.join("sparse.bin"), &bin).unwrap();
    let sparse = |indices: usize, values: usize| {
        serde_json::json!({"count": 1, "indices": {"bufferView": indices, "componentType": 5123},
            "values": {"bufferView": values}})
    };
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"},
        "buffers": [{"uri": "sparse.bin", "byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 2},
            {"buffer": 0, "byteOffset": 38, "byteLength": 2},
            {"buffer": 0, "byteOffset": 40, "byteLength": 12},
            {"buffer": 0, "byteOffset": 52, "byteLength": 12}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0.25], "sparse": sparse(1, 3)},
            {"componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [0, 0, 0.5], "sparse": sparse(2, 4)}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "targets": [{"POSITION": 1}]}],
                    "weights": [1.0]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    let path = dir.join("sparse.gltf");
    std::fs::write(&path, gltf.to_string()).unwrap();
    path
}

#[test]
fn sparse_accessors_are_read_with_their_substitutions() {
    let dir = temp_dir();
    let scene = read(&sparse_gltf(dir.path(), 1)).unwrap_or_else(|e| panic!("{e}"));
    let mesh = &scene.meshes[0];
    assert_eq!(
        mesh.positions,
        [Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.0, 0.25)]
    );
    let delta = mesh.attribute("target0:POSITION").unwrap();
    assert_eq!(
        (0..3).map(|v| delta.vertex(v)).collect::<Vec<_>>(),
        [vec![0.0; 3], vec![0.0, 0.0, 0.5], vec![0.0; 3]]
    );
    // Written dense, the same numbers come back.
    let back = written(&scene, "dense.glb");
    assert_same_flat(&back, &scene, "glb");
    // A substitution past the elements is an error naming it.
    let error = read(&sparse_gltf(dir.path(), 3)).unwrap_err().to_string();
    assert!(
        error.contains("sparse index 3 (entry 0) is past its 3 elements"),
        "{error}"
    );
}

/// A quad as `gltfpack -c` writes one: positions and normals (octahedral, i8) through
/// meshoptimizer's vertex codec, triangles through its index codec, each in a view of
/// `EXT_meshopt_compression` over a fallback buffer; `plain` writes the same data
/// uncompressed (the normals as the filter decodes them) instead.
fn meshopt_gltf(dir: &Path, name: &str, plain: bool, corrupt: bool) -> std::path::PathBuf {
    use meshopt::encoding::{
        decode_filter_oct, encode_filter_oct, encode_index_buffer, encode_vertex_buffer,
    };
    let positions: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.5],
    ];
    let normals = [
        [0.0f32, 0.0, 1.0, 0.0],
        [0.0, 0.6, 0.8, 0.0],
        [0.6, 0.0, 0.8, 0.0],
        [0.0, 0.0, 1.0, 0.0],
    ];
    let encoded_normals: Vec<[i8; 4]> = encode_filter_oct(&normals, 8);
    let mut filtered = encoded_normals.clone();
    decode_filter_oct(&mut filtered);
    let indices = [0u32, 1, 2, 1, 3, 2];
    let position_bytes: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let normal_bytes: Vec<u8> = filtered.iter().flatten().map(|&x| x as u8).collect();
    let index_bytes: Vec<u8> = indices
        .iter()
        .flat_map(|&i| (i as u16).to_le_bytes())
        .collect();
    let streams = match plain {
        true => vec![
            position_bytes.clone(),
            normal_bytes.clone(),
            index_bytes.clone(),
        ],
        false => vec![
            encode_vertex_buffer(&positions).unwrap(),
            encode_vertex_buffer(&encoded_normals).unwrap(),
            encode_index_buffer(&indices, 4).unwrap(),
        ],
    };
    let mut bin = Vec::new();
    let mut at = Vec::new();
    for stream in &streams {
        at.push(bin.len());
        bin.extend(stream);
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
    }
    if corrupt {
        bin[at[0] + 1..at[1]].iter_mut().for_each(|b| *b = 0xff);
    }
    std::fs::write(dir.join(format!("{name}.bin")), &bin).unwrap();
    let sizes: [(usize, usize, &str, &str); 3] = [
        (12, 4, "ATTRIBUTES", "NONE"),
        (4, 4, "ATTRIBUTES", "OCTAHEDRAL"),
        (2, 6, "TRIANGLES", "NONE"),
    ];
    let mut fallback_at = 0;
    let views: Vec<serde_json::Value> = (0..3)
        .map(|k| {
            let (stride, count, mode, filter) = sizes[k];
            let length = stride * count;
            let view = match plain {
                true => serde_json::json!({"buffer": 0, "byteOffset": at[k], "byteLength": length}),
                false => {
                    serde_json::json!({"buffer": 1, "byteOffset": fallback_at, "byteLength": length,
                    "extensions": {"EXT_meshopt_compression": {"buffer": 0, "byteOffset": at[k],
                        "byteLength": streams[k].len(), "byteStride": stride, "count": count,
                        "mode": mode, "filter": filter}}})
                }
            };
            fallback_at += length.next_multiple_of(4);
            let mut view = view;
            if k < 2 {
                view["byteStride"] = serde_json::json!(stride);
            }
            view
        })
        .collect();
    let mut buffers =
        vec![serde_json::json!({"uri": format!("{name}.bin"), "byteLength": bin.len()})];
    let mut extensions = vec!["KHR_mesh_quantization"];
    if !plain {
        buffers.push(serde_json::json!({"byteLength": fallback_at,
            "extensions": {"EXT_meshopt_compression": {"fallback": true}}}));
        extensions.insert(0, "EXT_meshopt_compression");
    }
    let mut gltf = serde_json::json!({
        "asset": {"version": "2.0"},
        "buffers": buffers,
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0.5]},
            {"bufferView": 1, "componentType": 5120, "normalized": true, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    gltf["extensionsUsed"] = serde_json::json!(extensions);
    gltf["extensionsRequired"] = serde_json::json!(extensions);
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, gltf.to_string()).unwrap();
    path
}

#[test]
fn meshopt_compressed_views_are_decoded_to_the_data_they_hold() {
    let dir = temp_dir();
    let compressed =
        read(&meshopt_gltf(dir.path(), "c", false, false)).unwrap_or_else(|e| panic!("{e}"));
    let plain = read(&meshopt_gltf(dir.path(), "p", true, false)).unwrap_or_else(|e| panic!("{e}"));
    assert_same_flat(&compressed, &plain, "gltf");
    assert_eq!(compressed.meshes[0].positions[3], Vec3::new(1.0, 1.0, 0.5));
    // Written uncompressed, without the extension, and read back the same.
    let back = written(&compressed, "out.glb");
    assert_same_flat(&back, &plain, "glb");
    let root = document(&back).root();
    assert_eq!(root.extensions_required, ["KHR_mesh_quantization"]);
    assert!(!root
        .extensions_used
        .iter()
        .any(|e| e == "EXT_meshopt_compression"));
    // Bytes that do not decode are an error naming the view.
    let error = read(&meshopt_gltf(dir.path(), "x", false, true))
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("buffer view 0: EXT_meshopt_compression data does not decode"),
        "{error}"
    );
}

/// A PLY whose faces hold a colour, a label and a quality beside their indices, and a
/// list per face and an `edge` element that rtmesh does not read. Its faces: one
/// naming a vertex twice and a triangle repeated, for repair to remove ahead of the
/// others, a quad (two triangles of one face) and a sliver.
fn ply_with_face_properties(dir: &Path) -> std::path::PathBuf {
    let ply = "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
element face 5\nproperty list uchar int vertex_indices\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty int label\nproperty list uchar int neighbours\nproperty float quality\n\
element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n\
0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n2 0 0 0 0 1\n2 0.001 0 0 0 1\n\
3 0 0 3 9 9 9 1 0 0\n3 1 2 5 0 0 255 9 0 -2\n3 1 2 5 0 0 255 9 0 -2\n4 0 1 2 3 255 0 0 7 0 0.25\n3 1 4 5 0 255 0 -3 2 4 5 1.5\n\
0 2\n";
    let path = dir.join("faces.ply");
    std::fs::write(&path, ply).unwrap();
    path
}

#[test]
fn a_ply_face_keeps_its_properties_through_every_step() {
    let dir = temp_dir();
    let path = ply_with_face_properties(dir.path());
    let scene = read(&path).unwrap();
    let mesh = &scene.meshes[0];
    // The quad's fan is two triangles with the quad's values, in the stored types.
    let summary: Vec<(&str, usize, &str)> = (mesh.triangle_attributes.iter())
        .map(|a| (a.name.as_str(), a.components, a.type_name()))
        .collect();
    assert_eq!(
        summary,
        [
            ("COLOR_0", 3, "uchar"),
            ("label", 1, "int"),
            ("quality", 1, "float")
        ]
    );
    let column = |name: &str| -> Vec<Vec<f64>> {
        let a = mesh
            .triangle_attributes
            .iter()
            .find(|a| a.name == name)
            .unwrap();
        (0..mesh.triangle_count()).map(|t| a.vertex(t)).collect()
    };
    assert_eq!(
        column("label"),
        [[1.0], [9.0], [9.0], [7.0], [7.0], [-3.0]].map(|v| v.to_vec())
    );
    assert_eq!(
        column("quality"),
        [[0.0], [-2.0], [-2.0], [0.25], [0.25], [1.5]].map(|v| v.to_vec())
    );
    assert_eq!(
        scene.read_notes.not_read,
        [
            "PLY face property 'neighbours' (a list per face)",
            "PLY element 'edge': 1"
        ]
    );
    // Written and read back, through pairing, repair and optimize: every output
    // triangle has its input triangle's values (`same_corners`), in PLY; the other
    // formats name them as not held.
    check_file(&path, &["ply", "glb", "obj"]);
    let notes = write(&scene, &dir.path().join("faces.glb")).unwrap();
    assert_eq!(
        notes.not_held,
        ["triangle attributes COLOR_0, label, quality (of the formats, PLY alone holds values per triangle)"]
    );
    assert_eq!(notes.not_read, scene.read_notes.not_read);
    let notes = write(&scene, &dir.path().join("faces-again.ply")).unwrap();
    assert!(notes.not_held.is_empty(), "{:?}", notes.not_held);
    let header = std::fs::read(dir.path().join("faces-again.ply")).unwrap();
    let header = String::from_utf8_lossy(&header[..400]);
    assert!(
        header.contains("element face 6\nproperty list uchar uint vertex_indices\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty int label\nproperty float quality\n"),
        "{header}"
    );
}

//! Reader and writer tests: every kind of bad input gives an error naming the file and
//! line (or offset), and round trips keep positions and triangle order bit-exact.

use super::*;
use crate::mesh::{Scene, TriMesh};
use crate::scenes;

/// Reading `bytes` as `name` fails with a message that starts with `prefix`.
fn assert_error(name: &str, bytes: &[u8], prefix: &str) {
    let message = error_of(name, bytes);
    assert!(message.starts_with(prefix), "{message}");
}

fn error_of(name: &str, bytes: &[u8]) -> String {
    match read_bytes(Path::new(name), bytes) {
        Ok(scene) => panic!(
            "{name}: expected an error, read {} meshes",
            scene.meshes.len()
        ),
        Err(e) => e.to_string(),
    }
}

#[test]
fn obj_errors_name_file_and_line() {
    let cases: [(&[u8], &str); 9] = [
        (
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n",
            "bad.obj:5:",
        ),
        (b"v 0 0 0\nv 1 0 zero\n", "bad.obj:2:"),
        (
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
            "bad.obj:4: face has 2 vertices",
        ),
        (
            b"v 0 0 0\nv 1 0 0\n\nv 0 1 0\nf 1 2 3\nf 1 x 3\n",
            "bad.obj:6:",
        ),
        (b"v 0 0 0\n\xff\xfe v 1 0 0\n", "bad.obj:2:"),
        (
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 3\n",
            "bad.obj:5: face has 1 vertices",
        ),
        // Attribute indices that tobj would wrap (or panic on, in a debug build).
        (
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/0 3/1\n",
            "bad.obj:5: face texture coordinate index 0 is out of range (1 read so far)",
        ),
        (
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//-1 2//-2 3//-1\n",
            "bad.obj:5: face normal index -2 is out of range (1 read so far)",
        ),
        (
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//4294967296 3//1\n",
            "bad.obj:5: face normal index 4294967296 is out of range (1 read so far)",
        ),
    ];
    for (bytes, expected) in cases {
        let message = error_of("bad.obj", bytes);
        assert!(
            message.starts_with(expected),
            "{message:?} should start with {expected:?}"
        );
    }
}

#[test]
fn obj_attribute_indices_in_range_read() {
    // Absolute and relative texture coordinate and normal indices, all in range.
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\nf 1/1/1 2/-1/-1 3/2/1\n";
    let scene = read_bytes(Path::new("ok.obj"), obj).expect("valid indices");
    assert_eq!(scene.meshes[0].triangles, vec![[0, 1, 2]]);
}

#[test]
fn empty_files_read_as_empty_or_fail_clearly() {
    let obj = read_bytes(Path::new("empty.obj"), b"").expect("an empty OBJ is an empty scene");
    assert_eq!(obj.instanced_triangle_count(), 0);
    assert!(error_of("empty.ply", b"").starts_with("empty.ply:"));
    assert!(error_of("empty.glb", b"").starts_with("empty.glb:"));
    assert!(error_of("empty.gltf", b"").starts_with("empty.gltf:"));
}

const ASCII_PLY_HEADER: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

#[test]
fn ply_ascii_reads_and_errors_name_the_line() {
    let good = format!("{ASCII_PLY_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    let scene = read_bytes(Path::new("t.ply"), good.as_bytes()).unwrap();
    assert_eq!(scene.meshes[0].triangles, vec![[0, 1, 2]]);

    let bad_number = format!("{ASCII_PLY_HEADER}0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n");
    assert_error("t.ply", bad_number.as_bytes(), "t.ply:11:");

    let out_of_range = format!("{ASCII_PLY_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
    assert!(error_of("t.ply", out_of_range.as_bytes()).contains("vertex index"));

    let two_corners = format!("{ASCII_PLY_HEADER}0 0 0\n1 0 0\n0 1 0\n2 0 1\n");
    assert!(error_of("t.ply", two_corners.as_bytes()).contains("face 0 has 2 vertices"));

    let truncated = format!("{ASCII_PLY_HEADER}0 0 0\n1 0 0\n");
    assert!(error_of("t.ply", truncated.as_bytes()).starts_with("t.ply:"));
}

#[test]
fn ply_absurd_counts_fail_before_allocating() {
    let header = "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 4000000000\nproperty list uchar uint vertex_indices\nend_header\n";
    let message = error_of("huge.ply", header.as_bytes());
    assert!(
        message.contains("4000000000 'vertex' elements"),
        "{message}"
    );
    let mut list = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uint uint vertex_indices\nend_header\n".to_vec();
    list.extend(std::iter::repeat_n(0u8, 36));
    list.extend(4_000_000_000u32.to_le_bytes());
    assert!(error_of("list.ply", &list).starts_with("list.ply:"));
}

#[test]
fn ply_polygons_are_fan_triangulated() {
    let text = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n-1 1 0\n5 0 1 2 3 4\n";
    let scene = read_bytes(Path::new("p.ply"), text.as_bytes()).unwrap();
    assert_eq!(
        scene.meshes[0].triangles,
        vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]
    );
}

#[test]
fn glb_with_lying_header_or_accessor_fails_clearly() {
    let mut bytes = b"glTF".to_vec();
    bytes.extend(2u32.to_le_bytes());
    bytes.extend(4u32.to_le_bytes()); // length smaller than the header itself
    assert!(error_of("x.glb", &bytes).contains("GLB header declares length"));

    let json = r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":12,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAA"}],
        "bufferViews":[{"buffer":0,"byteLength":12}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":5,"type":"VEC3","min":[0,0,0],"max":[0,0,0]}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]}"#;
    let message = error_of("x.gltf", json.as_bytes());
    assert!(message.contains("runs past its buffer view"), "{message}");
}

/// The corners of every triangle of every instance, in order, as bit patterns.
fn corner_bits(scene: &Scene) -> Vec<[u32; 9]> {
    let flat = scene.flatten().unwrap();
    (0..flat.triangle_count())
        .map(|t| {
            let [a, b, c] = flat.corners(t);
            let v = [a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z];
            v.map(f32::to_bits)
        })
        .collect()
}

/// Writes `scene` and reads it back. Tests run in parallel threads, so every call
/// gets its own directory (a shared one was removed under a neighbour in CI).
fn round_trip(scene: &Scene, extension: &str) -> Scene {
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("rtmesh-io-test-{}-{call}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("round-trip.{extension}"));
    write(scene, &path).unwrap();
    let back = read(&path).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    back
}

#[test]
fn round_trips_keep_corners_and_order_bit_exact() {
    let mut blob = scenes::scan_blob(2_000, 7);
    blob.positions[5].x = f32::from_bits(0x3f80_0001); // one ulp above 1
    blob.positions[6].y = -0.0;
    blob.positions[7].z = 1.0e-30;
    let scenes = [Scene::from_mesh(blob), scenes::room()];
    for scene in &scenes {
        let original = corner_bits(scene);
        for extension in ["obj", "ply", "glb", "gltf"] {
            let back = round_trip(scene, extension);
            assert_eq!(corner_bits(&back), original, "{extension}");
            // A second trip is the identity on the stored form.
            let again = round_trip(&back, extension);
            assert_eq!(again.meshes, back.meshes, "{extension} second trip");
        }
        let glb = round_trip(scene, "glb");
        let placements =
            |s: &Scene| -> Vec<_> { s.instances.iter().map(|i| (i.mesh, i.transform)).collect() };
        assert_eq!(placements(&glb), placements(scene), "glTF keeps instances");
    }
}

#[test]
fn gltf_keeps_materials_and_alpha_flags() {
    let mut mesh = scenes::box_mesh(glam::Vec3::ZERO, glam::Vec3::ONE);
    mesh.material_ids = vec![0, 0, 1, 1, 0, 0, 1, 1, 1, 1, 0, 0];
    mesh.alpha_tested = mesh.material_ids.iter().map(|&m| m == 1).collect();
    let mut scene = Scene::from_mesh(mesh);
    scene.materials = vec![
        crate::mesh::Material {
            name: "stone".into(),
            alpha_tested: false,
            mtl: None,
        },
        crate::mesh::Material {
            name: "leaves".into(),
            alpha_tested: true,
            mtl: None,
        },
    ];
    let back = round_trip(&scene, "glb");
    // One primitive per material, in order of first use, each in mesh order.
    let mesh = &scene.meshes[0];
    let order: Vec<usize> = [0, 1]
        .into_iter()
        .flat_map(|m| (0..12).filter(move |&t| mesh.material_ids[t] == m))
        .collect();
    let expected: Vec<[u32; 3]> = order.iter().map(|&t| mesh.triangles[t]).collect();
    assert_eq!(back.meshes[0].triangles, expected);
    let materials: Vec<u32> = order.iter().map(|&t| mesh.material_ids[t]).collect();
    assert_eq!(back.meshes[0].material_ids, materials);
    let alpha: Vec<bool> = materials.iter().map(|&m| m == 1).collect();
    assert_eq!(back.meshes[0].alpha_tested, alpha);
    assert_eq!(back.materials[..2], scene.materials[..]);
}

#[test]
fn obj_groups_become_geometries_and_ngons_fans() {
    let text = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\ng first\nf 1 2 3 4\ng second\nf 1/1/1 3/1/1 4/1/1\nf -4 -3 -2\n";
    let scene = read_bytes(Path::new("g.obj"), text).unwrap();
    let names: Vec<_> = scene.meshes.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["first", "second"]);
    assert_eq!(scene.meshes[0].triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(scene.meshes[1].triangle_count(), 2);
    assert_eq!(scene.source_vertex_count, Some(4));
    let empty = TriMesh::default();
    assert_eq!(empty.triangle_count(), 0);
}

/// A PLY of six vertices and one `tristrips` element: the strip 0 1 2 3, a restart,
/// then 2 3 4 4 5 (a swap: the repeated 4 makes two degenerate triangles).
fn tristrip_ply(binary: bool) -> Vec<u8> {
    let strip: [i32; 10] = [0, 1, 2, 3, -1, 2, 3, 4, 4, 5];
    let corners: [[f32; 3]; 6] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 2.0, 0.0],
        [1.0, 2.0, 0.0],
    ];
    let format = if binary {
        "binary_little_endian"
    } else {
        "ascii"
    };
    let mut bytes = format!(
        "ply\nformat {format} 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n"
    )
    .into_bytes();
    if binary {
        for c in corners.iter().flatten() {
            bytes.extend(c.to_le_bytes());
        }
        bytes.extend((strip.len() as i32).to_le_bytes());
        for i in strip {
            bytes.extend(i.to_le_bytes());
        }
    } else {
        for [x, y, z] in corners {
            bytes.extend(format!("{x} {y} {z}\n").bytes());
        }
        let list: Vec<String> = strip.iter().map(i32::to_string).collect();
        bytes.extend(format!("{} {}\n", strip.len(), list.join(" ")).bytes());
    }
    bytes
}

#[test]
fn ply_tristrips_read_the_exact_triangles_with_their_winding() {
    for binary in [false, true] {
        let scene = read_bytes(Path::new("strips.ply"), &tristrip_ply(binary)).unwrap();
        // Odd triangles of a strip swap their first two corners; the swap's two
        // degenerate triangles (3 4 4 and 4 4 5) are dropped.
        assert_eq!(
            scene.meshes[0].triangles,
            [[0, 1, 2], [2, 1, 3], [2, 3, 4]],
            "binary {binary}"
        );
        assert_eq!(
            scene.read_notes.strip_degenerates_dropped, 2,
            "binary {binary}"
        );
        // Every triangle faces +z, as the strip's first does.
        let mesh = &scene.meshes[0];
        for t in 0..mesh.triangle_count() {
            let [a, b, c] = mesh.corners(t);
            assert!(
                (b - a).cross(c - a).z > 0.0,
                "triangle {t}, binary {binary}"
            );
        }
    }
    let bad = tristrip_ply(false);
    let bad = String::from_utf8(bad).unwrap().replace(" -1 ", " -7 ");
    let message = error_of("strips.ply", bad.as_bytes());
    assert!(message.contains("index -7"), "{message}");
}

/// Two triangles of a unit square sharing the edge (1,0,0)–(0,1,0), as ascii STL.
const SQUARE_STL: &str = "solid square\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 1 0\n  endloop\n endfacet\n facet normal 0 0 1\n  outer loop\n   vertex 1 0 0\n   vertex 1 1 0\n   vertex 0 1 0\n  endloop\n endfacet\nendsolid square\n";

/// A binary STL of the triangles `corners`, with the header starting with `solid` (as
/// some writers do) to show that the size decides.
fn binary_stl(corners: &[[[f32; 3]; 3]], declared: u32) -> Vec<u8> {
    let mut bytes = b"solid but binary".to_vec();
    bytes.resize(80, b' ');
    bytes.extend(declared.to_le_bytes());
    for triangle in corners {
        bytes.extend([0u8; 12]);
        for c in triangle.iter().flatten() {
            bytes.extend(c.to_le_bytes());
        }
        bytes.extend([0u8; 2]);
    }
    bytes
}

#[test]
fn stl_ascii_and_binary_weld_to_the_same_indexed_mesh() {
    let square = [
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
    ];
    let ascii = read_bytes(Path::new("square.stl"), SQUARE_STL.as_bytes()).unwrap();
    let binary = read_bytes(Path::new("square.stl"), &binary_stl(&square, 2)).unwrap();
    for scene in [&ascii, &binary] {
        let mesh = &scene.meshes[0];
        assert_eq!(mesh.triangles, [[0, 1, 2], [1, 3, 2]]);
        assert_eq!(mesh.positions.len(), 4);
        for (t, corners) in square.iter().enumerate() {
            assert_eq!(mesh.corners(t), corners.map(glam::Vec3::from_array));
        }
        assert_eq!(scene.source_vertex_count, Some(6));
    }
    assert_eq!(ascii.meshes[0].name, "square");
    // Two solids: two geometries, named.
    let two = format!("{SQUARE_STL}{}", SQUARE_STL.replace("square", "other"));
    let scene = read_bytes(Path::new("two.stl"), two.as_bytes()).unwrap();
    let names: Vec<&str> = scene.meshes.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["square", "other"]);
    assert_eq!(scene.instances.len(), 2);
}

#[test]
fn stl_errors_name_the_file_and_line() {
    let square = [[[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]];
    let lying = binary_stl(&square, 1_000_000);
    assert_error("lying.stl", &lying[4..], "lying.stl: ");
    let message = error_of("lying.stl", &binary_stl(&square, 1_000_000));
    assert!(
        message.contains("declares 1000000 triangles") && message.contains("lying.stl"),
        "{message}"
    );
    let cases = [
        (
            SQUARE_STL.replace("vertex 1 1 0", "vertex 1 one 0"),
            "bad.stl:12: vertex coordinate `one`",
        ),
        (
            SQUARE_STL.replace(
                "   vertex 0 1 0\n  endloop\n endfacet\nendsolid",
                "   vertex 0 1 0\n   vertex 2 2 0\n  endloop\n endfacet\nendsolid",
            ),
            "bad.stl:14: a facet with more than 3",
        ),
        (
            SQUARE_STL.replace("endsolid square\n", ""),
            "bad.stl: the last solid has no endsolid",
        ),
        (
            SQUARE_STL.replacen("   vertex 0 0 0\n", "", 1),
            "bad.stl:6: a facet with 2 vertices",
        ),
        ("hello\n".into(), "bad.stl: 6 bytes: too short"),
    ];
    for (text, expected) in cases {
        let message = error_of("bad.stl", text.as_bytes());
        assert!(
            message.starts_with(expected),
            "{message:?} should start with {expected:?}"
        );
    }
}

#[test]
fn stl_attribute_words_are_kept_per_triangle() {
    let square = [
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
    ];
    let plain = binary_stl(&square, 2);
    let scene = read_bytes(Path::new("plain.stl"), &plain).unwrap();
    assert!(scene.meshes[0].triangle_attributes.is_empty());
    // A facet colour in the word (VisCAM's: bit 15 set, then 5-5-5 bits), on the second.
    let mut coloured = plain.clone();
    coloured[84 + 2 * 50 - 2..84 + 2 * 50].copy_from_slice(&0x801fu16.to_le_bytes());
    let scene = read_bytes(Path::new("coloured.stl"), &coloured).unwrap();
    let words = |scene: &Scene| -> Vec<f64> {
        let mesh = &scene.meshes[0];
        let word = &mesh.triangle_attributes[0];
        assert_eq!(word.name, stl::ATTRIBUTE_WORD);
        (0..mesh.triangle_count()).map(|t| word.get(t, 0)).collect()
    };
    assert_eq!(words(&scene), [0.0, 0x801f as f64]);
    for extension in ["stl", "ply"] {
        assert_eq!(
            words(&round_trip(&scene, extension)),
            [0.0, 0x801f as f64],
            "{extension}"
        );
    }
    let dir = std::env::temp_dir().join(format!("rtmesh-io-stl-words-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write(&scene, &dir.join("same.stl")).unwrap();
    let written = std::fs::read(dir.join("same.stl")).unwrap();
    let facet_words = |bytes: &[u8]| -> Vec<[u8; 2]> {
        (bytes[84..].chunks_exact(50))
            .map(|f| [f[48], f[49]])
            .collect()
    };
    assert_eq!(facet_words(&written), facet_words(&coloured));
    let notes = write(&scene, &dir.join("out.glb")).unwrap();
    assert_eq!(
        notes.not_held,
        [
            "the binary STL header (\"solid but binary\"), which an STL output alone keeps",
            "triangle attributes stl_attribute (of the formats, PLY alone holds values per triangle)"
        ]
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A PLY header's `comment` and `obj_info` lines (a scanner's provenance, a licence)
/// are written back in order by the PLY writer, after rtmesh's own comment and without
/// piling it up over round trips; MeshLab's `TextureFile` comments are the materials'
/// and written once; `info` lists them, and other formats name them as not held.
/// Before, every PLY written had rtmesh's comment alone.
#[test]
fn ply_comments_and_obj_info_are_written_back() {
    let ply = "ply\nformat ascii 1.0\ncomment zipper output\nobj_info scanner 3\n\
               comment TextureFile t.png\ncomment  licence: CC-BY 4.0 \nelement vertex 3\n\
               property float x\nproperty float y\nproperty float z\nelement face 1\n\
               property list uchar int vertex_indices\nproperty int texnumber\nend_header\n\
               0 0 0\n1 0 0\n0 1 0\n3 0 1 2 0\n";
    let scene = read_bytes(Path::new("scan.ply"), ply.as_bytes()).unwrap();
    let info = crate::mesh::MeshInfo::of(&scene);
    let expected = ["zipper output", " licence: CC-BY 4.0 ", "scanner 3"];
    assert_eq!(
        info.document
            .ply_comments
            .iter()
            .map(|c| c.trim())
            .collect::<Vec<_>>(),
        expected.map(str::trim)
    );
    let dir = std::env::temp_dir().join(format!("rtmesh-io-ply-comments-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write(&scene, &dir.join("once.ply")).unwrap();
    let once = read(&dir.join("once.ply")).unwrap();
    write(&once, &dir.join("twice.ply")).unwrap();
    let header = |file: &str| -> Vec<String> {
        let bytes = std::fs::read(dir.join(file)).unwrap();
        let end = bytes.windows(10).position(|w| w == b"end_header").unwrap();
        (String::from_utf8_lossy(&bytes[..end]).lines())
            .filter(|l| l.starts_with("comment") || l.starts_with("obj_info"))
            .map(|l| l.trim().to_owned())
            .collect()
    };
    let written = [
        format!("comment written by rtmesh {}", env!("CARGO_PKG_VERSION")),
        "comment zipper output".into(),
        "comment licence: CC-BY 4.0".into(),
        "comment TextureFile t.png".into(),
        "obj_info scanner 3".into(),
    ];
    assert_eq!(header("once.ply"), written);
    assert_eq!(header("twice.ply"), written);
    assert_eq!(once.document, scene.document);
    let notes = write(&scene, &dir.join("scan.glb")).unwrap();
    assert!(
        notes.not_held.iter().any(|n| n
            .starts_with("the PLY header's comment and obj_info lines: 3 (\"zipper output\", ")),
        "{:?}",
        notes.not_held
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A binary STL's 80-byte header (here Materialise's `COLOR=` default colour, bytes
/// past ASCII included) is written back byte for byte by the STL writer, shown by
/// `info` as text, and named where another format cannot hold it; a blank one, or the
/// one rtmesh writes, is not named. Before, every STL written got rtmesh's header.
#[test]
fn stl_binary_headers_are_written_back() {
    let triangle = [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]];
    let mut bytes = binary_stl(&triangle, 1);
    let header = b"COLOR=\x80\x40\x20\xff MATERIAL=\x01\x02\x03\x04";
    bytes[..80].fill(0);
    bytes[..header.len()].copy_from_slice(header);
    let scene = read_bytes(Path::new("coloured.stl"), &bytes).unwrap();
    let text = r"COLOR=\x80@ \xff MATERIAL=\x01\x02\x03\x04";
    assert_eq!(crate::mesh::MeshInfo::of(&scene).document.stl_header, text);
    let dir = std::env::temp_dir().join(format!("rtmesh-io-stl-header-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write(&scene, &dir.join("same.stl")).unwrap();
    assert_eq!(
        std::fs::read(dir.join("same.stl")).unwrap()[..84],
        bytes[..84]
    );
    let notes = write(&scene, &dir.join("out.obj")).unwrap();
    let note = format!("the binary STL header (\"{text}\"), which an STL output alone keeps");
    assert_eq!(notes.not_held, [note]);
    // A blank header, and the one rtmesh writes from another format, say nothing.
    bytes[..80].fill(b' ');
    let blank = read_bytes(Path::new("blank.stl"), &bytes).unwrap();
    assert!(write(&blank, &dir.join("blank.obj"))
        .unwrap()
        .not_held
        .is_empty());
    let from_obj = round_trip(&blank, "obj");
    write(&from_obj, &dir.join("own.stl")).unwrap();
    let own = read(&dir.join("own.stl")).unwrap();
    assert!(crate::mesh::MeshInfo::of(&own)
        .document
        .stl_header
        .starts_with(stl::OWN_HEADER));
    assert!(write(&own, &dir.join("own.obj"))
        .unwrap()
        .not_held
        .is_empty());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn stl_round_trip_keeps_corners_and_order_bit_exact() {
    let scene = scenes::by_name("room").unwrap();
    let back = round_trip(&scene, "stl");
    assert_eq!(
        corner_bits(&Scene::from_mesh(scene.flatten().unwrap())),
        corner_bits(&back)
    );
}

#[test]
fn gltf_writes_inactive_triangles_as_collapsed_degenerates_not_nan() {
    let mut mesh = scenes::quad_grid(2);
    let nan = mesh.positions.len() as u32;
    mesh.positions.push(glam::Vec3::NAN);
    // Triangle 1 made inactive as repair does (all corners on a NaN vertex), triangle 3
    // with one NaN corner as a file may have it.
    mesh.triangles[1] = [nan; 3];
    let [a, b, _] = mesh.triangles[3];
    mesh.triangles[3] = [a, b, nan];
    let scene = Scene::from_mesh(mesh.clone());
    for extension in ["glb", "gltf"] {
        let back = round_trip(&scene, extension);
        let out = &back.meshes[0];
        assert!(out.positions.iter().all(|p| p.is_finite()), "{extension}");
        assert_eq!(out.triangle_count(), mesh.triangle_count());
        for t in 0..mesh.triangle_count() {
            let [p, q, r] = out.corners(t);
            if t == 1 || t == 3 {
                assert!(p == q && q == r, "triangle {t} collapsed to a point");
            } else {
                assert_eq!(out.corners(t), mesh.corners(t), "triangle {t}");
            }
        }
        assert_eq!(
            out.corners(3)[0],
            mesh.positions[a as usize],
            "onto a finite corner"
        );
    }
}

#[test]
fn obj_bad_vertex_index_is_reported_at_its_own_line() {
    // The bad face is on line 5, inside a group that runs to line 35.
    let mut obj = String::from("g part\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    for i in 0..30 {
        obj.push_str(&format!("v {i} 1 1\n"));
    }
    assert_error(
        "group.obj",
        obj.as_bytes(),
        "group.obj:5: face vertex index 9 is out of range (3 read so far)",
    );
    assert_error(
        "rel.obj",
        b"v 0 0 0\nv 1 0 0\nf -1 -2 -3\n",
        "rel.obj:3: face vertex index -3",
    );
}

#[test]
fn obj_lines_and_points_are_ignored_and_counted() {
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nl 1 2 3 4\np 1 2\np 4\nf 1 2 3\n";
    let scene = read_bytes(Path::new("lines.obj"), obj).unwrap();
    assert_eq!(
        scene
            .meshes
            .iter()
            .map(TriMesh::triangle_count)
            .sum::<usize>(),
        1
    );
    assert_eq!(
        (
            scene.read_notes.ignored_lines,
            scene.read_notes.ignored_points
        ),
        (1, 2)
    );
}

#[test]
fn ply_vertices_without_x_y_and_z_are_errors() {
    let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0\n1 0\n0 1\n3 0 1 2\n";
    assert_error(
        "flat.ply",
        ply,
        "flat.ply: 'vertex' element has no 'z' property",
    );
}

#[test]
fn ply_keeps_every_vertex_property_with_its_type_and_name() {
    let text = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty float s\nproperty float t\nproperty int quality\nproperty double confidence\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 0 0 1 255 0 0 0 0 -7 0.25\n1 0 0 0 0 1 0 255 0 1 0 8 0.5\n0 1 0 0 0 1 0 0 255 0 1 2147483647 1e-300\n3 0 1 2\n";
    let scene = read_bytes(Path::new("attributes.ply"), text).unwrap();
    let mesh = &scene.meshes[0];
    let names: Vec<&str> = mesh.attributes.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(
        names,
        ["NORMAL", "COLOR_0", "TEXCOORD_0", "quality", "confidence"]
    );
    let colour = mesh.attribute("COLOR_0").unwrap();
    assert!(colour.normalized);
    assert_eq!(
        colour.values,
        crate::mesh::AttributeValues::U8(vec![255, 0, 0, 0, 255, 0, 0, 0, 255])
    );
    assert_eq!(
        mesh.attribute("TEXCOORD_0").unwrap().component_names,
        ["s", "t"]
    );
    assert_eq!(
        mesh.attribute("quality").unwrap().values,
        crate::mesh::AttributeValues::I32(vec![-7, 8, i32::MAX])
    );
    assert_eq!(mesh.attribute("confidence").unwrap().get(2, 0), 1e-300);
    // Binary PLY gives back the same streams, names and types.
    let back = round_trip(&scene, "ply");
    assert_eq!(back.meshes[0].attributes, mesh.attributes);
    assert_eq!(back.meshes[0].positions, mesh.positions);
}

#[test]
fn obj_keeps_usemtl_names_and_mtllib_without_the_library() {
    let text = b"mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nusemtl brick\nf 1/1/1 2/2/1 3/3/1\nusemtl glass\nf 2/2/1 4/1/1 3/3/1\n";
    let scene = read_bytes(Path::new("named.obj"), text).unwrap();
    let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["brick", "glass"]);
    let back = round_trip(&scene, "obj");
    let mesh = &back.meshes[0];
    let named: Vec<&str> = mesh
        .material_ids
        .iter()
        .map(|&m| back.materials[m as usize].name.as_str())
        .collect();
    assert_eq!(named, ["brick", "glass"]);
    assert_eq!(
        back.document.as_deref(),
        Some(&crate::io::Document::Obj {
            material_libraries: vec!["missing.mtl".into()]
        })
    );
    let uv = mesh.attribute("TEXCOORD_0").unwrap();
    let corner_uvs: Vec<Vec<f64>> = mesh.triangles[1]
        .iter()
        .map(|&v| uv.vertex(v as usize))
        .collect();
    assert_eq!(corner_uvs, [vec![1.0, 0.0], vec![0.0, 0.0], vec![0.0, 1.0]]);
}

#[test]
fn obj_smoothing_groups_are_named_where_the_file_has_no_normals() {
    let faces = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\ns 1\nf 1 2 3\ns off\nf 2 4 3\ns 2\nf 1 2 4\n";
    let scene = read_bytes(Path::new("smooth.obj"), faces.as_bytes()).unwrap();
    assert_eq!(
        scene.read_notes.not_read,
        ["OBJ smoothing groups (`s`): 2 statements, in a file without normals (`vn`)"]
    );
    let with_normals = format!("vn 0 0 1\n{}", faces.replace("f 1 2 3", "f 1//1 2//1 3//1"));
    let scene = read_bytes(Path::new("smooth.obj"), with_normals.as_bytes()).unwrap();
    assert!(scene.read_notes.not_read.is_empty());
}

#[test]
fn obj_names_it_cannot_keep_are_named() {
    let obj = "o car\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0 0\nvt 1 0 0.5\nvt 0 1\ng wheel\nf 1/1 2/2 3/3\ng door\nf 1/1 3/3 2/2\n";
    let scene = read_bytes(Path::new("car.obj"), obj.as_bytes()).unwrap();
    assert_eq!(
        scene.read_notes.not_read,
        ["OBJ object and group names that name no faces of their own: car (each geometry takes the name of the last `o` or `g` before its faces)"]
    );
    let plain = "o car\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0 0\nf 1/1 2/1 3/1\n";
    let scene = read_bytes(Path::new("car.obj"), plain.as_bytes()).unwrap();
    assert!(
        scene.read_notes.not_read.is_empty(),
        "{:?}",
        scene.read_notes.not_read
    );
}

/// `vt`'s third number (a 3D texture's w), where some is not 0, is the attribute
/// `_TEXCOORD_0_W`, exact corner by corner through OBJ, PLY and glTF and written back
/// as `vt u v w` (tobj reads two numbers; before, w was named as not read and lost). A
/// second geometry's own coordinates, a missing w (0) and one reused by two corners
/// keep their places; a file whose w are all 0 gets no such attribute.
#[test]
fn obj_texture_coordinates_keep_their_third_number() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0.25 0 0\nvt 1 0 0.5\nvt 0 1\n\
               o first\nf 1/1 2/2 3/3\nvt 0.5 0.5 -2.125\no second\nf 2/2 4/4 3/3\n";
    let corner_w = |scene: &Scene| -> Vec<[f64; 3]> {
        let flat = scene.flatten().unwrap();
        let w = flat.attribute(obj::TEXCOORD_W).expect("w kept");
        let mut names: Vec<&str> = flat.attributes.iter().map(|a| a.name.as_str()).collect();
        names.sort_unstable();
        assert_eq!(names, ["TEXCOORD_0", obj::TEXCOORD_W]);
        (flat.triangles.iter())
            .map(|t| t.map(|v| w.get(v as usize, 0)))
            .collect()
    };
    let scene = read_bytes(Path::new("w.obj"), obj.as_bytes()).unwrap();
    assert!(scene.read_notes.not_read.is_empty());
    let expected = [[0.0, 0.5, 0.0], [0.5, -2.125, 0.0]];
    assert_eq!(corner_w(&scene), expected);
    for extension in ["obj", "ply", "glb"] {
        assert_eq!(
            corner_w(&round_trip(&scene, extension)),
            expected,
            "{extension}"
        );
    }
    let dir = std::env::temp_dir().join(format!("rtmesh-io-w-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write(&scene, &dir.join("w.obj")).unwrap();
    let text = std::fs::read_to_string(dir.join("w.obj")).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let vt: Vec<&str> = text.lines().filter(|l| l.starts_with("vt ")).collect();
    assert_eq!(
        vt,
        [
            "vt 0.25 0 0",
            "vt 1 0 0.5",
            "vt 0 1 0",
            "vt 1 0 0.5",
            "vt 0.5 0.5 -2.125",
            "vt 0 1 0"
        ]
    );
    let zeros = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0 0\nvt 1 0 0.0\nvt 0 1 -0\nf 1/1 2/2 3/3\n";
    let scene = read_bytes(Path::new("zeros.obj"), zeros.as_bytes()).unwrap();
    assert!(scene.meshes[0].attribute(obj::TEXCOORD_W).is_none());
}

/// Two primitives whose vertices are their own (two boxes, one material each) get
/// streams of their own vertices: each POSITION accessor counts and bounds its box
/// alone, and reading back gives every corner and texture coordinate exactly. Where
/// primitives share vertices (one box, two materials: `gltf_keeps_materials_and_alpha_flags`)
/// they share the streams.
#[test]
fn gltf_primitives_with_their_own_vertices_get_their_own_streams() {
    let mut mesh = scenes::box_mesh(glam::Vec3::ZERO, glam::Vec3::ONE);
    let far = scenes::box_mesh(glam::Vec3::splat(2.0), glam::Vec3::splat(3.0));
    mesh.append(&far, &glam::Affine3A::IDENTITY, 0);
    let n = mesh.positions.len();
    let uv: Vec<[f32; 2]> = (0..n)
        .map(|v| [v as f32 / 16.0, 1.0 - v as f32 / 32.0])
        .collect();
    mesh.attributes = vec![crate::mesh::VertexAttribute::from_f32("TEXCOORD_0", &uv)];
    mesh.material_ids = (0..24).map(|t| u32::from(t >= 12)).collect();
    mesh.alpha_tested = vec![false; 24];
    let mut scene = Scene::from_mesh(mesh.clone());
    scene.materials = vec![crate::mesh::Material::default(); 2];
    let back = round_trip(&scene, "glb");
    assert_eq!(corner_bits(&back), corner_bits(&scene));
    let (got, expected) = (&back.meshes[0], &mesh);
    let uv_of = |m: &TriMesh, t: usize| {
        let a = m.attribute("TEXCOORD_0").unwrap();
        m.triangles[t].map(|v| a.vertex(v as usize))
    };
    for t in 0..24 {
        assert_eq!(uv_of(got, t), uv_of(expected, t), "triangle {t}");
    }
    let Some(Document::Gltf(document)) = back.document.as_deref() else {
        panic!("a glTF document");
    };
    let root = document.root();
    let primitives = &root.meshes[0].primitives;
    assert_eq!(primitives.len(), 2);
    for (p, low) in [(0, 0.0), (1, 2.0)] {
        let position = primitives[p].attributes
            [&::gltf::json::validation::Checked::Valid(::gltf::json::mesh::Semantic::Positions)];
        let accessor = &root.accessors[position.value()];
        assert_eq!(accessor.count.0, 8, "primitive {p}: its own 8 corners");
        let min = accessor.min.as_ref().unwrap();
        assert_eq!(min, &serde_json::json!([low, low, low]), "primitive {p}");
    }
}

//! The command-line contract of every subcommand, as scripts rely on it: the JSON keys
//! documented (each report also carries `rtmesh_version` and `schema`), exit code 0 on
//! success, 1 on a failed run with the message on standard error, 2 on a bad option
//! value with clap's message listing the choices.

use serde_json::Value;
use std::process::{Command, Output};

fn rtmesh(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rtmesh"))
        .args(args)
        .output()
        .expect("run rtmesh")
}

/// A scratch folder of this test, removed when it is dropped.
fn scratch(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("rtmesh-contract-{name}-"))
        .tempdir()
        .unwrap()
}

/// Run `args`, which must succeed, and check that stdout's JSON object (or each of its
/// lines, or the first element of its array) has exactly `keys` plus the stamp.
fn assert_keys(args: &[&str], keys: &[&str]) -> Vec<Value> {
    let out = rtmesh(args);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let values: Vec<Value> = match serde_json::from_str::<Value>(&text) {
        Ok(Value::Array(items)) => items,
        Ok(value) => vec![value],
        Err(_) => text
            .lines()
            .map(|line| serde_json::from_str(line).expect("one JSON object per line"))
            .collect(),
    };
    assert!(!values.is_empty(), "{args:?} printed no JSON");
    let mut expected: Vec<&str> = keys.to_vec();
    expected.extend(["rtmesh_version", "schema"]);
    expected.sort_unstable();
    for value in &values {
        let mut got: Vec<&str> = value
            .as_object()
            .expect("a JSON object")
            .keys()
            .map(String::as_str)
            .collect();
        got.sort_unstable();
        assert_eq!(got, expected, "{args:?}");
        assert_eq!(value["rtmesh_version"], env!("CARGO_PKG_VERSION"));
        assert_eq!(value["schema"], 1);
    }
    values
}

const TRACE_RUN: [&str; 10] = [
    "rays",
    "seconds",
    "mrays_per_s",
    "box_tests_per_ray",
    "tri_tests_per_ray",
    "pair_tests_per_ray",
    "nodes_per_ray",
    "hits",
    "hit_checksum",
    "all_seconds",
];

#[test]
fn info_convert_pair_lint_repair_keys() {
    let dir = scratch("keys");
    let info = [
        "alpha_tested_triangles",
        "boundary_edges",
        "bounds",
        "components",
        "instanced_triangles",
        "instances",
        "manifold_edges",
        "materials",
        "meshes",
        "non_finite_triangles",
        "nonmanifold_edges",
        "repeated_vertex_triangles",
        "triangles",
        "vertices",
        "welded_vertices",
        "zero_area_triangles",
        "strip_degenerates_dropped",
        "ignored_line_and_point_statements",
        "attributes",
        "triangle_attributes",
        "not_read",
        "material_names",
        "document",
        "side_files",
    ];
    assert_keys(&["info", "builtin:grid", "--json"], &info);
    let glb = dir.path().join("room.glb");
    let glb = glb.to_str().unwrap();
    assert_keys(
        &["convert", "builtin:room", glb, "--json"],
        &[
            "input",
            "output",
            "triangles",
            "vertices",
            "merged_vertices",
            "side_files",
            "written_beside",
            "embedded_images",
            "not_held",
            "not_read",
        ],
    );
    assert_keys(
        &["pair", "builtin:grid", "--json"],
        &[
            "mesh",
            "output",
            "triangles",
            "paired_triangles",
            "pair_ratio",
            "method",
            "seconds",
            "prescan_skipped",
        ],
    );
    assert_keys(
        &["lint", "builtin:cylinder", "--json"],
        &[
            "mesh",
            "triangles",
            "geometries",
            "empty_space",
            "aspect",
            "findings",
            "seconds",
        ],
    );
    let repair = assert_keys(
        &[
            "repair",
            "builtin:cylinder",
            "--size",
            "32x32",
            "--runs",
            "1",
            "--json",
        ],
        &[
            "mesh",
            "output",
            "trace",
            "triangles_in",
            "triangles_out",
            "merged_vertices",
            "removed_degenerate",
            "made_inactive",
            "removed_duplicates",
            "split_edges",
            "split_geometries",
            "split_alpha_geometries",
            "merged_groups",
            "geometries_out",
            "opaque_geometries",
            "elongated_before",
            "elongated_after",
            "wasted_box_area_before",
            "wasted_box_area_after",
            "budget_reached",
        ],
    );
    assert_eq!(repair[0]["trace"].as_array().map(Vec::len), Some(2));
    let skipped = assert_keys(
        &["repair", "builtin:cylinder", "--size", "0x0", "--json"],
        &repair[0]
            .as_object()
            .unwrap()
            .keys()
            .filter(|k| *k != "rtmesh_version" && *k != "schema")
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert!(skipped[0]["trace"].is_null());
}

#[test]
fn trace_render_demo_keys() {
    let dir = scratch("trace");
    let mut trace: Vec<&str> = TRACE_RUN.to_vec();
    trace.extend([
        "mesh",
        "ray_kind",
        "threads",
        "packet",
        "intersector",
        "bvh",
    ]);
    for extra in [
        &[][..],
        &["--leaf", "pair"],
        &["--rays", "shadow", "--packet", "4x4"],
    ] {
        let mut args = vec![
            "trace",
            "builtin:blob",
            "--size",
            "32x32",
            "--runs",
            "1",
            "--json",
        ];
        args.extend(extra);
        let value = &assert_keys(&args, &trace)[0];
        let mut bvh: Vec<&str> = value["bvh"]
            .as_object()
            .unwrap()
            .keys()
            .map(String::as_str)
            .collect();
        bvh.sort_unstable();
        assert_eq!(
            bvh,
            [
                "build_seconds",
                "bytes",
                "bytes_per_triangle",
                "depth",
                "leaves",
                "nodes",
                "sah_cost"
            ]
        );
    }
    let png = dir.path().join("blob.png");
    let png = png.to_str().unwrap();
    assert_keys(
        &[
            "render",
            "builtin:blob",
            "-o",
            png,
            "--size",
            "32x24",
            "--json",
        ],
        &["output", "width", "height", "shading"],
    );
    assert_keys(
        &[
            "render",
            "builtin:blob",
            "-o",
            png,
            "--size",
            "32x24",
            "--heatmap",
            "tris",
            "--json",
        ],
        &[
            "output",
            "width",
            "height",
            "heatmap",
            "mean_per_ray",
            "max_per_ray",
            "scale_max",
        ],
    );
    let demo_dir = dir.path().join("demo");
    let demo = assert_keys(
        &["demo", "-o", demo_dir.to_str().unwrap(), "--json"],
        &[
            "input",
            "output",
            "report",
            "pairs_file",
            "side_files",
            "not_held",
            "not_read",
            "ok",
            "error",
            "seconds",
            "target",
            "triangles_in",
            "triangles_out",
            "geometries_in",
            "geometries_out",
            "instances_out",
            "pair_ratio",
            "pairing",
            "lint",
            "repairs",
            "same_hits",
            "before",
            "after",
            "geometries",
            "histograms",
            "production",
            "step_seconds",
        ],
    );
    assert_eq!(demo.len(), 4);
}

#[test]
fn bench_keys() {
    let mut own: Vec<&str> = TRACE_RUN.to_vec();
    own.extend(["mesh", "workload", "threads", "build_seconds"]);
    let rows = assert_keys(
        &[
            "bench",
            "trace",
            "builtin:blob",
            "--size",
            "32x32",
            "--runs",
            "1",
            "--builds",
            "1",
            "--threads",
            "1",
            "--json",
        ],
        &own,
    );
    assert_eq!(rows.len(), 2, "primary and diffuse");
    let rows = assert_keys(
        &[
            "bench",
            "pairing",
            "builtin:blob",
            "--size",
            "32x32",
            "--runs",
            "1",
            "--json",
        ],
        &[
            "mesh",
            "method",
            "workload",
            "rays",
            "threads",
            "pair_seconds",
            "pair_ratio",
            "box_tests_per_ray",
            "tri_tests_per_ray",
            "pair_tests_per_ray",
            "mrays_per_s",
            "delta_box_percent",
            "delta_tests_percent",
            "delta_mrays_percent",
            "same_hits",
        ],
    );
    assert_eq!(
        rows.len(),
        2 * 4,
        "unpaired, window:2, sah, sah-max on two workloads"
    );
    let rows = assert_keys(
        &[
            "bench",
            "packets",
            "builtin:blob",
            "--size",
            "32x32",
            "--runs",
            "1",
            "--packets",
            "2x2",
            "--json",
        ],
        &[
            "mesh",
            "workload",
            "traversal",
            "rays",
            "threads",
            "seconds",
            "mrays_per_s",
            "box_tests_per_ray",
            "tri_tests_per_ray",
            "speedup",
            "same_hits_checksum",
        ],
    );
    assert_eq!(rows.len(), 3 * 2);
    let rows = assert_keys(
        &[
            "bench",
            "intersect",
            "builtin:blob",
            "--size",
            "8x8",
            "--runs",
            "1",
            "--intersectors",
            "moller,watertight",
            "--json",
        ],
        &[
            "mesh",
            "triangles",
            "rays",
            "packet",
            "intersector",
            "simd",
            "threads",
            "seconds",
            "mrays_per_s",
            "mtests_per_s",
            "speedup_over_scalar_moller_pre",
            "same_hits",
        ],
    );
    assert!(rows.len() >= 2 * 2);
}

/// Exit code 2 and clap's message, which names the option, the bad value and (for
/// enumerated options) the choices.
fn assert_rejected(args: &[&str], says: &[&str]) {
    let out = rtmesh(args);
    assert_eq!(out.status.code(), Some(2), "{args:?}");
    assert!(out.stdout.is_empty());
    let stderr = String::from_utf8_lossy(&out.stderr);
    for text in says {
        assert!(stderr.contains(text), "{args:?}: {stderr}");
    }
}

#[test]
fn bad_option_values_get_clap_errors() {
    assert_rejected(
        &["trace", "builtin:blob", "--rays", "sideways"],
        &["sideways", "primary, diffuse, shadow"],
    );
    assert_rejected(
        &["trace", "builtin:blob", "--leaf", "quad"],
        &["quad", "tri, pair"],
    );
    assert_rejected(
        &["trace", "builtin:blob", "--packet", "3x3"],
        &["3x3", "auto, none, 2x2, 4x4, 8x8"],
    );
    assert_rejected(
        &["trace", "builtin:blob", "--intersector", "fast"],
        &["fast", "moller-packet"],
    );
    assert_rejected(
        &["trace", "builtin:blob", "--size", "0x10"],
        &["0x10", "WIDTHxHEIGHT"],
    );
    assert_rejected(
        &[
            "render",
            "builtin:blob",
            "-o",
            "x.png",
            "--heatmap",
            "nodes",
        ],
        &["nodes", "boxes, tris"],
    );
    assert_rejected(
        &["pair", "builtin:grid", "--method", "window:0"],
        &["window:N"],
    );
    assert_rejected(
        &["bench", "trace", "builtin:blob", "--vs", "optix"],
        &["optix", "embree, obvhs"],
    );
    assert_rejected(
        &["bench", "packets", "builtin:blob", "--packets", "16x16"],
        &["16x16", "1x1, 2x2, 4x4, 8x8"],
    );
    assert_rejected(
        &["bench", "pairing", "builtin:blob", "--rays", "all"],
        &["all"],
    );
    assert_rejected(
        &["repair", "builtin:blob", "--force-split"],
        &["--split-elongated"],
    );
    assert_rejected(&["info"], &["<MESH>"]);
    assert_rejected(&["frobnicate"], &["frobnicate"]);
}

#[test]
fn failed_runs_exit_one_with_the_reason() {
    for args in [
        &["info", "builtin:nothing"][..],
        &["lint", "/nonexistent/mesh.obj"],
        &["pair", "/nonexistent/mesh.ply"],
        &["repair", "/nonexistent/mesh.glb"],
        &["trace", "/nonexistent/mesh.gltf"],
        &["render", "/nonexistent/mesh.obj", "-o", "x.png"],
        &["convert", "/nonexistent/mesh.obj", "x.ply"],
        &["bench", "trace", "/nonexistent/mesh.obj"],
        &["trace", "builtin:blob", "--leaf", "pair", "--packet", "4x4"],
    ] {
        let out = rtmesh(args);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.starts_with("error: "), "{args:?}: {stderr}");
        assert!(
            stderr.contains("nonexistent")
                || stderr.contains("nothing")
                || stderr.contains("--leaf tri"),
            "{args:?}: {stderr}"
        );
    }
    #[cfg(not(feature = "embree"))]
    {
        let out = rtmesh(&[
            "bench",
            "trace",
            "builtin:blob",
            "--vs",
            "embree",
            "--size",
            "8x8",
        ]);
        assert_eq!(out.status.code(), Some(1));
        assert!(String::from_utf8_lossy(&out.stderr).contains("--features embree"));
    }
}

/// The keys of `rtmesh cluster --json`.
const CLUSTER_KEYS: &[&str] = &[
    "mesh",
    "method",
    "triangles",
    "clusters",
    "mean_triangles",
    "mean_vertices_per_triangle",
    "floor_vertices_per_triangle",
    "bytes",
    "indexed_bytes",
    "disconnected",
    "seconds",
];

#[test]
fn cluster_and_dynamic_keys() {
    let clusters = assert_keys(&["cluster", "builtin:blob", "--json"], CLUSTER_KEYS);
    assert_eq!(clusters[0]["triangles"], 99892);
    let mut refined_keys = CLUSTER_KEYS.to_vec();
    refined_keys.push("refine_passes");
    let refined = assert_keys(
        &["cluster", "builtin:blob", "--refine-passes", "2", "--json"],
        &refined_keys,
    );
    assert_eq!(refined[0]["refine_passes"], 2);
    assert_eq!(refined[0]["triangles"], 99892);
    for build in ["rebuild", "refit", "clusters"] {
        let dynamic = assert_keys(
            &[
                "dynamic",
                "builtin:blob",
                "--motion",
                "twist",
                "--frames",
                "3",
                "--build",
                build,
                "--size",
                "32x32",
                "--runs",
                "1",
                "--json",
            ],
            &[
                "mesh",
                "motion",
                "build",
                "ray_kind",
                "packet",
                "triangles",
                "clusters",
                "precompute_ms",
                "arrangement",
                "frames",
                "total",
            ],
        );
        let frames = dynamic[0]["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 3);
        for key in [
            "frame",
            "build_ms",
            "trace_ms",
            "mrays_per_s",
            "box_tests_per_ray",
            "tri_tests_per_ray",
            "sah_cost",
            "hit_checksum",
        ] {
            assert!(frames[0].get(key).is_some(), "{build}: {key}");
        }
    }
    // Several builds in turn: one line a build, against the first; on the blob every
    // rtmesh build hits what the rebuild hits.
    let several = "dynamic builtin:blob --motion explode --frames 3 --build rebuild,refit,clusters --rounds 2 --size 32x32 --runs 1 --json";
    let sides = assert_keys(
        &several.split(' ').collect::<Vec<_>>(),
        &[
            "mesh",
            "motion",
            "build",
            "rounds",
            "build_ms",
            "build_speedup",
            "trace_ms",
            "trace_speedup",
            "same_hits",
        ],
    );
    let builds: Vec<&str> = sides.iter().map(|s| s["build"].as_str().unwrap()).collect();
    assert_eq!(builds, ["rebuild", "refit", "clusters"]);
    for side in &sides {
        assert_eq!(side["rounds"], 2);
        assert_eq!(side["trace_ms"].as_array().unwrap().len(), 3);
        assert_eq!(side["same_hits"], 1.0, "{side}");
    }
    assert_eq!(sides[0]["build_speedup"], 1.0);
    let no_frames = rtmesh(&[
        "dynamic",
        "builtin:blob",
        "--motion",
        "twist",
        "--frames",
        "0",
    ]);
    assert_eq!(no_frames.status.code(), Some(1));
    let unknown = rtmesh(&["cluster", "builtin:blob", "--method", "fancy"]);
    assert_eq!(unknown.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&unknown.stderr).contains("use grow, contract or meshopt"));
    // Contraction's and meshoptimizer's clusters: every triangle in one, within
    // MaxCount; contraction's connected.
    for method in ["contract", "meshopt"] {
        let report = assert_keys(
            &["cluster", "builtin:blob", "--method", method, "--json"],
            CLUSTER_KEYS,
        );
        assert_eq!(report[0]["triangles"], 99892);
        assert!(report[0]["mean_triangles"].as_f64().unwrap() <= 32.0);
        if method == "contract" {
            assert_eq!(report[0]["disconnected"], 0);
        }
    }
    // 8×8 primary packets over the cluster BVH hit what they hit over a rebuild.
    let checksums = |build: &str| -> Vec<u64> {
        let report = assert_keys_any(&[
            "dynamic",
            "builtin:blob",
            "--motion",
            "explode",
            "--frames",
            "3",
            "--build",
            build,
            "--packet",
            "8x8",
            "--size",
            "64x64",
            "--runs",
            "1",
            "--json",
        ]);
        assert_eq!(report["packet"], "8x8");
        let frames = report["frames"].as_array().unwrap();
        frames
            .iter()
            .map(|f| f["hit_checksum"].as_u64().unwrap())
            .collect()
    };
    assert_eq!(checksums("clusters"), checksums("rebuild"));
}

#[test]
fn strip_and_bench_strips_keys_and_files() {
    let dir = scratch("strip");
    let keys = [
        "mesh",
        "method",
        "max_length",
        "triangles",
        "strips",
        "indices",
        "indices_per_triangle",
        "mean_length",
        "restarts",
        "bytes_per_triangle",
        "seconds",
        "output",
    ];
    for (method, ext) in [("sah", "ply"), ("sah", "rts"), ("meshopt", "ply")] {
        let out = dir.path().join(format!("grid-{method}.{ext}"));
        let mut expected: Vec<&str> = keys.to_vec();
        if ext == "ply" {
            expected.push("degenerate_not_written");
        }
        if method == "meshopt" {
            expected.push("native_indices_per_triangle");
        } else {
            expected.extend(["tunnel_cuts", "partition"]);
        }
        let report = assert_keys(
            &[
                "strip",
                "builtin:grid",
                "--method",
                method,
                "-o",
                out.to_str().unwrap(),
                "--json",
            ],
            &expected,
        );
        let triangles = report[0]["triangles"].as_u64().unwrap();
        assert!(report[0]["indices_per_triangle"].as_f64().unwrap() < 1.6);
        if ext == "ply" {
            // The tristrips PLY reads back as the same number of triangles.
            let info = assert_keys_any(&["info", out.to_str().unwrap(), "--json"]);
            assert_eq!(info["triangles"].as_u64(), Some(triangles), "{info}");
        } else {
            let bytes = std::fs::read(&out).unwrap();
            assert!(bytes.starts_with(b"RTS1"));
        }
    }
    // glTF keeps the scene: the room's instances and materials, its surface whole.
    let gltf = dir.path().join("room.glb");
    let mut expected: Vec<&str> = keys.to_vec();
    expected.extend(["degenerate_not_written", "tunnel_cuts", "partition"]);
    let report = assert_keys(
        &[
            "strip",
            "builtin:room",
            "-o",
            gltf.to_str().unwrap(),
            "--json",
        ],
        &expected,
    );
    let info = assert_keys_any(&["info", gltf.to_str().unwrap(), "--json"]);
    let source = assert_keys_any(&["info", "builtin:room", "--json"]);
    assert_eq!(report[0]["degenerate_not_written"], 0);
    assert_eq!(info["triangles"], source["triangles"], "{info}");
    for key in ["meshes", "instances", "instanced_triangles"] {
        assert!(source[key].as_u64().is_some_and(|n| n > 0), "{key}");
        assert_eq!(info[key], source[key], "{key}");
    }
    let bad = dir.path().join("grid.stl");
    let out = rtmesh(&["strip", "builtin:grid", "-o", bad.to_str().unwrap()]);
    assert_eq!(
        out.status.code(),
        Some(1),
        "STL cannot hold strips: refused, not half-written"
    );
    assert!(!bad.exists());
    let rows = assert_keys(
        &[
            "bench",
            "strips",
            "builtin:grid",
            "--size",
            "16x16",
            "--runs",
            "1",
            "--json",
        ],
        &[
            "mesh",
            "method",
            "workload",
            "indices_per_triangle",
            "bytes_per_triangle",
            "total_bytes_per_triangle",
            "mrays_per_s",
            "box_tests_per_ray",
            "tri_tests_per_ray",
            "same_hits",
            "prepare_seconds",
        ],
    );
    let methods: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    for m in ["triangles", "pairs", "sah", "meshopt"] {
        assert!(methods.contains(&m), "{methods:?}");
    }
    for row in &rows {
        assert!(row["same_hits"].as_f64().unwrap() > 0.99, "{row}");
    }
}

/// Run `args`, which must succeed, and return its JSON object.
fn assert_keys_any(args: &[&str]) -> Value {
    let out = rtmesh(args);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

#[test]
fn animate_writes_every_frame_readable() {
    let dir = scratch("animate");
    let report = assert_keys(
        &[
            "animate",
            "builtin:blob",
            "--motion",
            "explode",
            "--frames",
            "3",
            "-o",
            dir.path().to_str().unwrap(),
            "--format",
            "ply",
            "--json",
        ],
        &["mesh", "motion", "frames", "files", "seconds"],
    );
    let files = report[0]["files"].as_array().unwrap();
    assert_eq!(files.len(), 3);
    let rest = assert_keys_any(&["info", "builtin:blob", "--json"]);
    let mut bounds = Vec::new();
    for file in files {
        let info = assert_keys_any(&["info", file.as_str().unwrap(), "--json"]);
        assert_eq!(info["triangles"], rest["triangles"]);
        bounds.push(info["bounds"].clone());
    }
    assert_ne!(bounds[0], bounds[2], "the last frame moved");
    let out = rtmesh(&[
        "animate",
        "builtin:blob",
        "--motion",
        "twist",
        "-o",
        dir.path().to_str().unwrap(),
        "--format",
        "xyz",
    ]);
    assert_eq!(out.status.code(), Some(1));
}

/// A skinned glTF played by `dynamic`: every build hits the same triangles in every
/// frame, and the frames move; `animate` bakes them into files that read back whole.
#[test]
fn gltf_animation_traces_and_bakes() {
    let Some(data) = rtmesh::data::mesh_data_dir() else {
        return;
    };
    let fox = data.join("animated/Fox.glb");
    let fox = fox.to_str().unwrap();
    let mut checksums = Vec::new();
    for build in ["rebuild", "refit", "clusters"] {
        let report = assert_keys_any(&[
            "dynamic", fox, "--motion", "gltf:Run", "--frames", "4", "--build", build, "--size",
            "64x64", "--runs", "1", "--json",
        ]);
        assert_eq!(report["motion"], "gltf:Run");
        assert_eq!(report["triangles"], 576);
        let sums: Vec<u64> = report["frames"]
            .as_array()
            .unwrap()
            .iter()
            .map(|f| f["hit_checksum"].as_u64().unwrap())
            .collect();
        checksums.push(sums);
    }
    assert!(checksums.windows(2).all(|w| w[0] == w[1]), "{checksums:?}");
    assert_ne!(checksums[0][0], checksums[0][1], "the fox runs");
    let dir = scratch("animate-gltf");
    let report = assert_keys_any(&[
        "animate",
        fox,
        "--motion",
        "gltf:Run",
        "--frames",
        "3",
        "-o",
        dir.path().to_str().unwrap(),
        "--json",
    ]);
    for file in report["files"].as_array().unwrap() {
        let info = assert_keys_any(&["info", file.as_str().unwrap(), "--json"]);
        assert_eq!(info["triangles"], 576);
    }
    let unknown = rtmesh(&["dynamic", fox, "--motion", "gltf:Fly", "--frames", "2"]);
    assert_eq!(unknown.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&unknown.stderr);
    assert!(
        stderr.contains("Fox.glb") && stderr.contains("Run, Survey, Walk"),
        "{stderr}"
    );
}

/// The glTF document a scene was read with.
fn gltf_document(scene: &rtmesh::Scene) -> &rtmesh::io::GltfDocument {
    match scene.document.as_deref() {
        Some(rtmesh::io::Document::Gltf(document)) => document,
        _ => panic!("read without its glTF document"),
    }
}

/// The bytes of image `i` as its document stores them (a GLB's buffer view, or the
/// file its URI names beside `path`).
fn image_bytes(document: &rtmesh::io::GltfDocument, i: usize, path: &std::path::Path) -> Vec<u8> {
    let image = &document.root().images[i];
    if let Some(uri) = &image.uri {
        return std::fs::read(path.with_file_name(uri)).unwrap();
    }
    let view = &document.root().buffer_views[image.buffer_view.unwrap().value()];
    document.view_bytes(view).to_vec()
}

/// `animate --motion gltf` bakes each frame into one geometry that keeps the source's
/// look: every triangle's material, whole (59 on BrainStem), the textures with their
/// image bytes and samplers (Fox, CesiumMan, in GLB and in .gltf with the image in its
/// `.bin`), and the texture coordinates exact corner by corner.
#[test]
fn baked_frames_keep_their_materials_and_textures() {
    let Some(data) = rtmesh::data::mesh_data_dir() else {
        return;
    };
    for (model, format) in [("BrainStem", "glb"), ("Fox", "glb"), ("CesiumMan", "gltf")] {
        let source_path = data.join(format!("animated/{model}.glb"));
        let dir = scratch("animate-looks");
        bake_frames(&source_path, 2, format, dir.path());
        let source = rtmesh::io::read(&source_path).unwrap();
        let rest = source.flatten().unwrap();
        let source_document = gltf_document(&source);
        let frame_path = dir.path().join(format!("frame-0001.{format}"));
        let frame = rtmesh::io::read(&frame_path).unwrap();
        let document = gltf_document(&frame);
        let material = |d: &rtmesh::io::GltfDocument, m: u32| {
            serde_json::to_value(&d.root().materials[m as usize]).unwrap()
        };
        assert_eq!(frame.meshes.len(), 1, "{model}: one baked geometry");
        let baked = &frame.meshes[0];
        assert_eq!(baked.triangle_count(), rest.triangle_count(), "{model}");
        for t in 0..rest.triangle_count() {
            assert_eq!(
                material(document, baked.material_ids[t]),
                material(source_document, rest.material_ids[t]),
                "{model}: triangle {t}'s material"
            );
        }
        assert_eq!(
            serde_json::to_value(&document.root().textures).unwrap(),
            serde_json::to_value(&source_document.root().textures).unwrap(),
            "{model}: textures"
        );
        assert_eq!(
            serde_json::to_value(&document.root().samplers).unwrap(),
            serde_json::to_value(&source_document.root().samplers).unwrap(),
            "{model}: samplers"
        );
        assert_eq!(
            document.root().images.len(),
            source_document.root().images.len()
        );
        for i in 0..document.root().images.len() {
            assert_eq!(
                image_bytes(document, i, &frame_path),
                image_bytes(source_document, i, &source_path),
                "{model}: image {i}"
            );
        }
        if let Some(uv) = rest.attribute("TEXCOORD_0") {
            let uv_of = |m: &rtmesh::TriMesh, a: &rtmesh::mesh::VertexAttribute, t: usize| {
                m.triangles[t].map(|v| a.vertex(v as usize))
            };
            let baked_uv = baked.attribute("TEXCOORD_0").expect("TEXCOORD_0 kept");
            for t in 0..rest.triangle_count() {
                assert_eq!(
                    uv_of(baked, baked_uv, t),
                    uv_of(&rest, uv, t),
                    "{model} {t}"
                );
            }
        }
        assert!(document.root().skins.is_empty() && document.root().animations.is_empty());
    }
}

/// `rtmesh animate SOURCE --motion gltf --frames FRAMES --format FORMAT -o DIR`, which
/// must succeed.
fn bake_frames(source: &std::path::Path, frames: usize, format: &str, dir: &std::path::Path) {
    let out = rtmesh(&[
        "animate",
        source.to_str().unwrap(),
        "--motion",
        "gltf",
        "--frames",
        &frames.to_string(),
        "--format",
        format,
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// OBJ frames of a glTF share one material library, named after the input, and one
/// copy of each image the glTF stores (before, each frame had its own library and its
/// own copy of every image: 100 frames, 100 copies).
#[test]
fn obj_frames_share_one_material_library() {
    let Some(data) = rtmesh::data::mesh_data_dir() else {
        return;
    };
    let source_path = data.join("animated/Fox.glb");
    let dir = scratch("animate-obj-library");
    bake_frames(&source_path, 3, "obj", dir.path());
    let mut written: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    written.sort();
    assert_eq!(
        written,
        [
            "Fox.mtl",
            "Fox_image0.png",
            "frame-0000.obj",
            "frame-0001.obj",
            "frame-0002.obj"
        ]
    );
    let source = rtmesh::io::read(&source_path).unwrap();
    assert_eq!(
        std::fs::read(dir.path().join("Fox_image0.png")).unwrap(),
        image_bytes(gltf_document(&source), 0, &source_path)
    );
    let library = std::fs::read_to_string(dir.path().join("Fox.mtl")).unwrap();
    assert!(library.contains(" Fox_image0.png\n"), "{library}");
    for f in 0..3 {
        let frame = std::fs::read_to_string(dir.path().join(format!("frame-000{f}.obj"))).unwrap();
        assert_eq!(
            frame
                .lines()
                .filter(|l| l.starts_with("mtllib"))
                .collect::<Vec<_>>(),
            ["mtllib Fox.mtl"],
            "frame {f}"
        );
    }
}

#[test]
fn bench_clusters_matches_counts_and_keeps_its_keys() {
    let rows = assert_keys(
        &[
            "bench",
            "clusters",
            "builtin:blob",
            "--phases",
            "0,1",
            "--json",
        ],
        &[
            "mesh",
            "method",
            "matched_to",
            "max_triangles",
            "clusters",
            "mean_triangles",
            "mean_vertices_per_triangle",
            "floor_vertices_per_triangle",
            "disconnected",
            "precompute_seconds",
            "precompute_us_per_triangle",
            "phases",
            "sah",
            "rebuild_sah",
        ],
    );
    let methods: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    assert_eq!(methods, ["grow", "meshopt", "contract", "meshopt"]);
    for pair in rows.chunks(2) {
        let (ours, theirs) = (&pair[0], &pair[1]);
        assert_eq!(theirs["matched_to"], ours["method"]);
        assert_eq!(theirs["max_triangles"].as_u64().unwrap() % 4, 0);
        let (a, b) = (
            ours["clusters"].as_f64().unwrap(),
            theirs["clusters"].as_f64().unwrap(),
        );
        assert!((a - b).abs() <= 0.25 * a, "counts {a} and {b} are near");
        for row in pair {
            let sah = row["sah"].as_array().unwrap();
            let rebuild = row["rebuild_sah"].as_array().unwrap();
            assert_eq!(sah.len(), 2);
            // A full per-triangle rebuild is the best tree these clusters can approach.
            for (s, r) in sah.iter().zip(rebuild) {
                assert!(s.as_f64().unwrap() >= 0.95 * r.as_f64().unwrap());
            }
        }
    }
}

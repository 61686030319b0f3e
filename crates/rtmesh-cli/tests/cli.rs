//! The `rtmesh` binary as scripts use it: JSON keys, exit codes, error messages.

use std::process::Command;

fn rtmesh(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_rtmesh"))
        .args(args)
        .output()
        .expect("run rtmesh")
}

fn json_of(args: &[&str]) -> serde_json::Value {
    let out = rtmesh(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("stdout is one JSON object")
}

#[test]
fn info_json_has_the_documented_keys() {
    let info = json_of(&["info", "builtin:grid", "--json"]);
    for key in [
        "vertices",
        "triangles",
        "welded_vertices",
        "bounds",
        "components",
        "boundary_edges",
        "nonmanifold_edges",
    ] {
        assert!(info.get(key).is_some(), "missing {key}");
    }
    assert_eq!(info["triangles"], 2 * 128 * 128);
    assert_eq!(info["vertices"], 129 * 129);
    assert_eq!(info["components"], 1);
    assert_eq!(info["boundary_edges"], 4 * 128);
}

#[test]
fn errors_name_file_and_line_and_exit_non_zero() {
    let dir = std::env::temp_dir().join(format!("rtmesh-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("broken.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 99\n").unwrap();
    let out = rtmesh(&["info", bad.to_str().unwrap()]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("broken.obj:5:"), "{stderr}");
    assert!(out.stdout.is_empty());

    let missing = rtmesh(&["info", "/nonexistent/mesh.ply"]);
    assert!(!missing.status.success());
    assert!(String::from_utf8_lossy(&missing.stderr).contains("/nonexistent/mesh.ply"));
    let unknown = rtmesh(&["info", "mesh.xyz"]);
    assert!(String::from_utf8_lossy(&unknown.stderr).contains("unknown mesh format"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn convert_writes_a_mesh_that_reads_back() {
    let dir = std::env::temp_dir().join(format!("rtmesh-cli-convert-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("room.glb");
    let summary = json_of(&["convert", "builtin:room", out.to_str().unwrap(), "--json"]);
    let info = json_of(&["info", out.to_str().unwrap(), "--json"]);
    assert_eq!(info["instanced_triangles"], summary["triangles"]);
    assert_eq!(info["instances"], 6);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn convert_names_what_the_format_cannot_hold_and_writes_an_obj_its_materials() {
    let dir = std::env::temp_dir().join(format!("rtmesh-cli-not-held-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let path = |name: &str| dir.join(name).to_str().unwrap().to_owned();
    json_of(&["convert", "builtin:room", &path("room.glb"), "--json"]);
    let obj = json_of(&["convert", &path("room.glb"), &path("room.obj"), "--json"]);
    assert_eq!(obj["written_beside"], serde_json::json!([path("room.mtl")]));
    // The room's six nodes place its geometries: the OBJ holds them in world space.
    assert_eq!(
        obj["not_held"],
        serde_json::json!([
            "nodes: 6 (their tree, names and transforms; the geometry is written in world space)"
        ])
    );
    let info = json_of(&["info", &path("room.obj"), "--json"]);
    assert_eq!(info["side_files"]["present"].as_array().unwrap().len(), 1);
    assert!(info["side_files"]["missing"].as_array().unwrap().is_empty());
    let out = rtmesh(&["convert", &path("room.glb"), &path("room.stl")]);
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("room.stl cannot hold, so goes without: geometries: 6 (merged")
            && stderr.contains("; materials: 1 (the format holds none)"),
        "{stderr}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn demo_optimizes_the_built_in_scenes_and_writes_the_reports() {
    let dir = std::env::temp_dir().join(format!("rtmesh-cli-demo-{}", std::process::id()));
    let out = rtmesh(&["demo", "-o", dir.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 4);
    for (line, name) in lines.iter().zip(["blob", "grid", "cylinder", "room"]) {
        assert_eq!(line["ok"], true);
        assert!(dir.join(format!("{name}.glb")).is_file());
        assert!(dir.join(format!("{name}.html")).is_file());
    }
    assert!(dir.join("index.html").is_file());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn pair_writes_pairs_first_and_reports_the_documented_keys() {
    let dir = std::env::temp_dir().join(format!("rtmesh-cli-pair-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("grid-paired.ply");
    let report = json_of(&[
        "pair",
        "builtin:grid",
        "-o",
        out.to_str().unwrap(),
        "--no-prescan",
        "--json",
    ]);
    for key in [
        "triangles",
        "paired_triangles",
        "pair_ratio",
        "method",
        "seconds",
        "prescan_skipped",
    ] {
        assert!(report.get(key).is_some(), "missing {key}");
    }
    assert_eq!(report["method"], "sah");
    assert_eq!(report["triangles"], 2 * 128 * 128);
    assert!(report["pair_ratio"].as_f64().unwrap() > 0.8, "{report}");
    // Pairing the written file again: the pre-scan sees it is already paired.
    let again = json_of(&["pair", out.to_str().unwrap(), "--json"]);
    assert_eq!(again["prescan_skipped"], true);
    let bad = rtmesh(&["pair", "builtin:grid", "--method", "window:0"]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("window:N"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn trace_with_pair_leaves_hits_what_triangle_leaves_hit() {
    let args = |leaf| {
        json_of(&[
            "trace",
            "builtin:blob",
            "--size",
            "64x64",
            "--runs",
            "1",
            "--leaf",
            leaf,
            "--json",
        ])
    };
    let (tri, pair) = (args("tri"), args("pair"));
    assert_eq!(tri["hits"], pair["hits"]);
    assert_eq!(tri["pair_tests_per_ray"], 0.0);
    assert!(pair["pair_tests_per_ray"].as_f64().unwrap() > 0.0);
    assert!(pair["bvh"]["nodes"].as_u64() < tri["bvh"]["nodes"].as_u64());
}

#[test]
fn lint_and_repair_report_and_fix_the_fan_cylinder() {
    let lint = json_of(&["lint", "builtin:cylinder", "--json"]);
    for key in [
        "triangles",
        "geometries",
        "empty_space",
        "aspect",
        "findings",
        "seconds",
    ] {
        assert!(lint.get(key).is_some(), "lint JSON lacks {key}");
    }
    let kinds: Vec<&str> = lint["findings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["kind"].as_str().unwrap())
        .collect();
    assert!(
        kinds.contains(&"elongated-triangles") && kinds.contains(&"fans"),
        "{kinds:?}"
    );
    let dir = std::env::temp_dir().join(format!("rtmesh-cli-repair-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("cylinder.ply");
    let map = dir.join("map.json");
    let repair = json_of(&[
        "repair",
        "builtin:cylinder",
        "--split-elongated",
        "--force-split",
        "-o",
        out.to_str().unwrap(),
        "--map",
        map.to_str().unwrap(),
        "--size",
        "128x128",
        "--runs",
        "1",
        "--json",
    ]);
    let triangles_out = repair["triangles_out"].as_u64().unwrap();
    assert!(triangles_out > repair["triangles_in"].as_u64().unwrap());
    let map: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&map).unwrap()).unwrap();
    assert_eq!(map["input_geometry"].as_array().unwrap().len(), 1);
    assert_eq!(
        map["input_triangle"][0].as_array().unwrap().len() as u64,
        triangles_out
    );
    let trace = repair["trace"].as_array().unwrap();
    assert_eq!(trace.len(), 2);
    for workload in trace {
        assert!(workload["box_after"].as_f64().unwrap() > 0.0);
        assert!(workload["box_before"].as_f64().unwrap() > 0.0);
    }
    let info = json_of(&["info", out.to_str().unwrap(), "--json"]);
    assert_eq!(info["triangles"].as_u64().unwrap(), triangles_out);
    std::fs::remove_dir_all(&dir).ok();
}

/// A glTF named by a bare file name from its own folder finds the `.bin` beside it.
#[test]
fn gltf_named_by_a_bare_file_name_reads_its_buffer() {
    let dir = std::env::temp_dir().join(format!("rtmesh-cli-bare-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let written = json_of(&[
        "convert",
        "builtin:room",
        dir.join("room.gltf").to_str().unwrap(),
        "--json",
    ]);
    let out = Command::new(env!("CARGO_BIN_EXE_rtmesh"))
        .current_dir(&dir)
        .args(["info", "room.gltf", "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(info["instanced_triangles"], written["triangles"]);
    std::fs::remove_dir_all(&dir).ok();
}

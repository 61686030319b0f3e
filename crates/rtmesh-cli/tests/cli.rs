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
    let unknown = rtmesh(&["info", "mesh.stl"]);
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
fn demo_runs() {
    let demo = json_of(&["demo", "--json"]);
    assert_eq!(demo.as_array().map(Vec::len), Some(4));
}

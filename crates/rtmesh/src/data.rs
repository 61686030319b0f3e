//! Where the real meshes live: `RTMESH_DATA`, else the first `shared/meshes` folder
//! beside the current directory or one of its ancestors (so `../shared/meshes` from the
//! workspace root, as from a crate folder). Tests, benchmarks and the CLI share this.

use std::path::PathBuf;

/// The mesh data folder (it holds `MANIFEST.tsv`), or `None` with a printed note when
/// there is none. With `RTMESH_REQUIRE_DATA=1` (CI) a missing folder panics instead, so
/// data tests fail loudly rather than skip.
pub fn mesh_data_dir() -> Option<PathBuf> {
    let candidates: Vec<PathBuf> = match std::env::var_os("RTMESH_DATA") {
        Some(dir) => vec![PathBuf::from(dir)],
        None => std::env::current_dir()
            .map(|cwd| {
                cwd.ancestors()
                    .map(|a| a.join("../shared/meshes"))
                    .collect()
            })
            .unwrap_or_default(),
    };
    if let Some(dir) = candidates.iter().find(|d| d.join("MANIFEST.tsv").is_file()) {
        return Some(dir.clone());
    }
    let looked = candidates
        .first()
        .map_or("(nowhere)".into(), |d| d.display().to_string());
    if std::env::var("RTMESH_REQUIRE_DATA").is_ok_and(|v| v == "1") {
        panic!("RTMESH_REQUIRE_DATA=1 but no MANIFEST.tsv at {looked} or above (set RTMESH_DATA)");
    }
    eprintln!("note: no mesh data at {looked} or above; data test skipped (set RTMESH_DATA)");
    None
}

/// The full Stanford dragon (871k triangles) when the data is present, else the
/// 100k-triangle procedural blob, with a label: the benches' large mesh.
pub fn dragon_or_blob() -> (String, crate::TriMesh) {
    let dir = mesh_data_dir().unwrap_or_default();
    match crate::io::read(&dir.join("dragon_vrip.ply")) {
        Ok(scene) => (
            "dragon_vrip (871k tris)".into(),
            scene.flatten().expect("the dragon is one mesh"),
        ),
        Err(e) => {
            eprintln!("note: {e}; using the procedural blob");
            (
                "blob (100k tris)".into(),
                crate::scenes::scan_blob(100_000, 1),
            )
        }
    }
}

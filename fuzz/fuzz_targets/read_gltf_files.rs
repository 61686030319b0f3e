//! Fuzz the glTF reader as it reads files: the input is written as `asset/fuzz.gltf`
//! beside a `asset/buffer.bin` and a canary outside the folder, then read by path, so
//! that buffer URIs resolve on the file system by the rule for references. Any bytes
//! must give a scene or an error, never a panic, and never the canary's bytes. A scene
//! read is written as GLB (its PNG and JPEG image files stored) and as OBJ (its
//! materials as an MTL library, stored images extracted beside it) into `out/` beside
//! the folder with its image files copied (`copy_side_files`); the canary is never
//! among the copies or the stored images, and nothing is written outside `out/`.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;
use std::sync::OnceLock;

/// The canary's bytes: a PNG signature, so that a GLB would store it were it ever read
/// as an image, then positions of 1e30 if anyone reads it as a buffer.
fn canary_bytes() -> Vec<u8> {
    let mut bytes = b"\x89PNG\r\n\x1a\n".to_vec();
    bytes.extend(1e30f32.to_le_bytes().repeat(64));
    bytes
}

/// The folder `…/asset` with `buffer.bin` in it and `canary.bin` beside it.
fn folder() -> &'static PathBuf {
    static FOLDER: OnceLock<PathBuf> = OnceLock::new();
    FOLDER.get_or_init(|| {
        let root = std::env::temp_dir().join(format!("rtmesh-fuzz-gltf-{}", std::process::id()));
        let asset = root.join("asset");
        std::fs::create_dir_all(&asset).unwrap();
        let corners: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
            .iter()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        std::fs::write(asset.join("buffer.bin"), corners).unwrap();
        std::fs::write(root.join("canary.bin"), canary_bytes()).unwrap();
        asset
    })
}

fuzz_target!(|data: &[u8]| {
    let path = folder().join("fuzz.gltf");
    std::fs::write(&path, data).unwrap();
    if let Ok(scene) = rtmesh::io::read(&path) {
        let canary = 1e30f32;
        assert!(
            scene
                .meshes
                .iter()
                .flat_map(|m| &m.positions)
                .all(|p| p.x != canary),
            "the canary outside the asset's folder was read"
        );
        let _ = rtmesh::mesh::MeshInfo::of(&scene);
        let out = folder().parent().unwrap().join("out");
        let _ = std::fs::remove_dir_all(&out);
        std::fs::create_dir_all(&out).unwrap();
        let options = rtmesh::io::ReadOptions::default();
        for output in [out.join("fuzz.glb"), out.join("fuzz.obj")] {
            let mut images = Vec::new();
            if let Ok(copies) = rtmesh::io::copy_side_files(&path, &scene, &output, &options) {
                for copy in &copies.copied {
                    assert!(copy.starts_with(&out), "{copies:?}");
                    let bytes = std::fs::read(copy).unwrap();
                    assert_ne!(bytes, canary_bytes(), "the canary was copied");
                }
                for (name, bytes) in &copies.images {
                    assert_ne!(*bytes, canary_bytes(), "{name} is the canary");
                }
                images = copies.images;
            }
            if let Ok(notes) = rtmesh::io::write_with_images(&scene, &output, &images) {
                let beside = &notes.written_beside;
                assert!(beside.iter().all(|f| f.starts_with(&out)), "{beside:?}");
            }
        }
    }
});

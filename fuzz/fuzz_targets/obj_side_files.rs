//! Fuzz an OBJ with its material library as files, written elsewhere: the input is an
//! OBJ and, after the first NUL byte, the MTL library `fuzz.mtl` beside it, in a folder
//! that also holds a texture `tex/a.png`, with a canary file outside it. The scene is
//! read by path, written as OBJ and as GLB into `out/`, and its side files copied
//! there (the GLB stores its PNG textures). Any bytes must give a result or an error,
//! never a panic; the canary is never copied nor stored, and nothing is written
//! outside `out/`.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A PNG's signature first, so that a GLB would store it if it were ever read.
const CANARY: &[u8] = b"\x89PNG\r\n\x1a\ncanary: never copied";

/// The folder `…/asset` with `tex/a.png` in it and `canary.png` beside it.
fn folder() -> &'static PathBuf {
    static FOLDER: OnceLock<PathBuf> = OnceLock::new();
    FOLDER.get_or_init(|| {
        let root = std::env::temp_dir().join(format!("rtmesh-fuzz-obj-{}", std::process::id()));
        let asset = root.join("asset");
        std::fs::create_dir_all(asset.join("tex")).unwrap();
        std::fs::write(asset.join("tex/a.png"), b"\x89PNG\r\n\x1a\na texture").unwrap();
        std::fs::write(root.join("canary.png"), CANARY).unwrap();
        asset
    })
}

/// Every file under `dir`, recursively.
fn files(dir: &Path, found: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if path.is_dir() {
            files(&path, found);
        } else {
            found.push(path);
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let asset = folder();
    let root = asset.parent().unwrap();
    let (obj, mtl) = match data.iter().position(|&b| b == 0) {
        Some(at) => (&data[..at], Some(&data[at + 1..])),
        None => (data, None),
    };
    let path = asset.join("fuzz.obj");
    std::fs::write(&path, obj).unwrap();
    let library = asset.join("fuzz.mtl");
    match mtl {
        Some(mtl) => std::fs::write(&library, mtl).unwrap(),
        None => {
            let _ = std::fs::remove_file(&library);
        }
    }
    let out = root.join("out");
    let _ = std::fs::remove_dir_all(&out);
    std::fs::create_dir_all(&out).unwrap();
    let options = rtmesh::io::ReadOptions::default();
    if let Ok(scene) = rtmesh::io::read_with(&path, &options, &mut |_, _| {}) {
        for name in ["fuzz.obj", "fuzz.glb"] {
            let output = out.join(name);
            let copies = rtmesh::io::copy_side_files(&path, &scene, &output, &options);
            let images = match copies {
                Ok(copies) => {
                    assert!(
                        copies.copied.iter().all(|c| c.starts_with(&out)),
                        "{copies:?}"
                    );
                    copies.images
                }
                Err(_) => Vec::new(),
            };
            let _ = rtmesh::io::write_with_images(&scene, &output, &images);
        }
    }
    let mut written = Vec::new();
    files(&out, &mut written);
    // The fuzzer learns the canary's bytes from the comparisons below; an input that
    // holds them itself is copied with them rightly.
    let holds_canary = |bytes: &[u8]| bytes.windows(CANARY.len()).any(|w| w == CANARY);
    for file in written.iter().filter(|_| !holds_canary(data)) {
        let bytes = std::fs::read(file).unwrap();
        assert!(
            !holds_canary(&bytes),
            "{} holds the canary",
            file.display()
        );
    }
    // Only asset/, out/ and the canary beside them.
    let mut beside: Vec<_> = std::fs::read_dir(root)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    beside.sort();
    assert_eq!(
        beside,
        ["asset", "canary.png", "out"],
        "a file was written outside out/"
    );
});

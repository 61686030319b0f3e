//! Fuzz the STL reader: any bytes must give a scene or an error, never a panic or a hang.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(scene) = rtmesh::io::read_bytes(std::path::Path::new("fuzz.stl"), data) {
        // Whatever was read must be usable downstream.
        let _ = rtmesh::mesh::MeshInfo::of(&scene);
    }
});

//! Fuzz the gltf reader and its animation: any bytes must give a scene or an error, never
//! a panic or a hang.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(scene) = rtmesh::io::read_bytes(std::path::Path::new("fuzz.glb"), data) {
        // Whatever was read must be usable downstream.
        let _ = rtmesh::mesh::MeshInfo::of(&scene);
        // Its animation, if any, must play or be refused.
        let gltf = rtmesh::animate::Motion::Gltf(None);
        if let Ok((_, animation)) = rtmesh::animate::Animation::of(&scene, &gltf) {
            let _ = animation.positions(0.5);
        }
        // And written back, every attribute with it (glTF from its document).
        let out = std::env::temp_dir().join(format!("rtmesh-fuzz-{}.glb", std::process::id()));
        let _ = rtmesh::io::write(&scene, &out);
    }
});

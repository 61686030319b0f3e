//! With the `embree` feature, compile `src/embree/layout.c`: the sizes and offsets of
//! the structs the FFI declares, as Embree's own header lays them out, for the tests
//! in `src/embree/layout.rs` to hold the Rust declarations to.
fn main() {
    #[cfg(feature = "embree")]
    {
        println!("cargo:rerun-if-changed=src/embree/layout.c");
        cc::Build::new()
            .file("src/embree/layout.c")
            .compile("rtmesh_embree_layout");
    }
}

//! Memory in proportion to the input: every reader's peak allocation while reading a
//! file stays within [`MAX_BYTES_PER_FILE_BYTE`] times the file's size plus
//! [`BASE_BYTES`], measured with a counting allocator, on crafted files of each
//! format (soups, fans, copies) and on files that lie about their size.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use std::sync::Mutex;

/// The stated bound: peak bytes allocated while reading, per byte of the file (and of
/// the files it refers to). The worst case is OBJ's shortest faces: `f 1 2 3` takes 8
/// bytes, and tobj holds about 80 bytes per face while it parses, beside the mesh.
const MAX_BYTES_PER_FILE_BYTE: usize = 24;
/// The stated bound's constant part.
const BASE_BYTES: usize = 16 << 20;

struct Counting;
static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator, only counting.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let now = CURRENT.fetch_add(layout.size(), Relaxed) + layout.size();
        PEAK.fetch_max(now, Relaxed);
        // SAFETY: the caller's layout, as the trait requires.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        CURRENT.fetch_sub(layout.size(), Relaxed);
        // SAFETY: as allocated above.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// One measurement at a time: the counters are process-wide.
static SERIAL: Mutex<()> = Mutex::new(());

/// Peak bytes allocated (above what was live before) while reading `path`.
fn peak_reading(path: &Path) -> (usize, bool) {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let before = CURRENT.load(Relaxed);
    PEAK.store(before, Relaxed);
    let read = rtmesh::io::read(path).is_ok();
    (PEAK.load(Relaxed) - before, read)
}

fn assert_bounded(path: &Path) {
    let bytes = |p: &Path| std::fs::metadata(p).map_or(0, |m| m.len() as usize);
    let mut size = bytes(path);
    if path.extension().is_some_and(|e| e == "gltf") {
        // rtmesh writes a .gltf's buffer beside it, with the same stem.
        size += bytes(&path.with_extension("bin"));
    }
    let (peak, _) = peak_reading(path);
    let bound = MAX_BYTES_PER_FILE_BYTE * size + BASE_BYTES;
    assert!(
        peak <= bound,
        "{}: {peak} bytes at the peak for a {size}-byte file (bound {bound})",
        path.display()
    );
    eprintln!(
        "{}: {size} bytes, peak {peak} ({:.1}x + base)",
        path.display(),
        peak as f64 / size as f64
    );
}

#[test]
fn every_reader_allocates_in_proportion_to_the_file() {
    let dir = std::env::temp_dir().join(format!("rtmesh-memory-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A 200,000-triangle fan, written by rtmesh in every format it writes.
    let n = 200_000u32;
    let mut positions = vec![glam::Vec3::ZERO];
    positions.extend((0..n).map(|k| {
        let a = std::f32::consts::TAU * k as f32 / n as f32;
        glam::Vec3::new(a.cos(), a.sin(), 0.0)
    }));
    let triangles = (0..n).map(|k| [0, 1 + k, 1 + (k + 1) % n]).collect();
    let fan = rtmesh::Scene::from_mesh(rtmesh::TriMesh::new(positions, triangles));
    for extension in ["obj", "ply", "glb", "gltf", "stl"] {
        let path = dir.join(format!("fan.{extension}"));
        rtmesh::io::write(&fan, &path).unwrap();
        assert_bounded(&path);
    }
    // A million copies of one triangle (the smallest bytes per triangle OBJ allows).
    let copies = dir.join("copies.obj");
    std::fs::write(
        &copies,
        format!(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\n{}",
            "f 1 2 3\n".repeat(1_000_000)
        ),
    )
    .unwrap();
    assert_bounded(&copies);
    // Headers that claim far more than the file holds.
    let lying = [
        ("lying.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n".to_vec()),
        ("lying.stl", {
            let mut bytes = vec![b' '; 80];
            bytes.extend(4_000_000_000u32.to_le_bytes());
            bytes.extend([0u8; 50]);
            bytes
        }),
    ];
    for (name, bytes) in lying {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let (peak, read) = peak_reading(&path);
        assert!(
            !read && peak <= BASE_BYTES,
            "{name}: read {read}, peak {peak}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

//! Procedural scenes for tests, benchmarks and the built-in demo. All are deterministic.
//!
//! - [`scan_blob`]: a closed, bumpy, irregularly triangulated surface, like a 3D scan.
//! - [`rotated_grid`]: a quad grid turned 45° about Z and triangulated: every edge is
//!   diagonal to the axes, the case the pairing paper uses.
//! - [`fan_cylinder`]: a closed cylinder whose caps are triangle fans and whose sides are
//!   long thin triangles, the shapes NVIDIA's mesh advice warns about.
//! - [`room`]: a small multi-object scene (several geometries, one instanced twice).

use crate::mesh::{Scene, TriMesh};
use crate::random::SplitMix64;
use glam::{Affine3A, Quat, Vec3};
use std::f32::consts::{PI, TAU};

/// Names accepted by [`by_name`].
pub const NAMES: [&str; 4] = ["blob", "grid", "cylinder", "room"];

/// A built-in scene by name (see [`NAMES`]) at its default size.
pub fn by_name(name: &str) -> Option<Scene> {
    match name {
        "blob" => Some(Scene::from_mesh(scan_blob(100_000, 1))),
        "grid" => Some(Scene::from_mesh(rotated_grid(128))),
        "cylinder" => Some(Scene::from_mesh(fan_cylinder(256))),
        "room" => Some(room()),
        _ => None,
    }
}

/// A latitude–longitude sphere of `rings` interior rings of `segments` vertices each, plus
/// two poles, with the vertex at (ring, segment) placed by `place(latitude, longitude)`
/// (both in radians) and each quad's diagonal chosen by `flip(ring, segment)`.
fn latitude_longitude(
    rings: usize,
    segments: usize,
    mut place: impl FnMut(f32, f32) -> Vec3,
    mut flip: impl FnMut(usize, usize) -> bool,
) -> TriMesh {
    let mut positions = vec![place(-PI / 2.0, 0.0)];
    for r in 0..rings {
        let latitude = -PI / 2.0 + PI * (r + 1) as f32 / (rings + 1) as f32;
        for s in 0..segments {
            positions.push(place(latitude, TAU * s as f32 / segments as f32));
        }
    }
    positions.push(place(PI / 2.0, 0.0));
    let north = (positions.len() - 1) as u32;
    let at = |r: usize, s: usize| (1 + r * segments + s % segments) as u32;
    let mut triangles = Vec::with_capacity(2 * segments * rings);
    for s in 0..segments {
        triangles.push([0, at(0, s + 1), at(0, s)]);
        triangles.push([north, at(rings - 1, s), at(rings - 1, s + 1)]);
    }
    for r in 0..rings - 1 {
        for s in 0..segments {
            let (a, b, c, d) = (at(r, s), at(r, s + 1), at(r + 1, s + 1), at(r + 1, s));
            if flip(r, s) {
                triangles.push([a, b, d]);
                triangles.push([b, c, d]);
            } else {
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
    }
    TriMesh::new(positions, triangles)
}

/// A closed, bumpy surface of about `target_triangles` triangles with an irregular
/// triangulation (jittered vertices, random diagonals), like a scanned object.
pub fn scan_blob(target_triangles: usize, seed: u64) -> TriMesh {
    let segments = ((target_triangles as f32).sqrt() * 1.4).max(6.0) as usize;
    let rings = (target_triangles / (2 * segments)).max(2);
    let mut rng = SplitMix64::new(seed);
    let mut jitter = SplitMix64::new(seed ^ 0xA5A5);
    let ring_step = PI / (rings + 1) as f32;
    let segment_step = TAU / segments as f32;
    latitude_longitude(
        rings,
        segments,
        |lat, lon| {
            let (lat, lon) = if lat.abs() < PI / 2.0 {
                (
                    lat + (jitter.next_f32() - 0.5) * 0.4 * ring_step,
                    lon + (jitter.next_f32() - 0.5) * 0.4 * segment_step,
                )
            } else {
                (lat, lon)
            };
            let direction = Vec3::new(lat.cos() * lon.cos(), lat.sin(), lat.cos() * lon.sin());
            let bumps = 0.12 * (3.0 * lon).sin() * (2.0 * lat).cos()
                + 0.05 * (7.0 * lon + 1.0).sin() * (5.0 * lat).sin()
                + 0.02 * (17.0 * lon).cos() * (13.0 * lat + 0.5).sin();
            direction * Vec3::new(1.0, 1.3, 0.8) * (1.0 + bumps)
        },
        |_, _| rng.next_u64() & 1 == 1,
    )
}

/// A UV sphere of radius 1 (closed), `rings` × `segments`.
pub fn uv_sphere(rings: usize, segments: usize) -> TriMesh {
    latitude_longitude(
        rings,
        segments,
        |lat, lon| Vec3::new(lat.cos() * lon.cos(), lat.sin(), lat.cos() * lon.sin()),
        |_, _| false,
    )
}

/// An `n` × `n` grid of unit quads in the XY plane, corner at the origin, axis-aligned,
/// each quad split along the same diagonal.
pub fn quad_grid(n: usize) -> TriMesh {
    let side = n + 1;
    let positions = (0..side * side)
        .map(|i| Vec3::new((i % side) as f32, (i / side) as f32, 0.0))
        .collect();
    let mut triangles = Vec::with_capacity(2 * n * n);
    for y in 0..n {
        for x in 0..n {
            let a = (y * side + x) as u32;
            let (b, c, d) = (a + 1, a + 1 + side as u32, a + side as u32);
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    TriMesh::new(positions, triangles)
}

/// An `n` × `n` grid of unit quads in the XY plane, centred, turned 45° about Z, each
/// quad split along the same diagonal.
pub fn rotated_grid(n: usize) -> TriMesh {
    let rotation = Quat::from_rotation_z(PI / 4.0);
    let centre = Vec3::new(n as f32 / 2.0, n as f32 / 2.0, 0.0);
    let mut grid = quad_grid(n);
    for p in &mut grid.positions {
        *p = rotation * (*p - centre);
    }
    grid
}

/// A closed cylinder of radius 1 and height 4 along Y with `segments` sides: caps are
/// fans around a centre vertex, sides are one row of long thin triangles.
pub fn fan_cylinder(segments: usize) -> TriMesh {
    let mut positions = vec![Vec3::new(0.0, -2.0, 0.0), Vec3::new(0.0, 2.0, 0.0)];
    for y in [-2.0, 2.0] {
        for s in 0..segments {
            let angle = TAU * s as f32 / segments as f32;
            positions.push(Vec3::new(angle.cos(), y, angle.sin()));
        }
    }
    let bottom = |s: usize| (2 + s % segments) as u32;
    let top = |s: usize| (2 + segments + s % segments) as u32;
    let mut triangles = Vec::with_capacity(4 * segments);
    for s in 0..segments {
        triangles.push([0, bottom(s), bottom(s + 1)]);
        triangles.push([1, top(s + 1), top(s)]);
        triangles.push([bottom(s), top(s), top(s + 1)]);
        triangles.push([bottom(s), top(s + 1), bottom(s + 1)]);
    }
    TriMesh::new(positions, triangles)
}

/// A closed axis-aligned box with outward-facing triangles.
pub fn box_mesh(min: Vec3, max: Vec3) -> TriMesh {
    let positions = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            )
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let triangles = quads
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    TriMesh::new(positions, triangles)
}

/// A small room: floor, walls, a table and two instances of one sphere.
pub fn room() -> Scene {
    let mut scene = Scene::default();
    scene.materials.push(crate::mesh::Material::default());
    let named = |name: &str, mut mesh: TriMesh| {
        mesh.name = name.to_owned();
        mesh
    };
    let identity = Affine3A::IDENTITY;
    scene.push_mesh(
        named("floor", rotated_grid(16)),
        Affine3A::from_rotation_x(-PI / 2.0),
    );
    scene.push_mesh(
        named(
            "back wall",
            box_mesh(Vec3::new(-8.0, 0.0, -8.5), Vec3::new(8.0, 6.0, -8.0)),
        ),
        identity,
    );
    scene.push_mesh(
        named(
            "left wall",
            box_mesh(Vec3::new(-8.5, 0.0, -8.0), Vec3::new(-8.0, 6.0, 8.0)),
        ),
        identity,
    );
    let mut table = box_mesh(Vec3::new(-2.0, 1.0, -1.0), Vec3::new(2.0, 1.2, 1.0));
    for (x, z) in [(-1.8, -0.8), (1.6, -0.8), (-1.8, 0.6), (1.6, 0.6)] {
        let leg = box_mesh(Vec3::new(x, 0.0, z), Vec3::new(x + 0.2, 1.0, z + 0.2));
        table.append(&leg, &identity, 0);
    }
    scene.push_mesh(named("table", table), identity);
    let ball = scene.push_mesh(
        named("ball", uv_sphere(24, 48)),
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.5),
            Quat::IDENTITY,
            Vec3::new(-1.0, 1.7, 0.0),
        ),
    );
    scene.instances.push(crate::mesh::Instance::new(
        ball,
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.8),
            Quat::IDENTITY,
            Vec3::new(4.0, 0.8, 3.0),
        ),
    ));
    scene
}

/// Random meshes for property tests: 4 to 23 vertices in a cube, 1 to 59 triangles of
/// any three of them (non-manifold, disconnected, with repeated vertices).
#[cfg(test)]
pub(crate) fn arbitrary_mesh() -> impl proptest::strategy::Strategy<Value = TriMesh> {
    use proptest::prelude::*;
    (4usize..24).prop_flat_map(|v| {
        (
            proptest::collection::vec(
                (-4.0f32..4.0, -4.0f32..4.0, -4.0f32..4.0)
                    .prop_map(|(x, y, z)| glam::Vec3::new(x, y, z)),
                v,
            ),
            proptest::collection::vec([0..v as u32, 0..v as u32, 0..v as u32], 1..60),
        )
            .prop_map(|(positions, triangles)| TriMesh::new(positions, triangles))
    })
}

/// A 20 × 20 quad grid with the triangles `holes` (modulo its 800) taken out, for
/// property tests.
#[cfg(test)]
pub(crate) fn grid_with_holes(holes: &[usize]) -> TriMesh {
    let mut mesh = quad_grid(20);
    let mut keep = vec![true; mesh.triangle_count()];
    let n = keep.len();
    for h in holes {
        keep[h % n] = false;
    }
    let mut k = keep.iter();
    mesh.triangles.retain(|_| *k.next().unwrap());
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{connected_components, validate, EdgeAdjacency};
    use proptest::prelude::*;

    /// Closed manifold genus-0 mesh: every edge has two triangles, V − E + F = 2.
    fn assert_closed_sphere(mesh: &TriMesh) {
        assert!(validate(mesh).is_clean());
        let adjacency = EdgeAdjacency::build(mesh);
        let (v, e, f) = (
            mesh.positions.len() as i64,
            adjacency.edges.len() as i64,
            mesh.triangle_count() as i64,
        );
        assert_eq!(
            adjacency.manifold_edge_count() as i64,
            e,
            "every edge has two triangles"
        );
        assert_eq!(2 * e, 3 * f);
        assert_eq!(v - e + f, 2, "Euler characteristic of a sphere");
        assert_eq!(connected_components(&adjacency).1, 1);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        #[test]
        fn blobs_are_closed_spheres(target in 20usize..5_000, seed in any::<u64>()) {
            assert_closed_sphere(&scan_blob(target, seed));
        }

        #[test]
        fn spheres_and_cylinders_are_closed(rings in 2usize..30, segments in 3usize..60) {
            assert_closed_sphere(&uv_sphere(rings, segments));
            assert_closed_sphere(&fan_cylinder(segments));
        }

        #[test]
        fn grid_satisfies_euler_for_a_disk(n in 1usize..40) {
            let mesh = rotated_grid(n);
            let adjacency = EdgeAdjacency::build(&mesh);
            let (v, e, f) = (mesh.positions.len() as i64, adjacency.edges.len() as i64, mesh.triangle_count() as i64);
            prop_assert_eq!(v - e + f, 1);
            prop_assert_eq!(adjacency.boundary_edge_count(), 4 * n);
        }
    }

    #[test]
    fn boxes_and_the_default_scenes() {
        assert_closed_sphere(&box_mesh(Vec3::ZERO, Vec3::ONE));
        let blob = scan_blob(100_000, 1);
        assert!(
            (95_000..105_000).contains(&blob.triangle_count()),
            "{}",
            blob.triangle_count()
        );
        for name in NAMES {
            assert!(by_name(name).unwrap().instanced_triangle_count() > 0);
        }
        let room = room();
        assert!(room.meshes.len() >= 4);
        assert!(
            room.instances.len() > room.meshes.len(),
            "one mesh is instanced twice"
        );
    }
}

//! Duplicate triangles: triangles whose three corners are those of an earlier
//! triangle (same positions, compared bit for bit after welding).
//!
//! A copy with the same winding is a pure cost: every ray that reaches it tests it
//! again, and it hides nothing the original does not. A copy with the opposite winding
//! (back to back) is the usual way to make a surface two-sided for a rasteriser with
//! back-face culling; a ray tracer with culling off needs only one of the two.
//!
//! Each usable triangle (valid indices, finite corners, three distinct welded
//! vertices) is keyed by its welded vertices sorted, which are equal between any two
//! triangles on the same corners; one sort of the keys groups the copies. Within a
//! group, the vertices rotated to start at the smallest are equal when the winding is.
//! Cost: O(T log T) for the sort, plus the exact weld; 16 bytes per triangle.

use super::{has_edges, TriMesh};
use rayon::prelude::*;

/// The copies in a mesh, by triangle id (ascending).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Duplicates {
    /// Triangles with the corners and winding of an earlier triangle.
    pub repeated: Vec<u32>,
    /// Triangles with the corners of an earlier triangle but the opposite winding,
    /// and no earlier triangle with their own winding (the back of a two-sided
    /// surface).
    pub back_to_back: Vec<u32>,
}

/// The duplicate triangles of `mesh`.
pub fn duplicates(mesh: &TriMesh) -> Duplicates {
    let welded = mesh.topology();
    // The corners rotated to start at the smallest: equal when the winding is.
    let rotated = |t: usize| super::smallest_first(welded.triangles[t]);
    // Per usable triangle, its corners sorted then its id, in one integer.
    let mut keys: Vec<u128> = welded
        .triangles
        .par_iter()
        .enumerate()
        .filter_map(|(t, &tri)| {
            let usable =
                has_edges(&tri, welded.positions.len()) && welded.finite_corners(t).is_some();
            usable.then(|| {
                let mut sorted = tri;
                sorted.sort_unstable();
                (sorted[0] as u128) << 96
                    | (sorted[1] as u128) << 64
                    | (sorted[2] as u128) << 32
                    | t as u128
            })
        })
        .collect();
    keys.par_sort_unstable();
    let mut found = Duplicates::default();
    for group in keys.chunk_by(|a, b| a >> 32 == b >> 32) {
        // Corners have two windings: the first triangle's, and the other, once seen.
        let winding = rotated(group[0] as u32 as usize);
        let mut other_seen = false;
        for &key in &group[1..] {
            let t = key as u32;
            if rotated(t as usize) == winding || other_seen {
                found.repeated.push(t);
            } else {
                other_seen = true;
                found.back_to_back.push(t);
            }
        }
    }
    found.repeated.sort_unstable();
    found.back_to_back.sort_unstable();
    found
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn finds_copies_by_position_and_winding() {
        // Vertex 4 repeats vertex 1's position: triangle 3 names it and is still a copy.
        let positions = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            Vec3::X,
            Vec3::new(f32::NAN, 0.0, 0.0),
        ];
        let triangles = vec![
            [0, 1, 2], // 0: original
            [1, 2, 0], // 1: same corners, same winding (rotated)
            [0, 2, 1], // 2: back to back with 0
            [2, 0, 4], // 3: same as 0 through the welded vertex
            [0, 1, 3], // 4: shares an edge only
            [2, 1, 0], // 5: same winding as 2, a later copy of it
            [0, 1, 1], // 6: degenerate: not a copy of anything
            [0, 1, 1], // 7: degenerate
            [0, 1, 5], // 8: inactive
            [0, 1, 5], // 9: inactive
        ];
        let found = duplicates(&TriMesh::new(positions, triangles));
        assert_eq!(found.repeated, vec![1, 3, 5]);
        assert_eq!(found.back_to_back, vec![2]);
    }

    #[test]
    fn a_clean_mesh_has_none() {
        let mesh = crate::scenes::uv_sphere(12, 16);
        assert_eq!(duplicates(&mesh), Duplicates::default());
    }
}

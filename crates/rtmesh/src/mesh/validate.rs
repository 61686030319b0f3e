//! Mesh validation: which triangles are broken, and how.
//!
//! One pass over the triangles, O(T). A triangle is listed under every problem it has,
//! in triangle order, so callers can report counts and the offenders.

use super::TriMesh;
use serde::Serialize;

/// Triangles with each kind of problem (triangle indices, ascending).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Validation {
    /// Triangles with an index past the end of `positions`.
    pub out_of_range_indices: Vec<u32>,
    /// Triangles with a NaN or infinite corner (NaN is DXR's "inactive" triangle).
    pub non_finite_positions: Vec<u32>,
    /// Triangles that name one vertex twice or three times.
    pub repeated_vertices: Vec<u32>,
    /// Triangles with distinct indices whose corners span zero area (collinear or
    /// coincident points).
    pub zero_area: Vec<u32>,
}

impl Validation {
    /// Degenerate triangles (repeated vertices or zero area), ascending.
    pub fn degenerate(&self) -> Vec<u32> {
        let mut all: Vec<u32> = self
            .repeated_vertices
            .iter()
            .chain(&self.zero_area)
            .copied()
            .collect();
        all.sort_unstable();
        all
    }

    /// True when no problem was found.
    pub fn is_clean(&self) -> bool {
        self.out_of_range_indices.is_empty()
            && self.non_finite_positions.is_empty()
            && self.repeated_vertices.is_empty()
            && self.zero_area.is_empty()
    }
}

/// Check every triangle of `mesh`.
pub fn validate(mesh: &TriMesh) -> Validation {
    let mut report = Validation::default();
    let n = mesh.positions.len() as u64;
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let t = t as u32;
        if tri.iter().any(|&v| v as u64 >= n) {
            report.out_of_range_indices.push(t);
            continue;
        }
        let [a, b, c] = tri.map(|v| mesh.positions[v as usize]);
        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
            report.non_finite_positions.push(t);
            continue;
        }
        if super::names_a_vertex_twice(*tri) {
            report.repeated_vertices.push(t);
            continue;
        }
        // Exact zero test in f32 as the tracer would see it: the cross product of the
        // edges, computed with the same operations the intersectors use.
        if (b - a).cross(c - a) == glam::Vec3::ZERO {
            report.zero_area.push(t);
        }
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn finds_each_planted_problem_once() {
        let positions = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(f32::NAN, 0.0, 0.0),
        ];
        let mesh = TriMesh::new(
            positions,
            vec![
                [0, 1, 2], // fine
                [0, 1, 9], // out of range
                [0, 1, 4], // NaN
                [0, 0, 2], // repeated
                [0, 1, 3], // collinear
            ],
        );
        let v = validate(&mesh);
        assert_eq!(v.out_of_range_indices, vec![1]);
        assert_eq!(v.non_finite_positions, vec![2]);
        assert_eq!(v.repeated_vertices, vec![3]);
        assert_eq!(v.zero_area, vec![4]);
        assert!(!v.is_clean());
    }
}

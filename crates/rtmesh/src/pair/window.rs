//! Window-N pairing over the input order: the baseline of Aman & Fenney, "Fast Triangle
//! Pairing for Ray Tracing" (Imagination, HPG 2024), and what a tool that pairs while
//! streaming triangles does.
//!
//! Each free triangle, in input order, takes the free pairable triangle among the next
//! `N` whose pair box has the smallest surface area (the earliest on ties). Cost:
//! O(T · N) time, no extra memory beyond the partner array.

use super::{shared_side, triangle_box, ActiveTriangles, Pairing, UNPAIRED};
use crate::mesh::TriMesh;

/// Window-`window` pairing (`window ≥ 1`).
pub fn pair_window(mesh: &TriMesh, window: usize) -> Pairing {
    let n = mesh.triangle_count();
    let active = ActiveTriangles::new(mesh);
    let mut partner = vec![UNPAIRED; n];
    for a in 0..n {
        if partner[a] != UNPAIRED || !active.get(a) {
            continue;
        }
        let box_a = triangle_box(mesh, a);
        let best = (a + 1..n.min(a + 1 + window))
            .filter(|&b| {
                partner[b] == UNPAIRED
                    && active.get(b)
                    && shared_side(&mesh.triangles[a], &mesh.triangles[b]).is_some()
            })
            .map(|b| (box_a.union(triangle_box(mesh, b)).half_area(), b))
            .min_by(|x, y| x.0.total_cmp(&y.0));
        if let Some((_, b)) = best {
            partner[a] = b as u32;
            partner[b] = a as u32;
        }
    }
    Pairing::from_partners(&partner)
}

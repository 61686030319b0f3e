//! Iterative growing of precomputed triangle clusters (Garanzha, EGSR 2009; the
//! acceptance heuristic Acc(k) is in the module header of `cluster`): a cluster starts
//! at the first triangle not yet taken, in Morton order over the centroids so that
//! clusters tile the surface, and takes, one at a time, the neighbour across an edge
//! whose Acc of the grown set is largest, while it is positive. The slides prefer it to
//! contraction for its memory: one growing set and its frontier at a time.
//!
//! Cost: O(T · F · |k|) for F candidates on a cluster's frontier (tens) and |k| the
//! cluster's size (Acc(k ∪ t) walks k's vertices and normals).

use super::{
    acceptance, edge_neighbours, finish, morton_order, prepare, ClusterSettings, Clusters, Set,
    Summary,
};
use crate::mesh::TriMesh;
use glam::Vec3;

/// Triangle `t` as a one-triangle [`Summary`], its distinct vertices kept in `distinct`.
fn one_triangle<'a>(
    mesh: &TriMesh,
    t: usize,
    normal: &'a Vec3,
    area: f32,
    distinct: &'a mut [u32; 3],
) -> Summary<'a> {
    let mut count = 0;
    let mut vertex_sum = Vec3::ZERO;
    for v in mesh.triangles[t] {
        if !distinct[..count].contains(&v) {
            distinct[count] = v;
            count += 1;
            vertex_sum += mesh.positions[v as usize];
        }
    }
    Summary {
        vertices: &distinct[..count],
        vertex_sum,
        normals: std::slice::from_ref(normal),
        normal_sum: *normal * area.max(f32::MIN_POSITIVE),
        area,
        triangles: 1,
    }
}

/// Iterative growing (module header): clusters of `mesh`'s triangles, every triangle in
/// exactly one, each connected through shared edges (by position) except that a
/// degenerate or isolated triangle may make a cluster of its own.
pub fn grow(mesh: &TriMesh, settings: &ClusterSettings) -> Clusters {
    let n = mesh.triangle_count();
    let (adjacency, shape, scale, mut marks) = prepare(mesh, settings);
    let mut taken = vec![false; n];
    let mut frontier: Vec<u32> = Vec::new();
    let mut groups: Vec<Vec<u32>> = Vec::new();
    for seed in morton_order(mesh) {
        if taken[seed as usize] {
            continue;
        }
        let mut k = Set::default();
        frontier.clear();
        let mut next = Some(seed);
        while let Some(t) = next {
            let tu = t as usize;
            taken[tu] = true;
            k.add(mesh, t, shape[tu]);
            for u in edge_neighbours(&adjacency, tu) {
                if !taken[u as usize] && !frontier.contains(&u) {
                    frontier.push(u);
                }
            }
            frontier.retain(|&u| !taken[u as usize]);
            // The neighbour whose addition keeps Acc highest, if it stays positive.
            next = frontier
                .iter()
                .filter_map(|&u| {
                    let (normal, area) = &shape[u as usize];
                    if *area == 0.0 {
                        return None;
                    }
                    let mut distinct = [0u32; 3];
                    let candidate = one_triangle(mesh, u as usize, normal, *area, &mut distinct);
                    acceptance(mesh, k.summary(), candidate, &scale, &mut marks)
                        .filter(|&a| a > 0.0)
                        .map(|a| (a, u))
                })
                .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)))
                .map(|(_, u)| u);
        }
        groups.push(k.triangles);
    }
    finish(mesh, &adjacency, groups, settings)
}

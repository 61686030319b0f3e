//! Boundary refinement of precomputed clusters (not in Garanzha's slides). Growing and
//! contraction make round, disk-like clusters by Acc(k); their axis-aligned boxes
//! overlap more than those of meshoptimizer's spatial clusterizer, which splits by SAH
//! along the axes. This pass moves single triangles on a cluster's border to a
//! neighbouring cluster (across an edge) wherever that lowers
//!
//! ```text
//! C = Σ over clusters k of halfArea(box(k)) · |k|
//! ```
//!
//! the SAH cost of the clusters as leaves, a greedy local search in the manner of the
//! boundary moves of Kernighan–Lin and Fiduccia–Mattheyses in graph partitioning, on an
//! SAH objective. A move must keep the receiving cluster within MaxCount triangles and
//! the vertex limit, and the giving one connected (always, when the triangle has one
//! neighbour there; else a search over that cluster decides). A triangle takes the
//! neighbour of the largest gain; each pass visits the triangles of the clusters the pass
//! before changed, and of their neighbours.
//!
//! Cost: O(P · T · |k|) for P passes (a box without the triangle, a vertex count, a
//! search), about 0.7 µs a triangle for 8 passes on the dragon, which nearly doubles
//! growing's precompute (docs/measurements/clusters.md).

use super::{edge_neighbours, vertex_count, ClusterSettings};
use crate::geom::Aabb;
use crate::mesh::{EdgeAdjacency, TriMesh};

/// Move border triangles of `groups` to a neighbouring cluster where that lowers
/// Σ halfArea(box) · |k|, for `settings.refine_passes` passes or until a pass moves
/// nothing; every group stays connected and within MaxCount and the vertex limit.
pub(super) fn refine(
    mesh: &TriMesh,
    adjacency: &EdgeAdjacency,
    groups: &mut [Vec<u32>],
    settings: &ClusterSettings,
) {
    let passes = settings.refine_passes;
    if passes == 0 {
        return;
    }
    let n = mesh.triangle_count();
    // Each triangle's neighbours across its edges, flattened once: every pass reads
    // them several times per triangle.
    let mut start = Vec::with_capacity(n + 1);
    let mut across = Vec::with_capacity(3 * n);
    start.push(0u32);
    for t in 0..n {
        across.extend(edge_neighbours(adjacency, t).filter(|&u| u as usize != t));
        start.push(across.len() as u32);
    }
    let neighbours = |t: u32| &across[start[t as usize] as usize..start[t as usize + 1] as usize];
    let mut owner = vec![u32::MAX; n];
    for (g, triangles) in groups.iter().enumerate() {
        for &t in triangles {
            owner[t as usize] = g as u32;
        }
    }
    let triangle_box = |t: u32| Aabb::from_points(&mesh.corners(t as usize));
    let box_without = |triangles: &[u32], skip: u32| {
        triangles
            .iter()
            .filter(|&&u| u != skip)
            .fold(Aabb::EMPTY, |b, &u| b.union(triangle_box(u)))
    };
    // Corners of `t` that no triangle of `triangles` other than `t` names.
    let own_corners = |triangles: &[u32], t: u32| {
        mesh.triangles[t as usize]
            .iter()
            .filter(|&&v| {
                !triangles
                    .iter()
                    .any(|&u| u != t && mesh.triangles[u as usize].contains(&v))
            })
            .count()
    };
    let cost = |b: &Aabb, count: usize| b.half_area() * count as f32;
    let mut boxes: Vec<Aabb> = groups.iter().map(|g| box_without(g, u32::MAX)).collect();
    let mut vertices: Vec<usize> = groups
        .iter()
        .map(|g| vertex_count(mesh, g.iter()))
        .collect();
    let mut gains: Vec<(f32, u32)> = Vec::new();
    let mut mark = vec![0u32; n];
    let mut stamp = 0u32;
    let mut queue: Vec<u32> = Vec::new();
    // Clusters changed by the pass before: only their triangles and their neighbours'
    // can gain from a move now.
    let mut changed = vec![true; groups.len()];
    let mut changing = vec![false; groups.len()];
    for _ in 0..passes {
        let mut moved = 0;
        for t in 0..n as u32 {
            let a = owner[t as usize];
            if a == u32::MAX || groups[a as usize].len() <= 1 {
                continue;
            }
            if !changed[a as usize]
                && !neighbours(t)
                    .iter()
                    .any(|&u| owner[u as usize] != u32::MAX && changed[owner[u as usize] as usize])
            {
                continue;
            }
            let tb = triangle_box(t);
            gains.clear();
            gains.extend(
                neighbours(t)
                    .iter()
                    .map(|&u| owner[u as usize])
                    .filter(|&b| {
                        b != a && b != u32::MAX && groups[b as usize].len() < settings.max_triangles
                    })
                    .map(|b| {
                        let (bb, count) = (&boxes[b as usize], groups[b as usize].len());
                        (cost(&bb.union(tb), count + 1) - cost(bb, count), b)
                    }),
            );
            if gains.is_empty() {
                continue;
            }
            let ga = &groups[a as usize];
            // A box that t does not touch stays as it is without t.
            let inside = tb.min.cmpgt(boxes[a as usize].min).all()
                && tb.max.cmplt(boxes[a as usize].max).all();
            let without = if inside {
                boxes[a as usize]
            } else {
                box_without(ga, t)
            };
            let here = cost(&boxes[a as usize], ga.len()) - cost(&without, ga.len() - 1);
            gains.retain(|g| g.0 < here);
            gains.sort_unstable_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)));
            gains.dedup_by_key(|g| g.1);
            // The best receiver within the vertex limit, with the corners t brings it.
            let Some((b, brought)) = gains.iter().find_map(|&(_, b)| {
                let brought = own_corners(&groups[b as usize], t);
                (vertices[b as usize] + brought <= settings.max_vertices).then_some((b, brought))
            }) else {
                continue;
            };
            // A stays connected without t: always when t has one neighbour in A (a leaf
            // of A's dual graph), else when a search from one of them reaches all.
            let in_a = neighbours(t)
                .iter()
                .filter(|&&u| owner[u as usize] == a)
                .count();
            if in_a != 1 {
                stamp += 1;
                mark[t as usize] = stamp;
                queue.clear();
                let start = *ga.iter().find(|&&u| u != t).expect("two or more");
                queue.push(start);
                mark[start as usize] = stamp;
                let mut reached = 1;
                while let Some(u) = queue.pop() {
                    for &w in neighbours(u) {
                        if owner[w as usize] == a && mark[w as usize] != stamp {
                            mark[w as usize] = stamp;
                            queue.push(w);
                            reached += 1;
                        }
                    }
                }
                if reached != ga.len() - 1 {
                    continue;
                }
            }
            vertices[a as usize] -= own_corners(ga, t);
            vertices[b as usize] += brought;
            groups[a as usize].retain(|&u| u != t);
            groups[b as usize].push(t);
            owner[t as usize] = b;
            boxes[a as usize] = without;
            boxes[b as usize] = boxes[b as usize].union(tb);
            changing[a as usize] = true;
            changing[b as usize] = true;
            moved += 1;
        }
        if moved == 0 {
            break;
        }
        std::mem::swap(&mut changed, &mut changing);
        changing.fill(false);
    }
}

//! The baseline clusterizer: meshoptimizer's ray-tracing clusters
//! (`meshopt_buildMeshletsSpatial`, through the `meshopt` crate, which vendors
//! meshoptimizer 1.3), with min = max / 4 triangles and fill weight 0.5, as NVIDIA's
//! vk_animated_clusters calls it. It splits the mesh by SAH over triangle centroids and
//! needs no connectivity, so its clusters need not be connected.
//!
//! Its meshlets are mapped back to input triangle ids (by each triangle's rotation that
//! starts at its smallest index, in a sorted table) and stored as rtmesh's [`Clusters`]; triangles it
//! does not return (none seen so far) become clusters of one.
//!
//! Cost: meshoptimizer's, then O(T log T) for the ids.

use super::{ClusterSettings, Clusters};
use crate::mesh::TriMesh;
use rayon::prelude::*;

/// meshoptimizer's spatial clusters of `mesh`, at most `settings.max_triangles`
/// triangles (rounded down to a multiple of 4, at least 4) and `settings.max_vertices`
/// vertices each.
pub fn spatial(mesh: &TriMesh, settings: &ClusterSettings) -> Clusters {
    let max_triangles = (settings.max_triangles / 4 * 4).max(4);
    let max_vertices = settings.max_vertices.clamp(3, 256);
    let n = mesh.triangle_count();
    let vertex_count = mesh.positions.len();
    let key = |t: [u32; 3]| {
        let r = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
        [t[r], t[(r + 1) % 3], t[(r + 2) % 3]]
    };
    // Input ids by key, sorted: a meshlet triangle takes the first free id of its key.
    let mut ids: Vec<([u32; 3], u32)> = mesh
        .triangles
        .iter()
        .enumerate()
        .map(|(t, &v)| (key(v), t as u32))
        .collect();
    ids.par_sort_unstable();
    let mut taken = vec![false; n];
    let mut take = |t: [u32; 3]| {
        let k = key(t);
        let first = ids.partition_point(|e| e.0 < k);
        let slot = (first..ids.len())
            .take_while(|&i| ids[i].0 == k)
            .find(|&i| !taken[i])?;
        taken[slot] = true;
        Some(ids[slot].1)
    };
    let in_range = |t: &[u32; 3]| t.iter().all(|&v| (v as usize) < vertex_count);
    let indices: Vec<u32> = mesh
        .triangles
        .iter()
        .filter(|t| in_range(t))
        .flatten()
        .copied()
        .collect();
    let mut out = Clusters::default();
    // meshoptimizer asserts that output and input differ, which two empty vectors'
    // dangling pointers do not.
    if !indices.is_empty() {
        let positions: Vec<f32> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
        let bytes: Vec<u8> = positions.iter().flat_map(|c| c.to_le_bytes()).collect();
        let adapter = ::meshopt::VertexDataAdapter::new(&bytes, 12, 0).expect("12-byte positions");
        let meshlets = ::meshopt::clusterize::build_meshlets_spatial(
            &indices,
            &adapter,
            max_vertices,
            max_triangles / 4,
            max_triangles,
            0.5,
        );
        for meshlet in meshlets.iter() {
            let group: Vec<u32> = meshlet
                .triangles
                .chunks_exact(3)
                .filter_map(|c| take([0, 1, 2].map(|k| meshlet.vertices[c[k] as usize])))
                .collect();
            if !group.is_empty() {
                out.push(mesh, &group);
            }
        }
    }
    let mut left: Vec<u32> = (0..n).filter(|&i| !taken[i]).map(|i| ids[i].1).collect();
    left.sort_unstable();
    for t in left {
        out.push(mesh, &[t]);
    }
    out
}

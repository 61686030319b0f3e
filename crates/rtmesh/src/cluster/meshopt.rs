//! The baseline clusterizer: meshoptimizer's ray-tracing clusters
//! (`meshopt_buildMeshletsSpatial`, through the `meshopt` crate, which vendors
//! meshoptimizer 1.3), with min = max / 4 triangles and fill weight 0.5, as NVIDIA's
//! vk_animated_clusters calls it. It splits the mesh by SAH over triangle centroids and
//! needs no connectivity, so its clusters need not be connected.
//!
//! Its meshlets are mapped back to input triangle ids ([`TriangleIds`]) and stored as
//! rtmesh's [`Clusters`], in blocks of four as rtmesh's own clusters are
//! ([`split_into_blocks`]), so that both are traced alike. It is given one copy of each
//! triangle (it slows to quadratic time on coincident centroids); the other copies, and
//! triangles it does not return (none seen so far), are clustered with their copies.
//!
//! Cost: meshoptimizer's, then O(T log T) for the ids.

use super::{split_into_blocks, ClusterSettings, Clusters};
use crate::mesh::{smallest_first, TriMesh, TriangleIds};

/// meshoptimizer's spatial clusters of `mesh`, at most `settings.max_triangles`
/// triangles (rounded down to a multiple of 4, at least 4) and `settings.max_vertices`
/// vertices each.
pub fn spatial(mesh: &TriMesh, settings: &ClusterSettings) -> Clusters {
    let max_triangles = (settings.max_triangles / 4 * 4).max(4);
    let max_vertices = settings.max_vertices.clamp(3, 256);
    let vertex_count = mesh.positions.len();
    let mut ids = TriangleIds::new(&mesh.triangles);
    let in_range = |t: &[u32; 3]| t.iter().all(|&v| (v as usize) < vertex_count);
    // One copy of each triangle: meshoptimizer's split slows to quadratic time on
    // coincident centroids (40,000 copies of one triangle took 1.5 s, a million would
    // take minutes); the other copies become clusters of their own below.
    let mut seen = std::collections::HashSet::new();
    let indices: Vec<u32> = mesh
        .triangles
        .iter()
        .filter(|&&t| in_range(&t) && seen.insert(smallest_first(t)))
        .flatten()
        .copied()
        .collect();
    let mut out = Clusters::default();
    // meshoptimizer asserts that output and input differ, which two empty vectors'
    // dangling pointers do not.
    if !indices.is_empty() {
        let bytes: Vec<u8> = mesh
            .positions
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
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
            let mut group: Vec<u32> = meshlet
                .triangles
                .chunks_exact(3)
                .filter_map(|c| ids.take([0, 1, 2].map(|k| meshlet.vertices[c[k] as usize])))
                .collect();
            if !group.is_empty() {
                split_into_blocks(mesh, &mut group);
                out.push(mesh, &group);
            }
        }
    }
    // What meshoptimizer did not return (none seen so far) and the copies: copies of
    // one triangle together, up to MaxCount a cluster.
    for same in ids.untaken_runs() {
        for chunk in same.chunks(max_triangles) {
            out.push(mesh, chunk);
        }
    }
    out
}

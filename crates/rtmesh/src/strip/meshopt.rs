//! The baseline: meshoptimizer's rasterization stripifier (`meshopt_stripify`, through
//! the `meshopt` crate, which vendors meshoptimizer 1.3), after its vertex-cache
//! optimisation (`meshopt_optimizeVertexCache`), as a renderer would run it, except
//! around a vertex of over 1,024 triangles, where that optimisation turns quadratic.
//!
//! Its strips are rasterization strips with restart indices. To trace them on the same
//! hierarchy as Strip-RT's, each run is decoded and cut into rtmesh's strip format
//! wherever two consecutive triangles do not share an edge the other way round
//! (meshoptimizer's swaps and joins), and at `max_length`. Triangles with a repeated
//! index, which meshoptimizer drops, become strips of one.
//!
//! Cost: meshoptimizer's, O(T), then O(T log T) to map its triangles back to input ids
//! ([`TriangleIds`]).

use super::{standard_triangles, Encoder, Strips};
use crate::mesh::{names_a_vertex_twice, TriMesh, TriangleIds};

/// What meshoptimizer's stripifier made.
pub struct MeshoptStrips {
    /// Its strips, converted to rtmesh's format and cut at the maximum length.
    pub strips: Strips,
    /// Indices of its own output, restarts included.
    pub native_indices: usize,
    /// Restart indices in its own output.
    pub native_restarts: usize,
}

/// Most triangles on one vertex for which the vertex cache is optimised first.
const MAX_CACHED_VALENCE: u32 = 1024;

/// The restart index passed to meshoptimizer.
const RESTART: u32 = u32::MAX;

/// Stripify `mesh` with meshoptimizer, then cut its strips at `max_length`.
pub fn stripify(mesh: &TriMesh, max_length: usize) -> MeshoptStrips {
    let tris = &mesh.triangles;
    let vertex_count = mesh.positions.len();
    let proper =
        |t: &[u32; 3]| !names_a_vertex_twice(*t) && t.iter().all(|&v| (v as usize) < vertex_count);
    let indices: Vec<u32> = tris
        .iter()
        .filter(|t| proper(t))
        .flatten()
        .copied()
        .collect();
    // meshoptimizer's vertex-cache optimiser slows to quadratic time around a vertex
    // of very high valence (a book of 100,000 pages on one spine took 20 s): past
    // MAX_CACHED_VALENCE triangles on one vertex the input order is stripped as it is.
    let mut valence = vec![0u32; vertex_count];
    for &v in &indices {
        valence[v as usize] += 1;
    }
    // meshoptimizer asserts that output and input differ, which two empty vectors'
    // dangling pointers do not.
    let native = if indices.is_empty() {
        Vec::new()
    } else if valence.iter().all(|&n| n <= MAX_CACHED_VALENCE) {
        let cached = ::meshopt::optimize_vertex_cache(&indices, vertex_count);
        ::meshopt::stripify(&cached, vertex_count, RESTART).unwrap_or_default()
    } else {
        ::meshopt::stripify(&indices, vertex_count, RESTART).unwrap_or_default()
    };
    let native_restarts = native.iter().filter(|&&i| i == RESTART).count();

    let mut ids = TriangleIds::new(tris);
    let mut encoder = Encoder::new(tris);
    let mut sequence: Vec<u32> = Vec::new();
    let mut exits: Vec<u8> = Vec::new();
    let max_length = max_length.max(1);
    let flush = |sequence: &mut Vec<u32>, exits: &mut Vec<u8>, encoder: &mut Encoder| {
        encoder.push(sequence, exits);
        sequence.clear();
        exits.clear();
    };
    let mut run_triangles = Vec::new();
    for run in native.split(|&i| i == RESTART) {
        run_triangles.clear();
        standard_triangles(run, &mut run_triangles);
        for &t in &run_triangles {
            let Some(id) = ids.take(t) else {
                continue;
            };
            // The side of the previous triangle this one shares the other way round,
            // other than the side the previous one was entered by.
            let exit = sequence.last().and_then(|&p| {
                let prev = tris[p as usize];
                let entry = exits.len().checked_sub(1).map(|i| {
                    let q = tris[sequence[i] as usize];
                    let s = exits[i] as usize;
                    [q[(s + 1) % 3], q[s]]
                });
                (0..3).find(|&s| {
                    let edge = [prev[s], prev[(s + 1) % 3]];
                    let shares = (0..3).any(|k| {
                        tris[id as usize][k] == edge[1] && tris[id as usize][(k + 1) % 3] == edge[0]
                    });
                    shares && entry != Some(edge)
                })
            });
            match exit {
                Some(s) if sequence.len() < max_length => exits.push(s as u8),
                _ if sequence.is_empty() => {}
                _ => flush(&mut sequence, &mut exits, &mut encoder),
            }
            sequence.push(id);
        }
        if !sequence.is_empty() {
            flush(&mut sequence, &mut exits, &mut encoder);
        }
    }
    // Whatever meshoptimizer did not return (degenerate or out-of-range triangles).
    for t in ids.untaken() {
        encoder.push(&[t], &[]);
    }
    MeshoptStrips {
        strips: encoder.finish(),
        native_indices: native.len(),
        native_restarts,
    }
}

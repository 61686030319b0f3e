//! Edge adjacency: canonical edges `(min vertex, max vertex)`, the triangles around each
//! edge, and each triangle's three edges.
//!
//! Built by a counting sort on the smaller vertex (a CSR table of half-edges per vertex),
//! then a tiny insertion sort of each vertex's few half-edges on the larger vertex:
//! O(T + V) time, three passes over 3T half-edges, no hashing and no per-edge allocation.
//! Its speed is measured by `benches/adjacency.rs`.
//!
//! Boundary edges have one triangle, manifold edges two, non-manifold edges three or
//! more. Triangles that repeat a vertex (`[a, a, b]` is a line that would touch edge
//! `(a, b)` twice) and triangles with indices out of range have no edges: their slots in
//! [`EdgeAdjacency::triangle_edges`] hold [`NO_EDGE`].

use super::TriMesh;
use rayon::prelude::*;

/// Marks a triangle side that is not an edge (repeated vertex, or index out of range).
pub const NO_EDGE: u32 = u32::MAX;

/// Edges of a mesh and their incident triangles.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EdgeAdjacency {
    /// Canonical edges `[min, max]`, sorted ascending.
    pub edges: Vec<[u32; 2]>,
    /// CSR offsets: the triangles of edge `e` are
    /// `edge_triangles[edge_triangle_start[e]..edge_triangle_start[e + 1]]`.
    pub edge_triangle_start: Vec<u32>,
    /// Incident triangles of every edge, ascending within an edge.
    pub edge_triangles: Vec<u32>,
    /// For triangle `t = [a, b, c]`: the edges of sides `(a, b)`, `(b, c)`, `(c, a)`.
    pub triangle_edges: Vec<[u32; 3]>,
}

impl EdgeAdjacency {
    /// Build the adjacency of `mesh`'s triangles (by vertex index: weld first to join
    /// split vertices).
    pub fn build(mesh: &TriMesh) -> Self {
        let runs = HalfEdgeRuns::build(mesh);
        let half_edge_count = runs.slots.len();
        let mut edges = Vec::with_capacity(half_edge_count / 2 + 1);
        let mut edge_triangle_start = Vec::with_capacity(half_edge_count / 2 + 2);
        let mut edge_triangles = Vec::with_capacity(half_edge_count);
        let mut triangle_edges = vec![[NO_EDGE; 3]; mesh.triangles.len()];
        runs.for_each_edge(|v, other, half_edges| {
            let edge = edges.len() as u32;
            edges.push([v, other]);
            edge_triangle_start.push(edge_triangles.len() as u32);
            for &(_, half_edge) in half_edges {
                edge_triangles.push(half_edge / 3);
                triangle_edges[half_edge as usize / 3][half_edge as usize % 3] = edge;
            }
        });
        edge_triangle_start.push(edge_triangles.len() as u32);
        Self {
            edges,
            edge_triangle_start,
            edge_triangles,
            triangle_edges,
        }
    }

    /// Triangles around edge `e`.
    #[inline]
    pub fn triangles_of(&self, e: u32) -> &[u32] {
        let e = e as usize;
        &self.edge_triangles
            [self.edge_triangle_start[e] as usize..self.edge_triangle_start[e + 1] as usize]
    }

    /// Number of triangles around edge `e`.
    #[inline]
    pub fn valence(&self, e: u32) -> usize {
        let e = e as usize;
        (self.edge_triangle_start[e + 1] - self.edge_triangle_start[e]) as usize
    }

    fn count_edges(&self, keep: impl Fn(usize) -> bool) -> usize {
        (0..self.edges.len())
            .filter(|&e| keep(self.valence(e as u32)))
            .count()
    }

    /// Edges with exactly one triangle.
    pub fn boundary_edge_count(&self) -> usize {
        self.count_edges(|n| n == 1)
    }

    /// Edges with exactly two triangles.
    pub fn manifold_edge_count(&self) -> usize {
        self.count_edges(|n| n == 2)
    }

    /// Edges with three or more triangles.
    pub fn nonmanifold_edge_count(&self) -> usize {
        self.count_edges(|n| n > 2)
    }
}

/// The half-edges of a mesh grouped by canonical edge: a CSR table over the smaller
/// vertex whose per-vertex runs are sorted by (larger vertex, half-edge id). Half-edge
/// `3t + k` is side `(t[k], t[k + 1])` of triangle `t`. Shared by [`EdgeAdjacency`] and
/// the maximum-matching search ([`crate::pair::matching`]), which walk the edges in
/// ascending `(min, max)`.
pub(crate) struct HalfEdgeRuns {
    /// `slots[start[v]..start[v + 1]]` are the half-edges whose smaller vertex is `v`.
    start: Vec<u32>,
    /// One entry per half-edge: (larger vertex, half-edge id).
    slots: Vec<(u32, u32)>,
}

/// Whether triangle `t` has three edges: indices below `vertex_count` and three
/// distinct vertices. Tested with `&`, not `&&`: nearly every triangle passes, and one
/// test of all six conditions costs less than six branches.
#[inline]
pub(crate) fn has_edges(t: &[u32; 3], vertex_count: usize) -> bool {
    ((t[0] as usize) < vertex_count)
        & ((t[1] as usize) < vertex_count)
        & ((t[2] as usize) < vertex_count)
        & (t[0] != t[1])
        & (t[1] != t[2])
        & (t[2] != t[0])
}

/// The length of the parts that `triangle_count` triangles split into for a counting
/// sort: one part per pool thread, or one below 32k triangles. A multiple of 16, so
/// that parts are whole groups of the 16-lane AVX-512 passes.
pub(crate) fn triangle_part_len(triangle_count: usize) -> usize {
    let parts = rayon::current_num_threads()
        .min(triangle_count >> 15)
        .max(1);
    triangle_count.div_ceil(parts).next_multiple_of(16).max(16)
}

/// A scatter's destination, shared by threads that write disjoint slots of it (the
/// counting sorts of the half-edge runs and of the pairing's twin search).
pub(crate) struct SharedSlice<K>(pub(crate) *mut K);
// SAFETY: threads write disjoint elements only.
unsafe impl<K: Send> Sync for SharedSlice<K> {}

/// Turn per-part counts per bucket (`buckets` of them) into per-part cursors, in
/// place, each part's slots in a bucket after the earlier parts': a stable counting
/// sort over parts. Returns where every bucket starts, and the total last.
pub(crate) fn part_cursors(cursors: &mut [Vec<u32>], buckets: usize) -> Vec<u32> {
    let mut start = vec![0u32; buckets + 1];
    let mut sum = 0u32;
    for b in 0..buckets {
        start[b] = sum;
        for cursor in cursors.iter_mut() {
            let count = cursor[b];
            cursor[b] = sum;
            sum += count;
        }
    }
    start[buckets] = sum;
    start
}

impl HalfEdgeRuns {
    /// Counting sort of the half-edges of the valid triangles (indices in range, three
    /// distinct vertices) on their smaller vertex, as entries (larger vertex,
    /// half-edge id); within a vertex's run, half-edge ids ascend and larger vertices
    /// are in no order. Parts of the triangles on the pool's threads.
    fn unsorted(mesh: &TriMesh) -> Self {
        let vertex_count = mesh.positions.len();
        let valid = |t: &[u32; 3]| has_edges(t, vertex_count);
        // Each part of the triangles counts and scatters its own half-edges, after the
        // earlier parts' in every vertex's run, so runs keep ascending half-edge ids.
        let part_len = triangle_part_len(mesh.triangles.len());
        // Pass 1: count half-edges per smaller vertex, per part.
        let mut cursors: Vec<Vec<u32>> = mesh
            .triangles
            .par_chunks(part_len)
            .map(|part| {
                let mut count = vec![0u32; vertex_count];
                for t in part {
                    if valid(t) {
                        for k in 0..3 {
                            count[t[k].min(t[(k + 1) % 3]) as usize] += 1;
                        }
                    }
                }
                count
            })
            .collect();
        let start = part_cursors(&mut cursors, vertex_count);
        // Pass 2: scatter each half-edge's entry into its smaller vertex's slots.
        let half_edge_count = start[vertex_count] as usize;
        let mut slots: Vec<(u32, u32)> = crate::pages::vec_on_huge_pages(half_edge_count);
        let destination = SharedSlice(slots.as_mut_ptr());
        let destination = &destination;
        mesh.triangles
            .par_chunks(part_len)
            .zip(cursors)
            .enumerate()
            .for_each(|(p, (part, mut cursor))| {
                for (i, t) in part.iter().enumerate() {
                    if !valid(t) {
                        continue;
                    }
                    for k in 0..3 {
                        let (a, b) = (t[k], t[(k + 1) % 3]);
                        let half_edge = ((p * part_len + i) * 3 + k) as u32;
                        let c = &mut cursor[a.min(b) as usize];
                        // SAFETY: the counts give every half-edge of every part its
                        // own slot below `half_edge_count`.
                        unsafe { destination.0.add(*c as usize).write((a.max(b), half_edge)) };
                        *c += 1;
                    }
                }
            });
        // SAFETY: the cursors covered every slot exactly once.
        unsafe { slots.set_len(half_edge_count) };
        Self { start, slots }
    }

    /// The entries of the half-edges whose smaller vertex is `v`.
    #[inline]
    pub(crate) fn run(&self, v: usize) -> &[(u32, u32)] {
        &self.slots[self.start[v] as usize..self.start[v + 1] as usize]
    }

    /// Vertices (the runs' index range).
    pub(crate) fn vertex_count(&self) -> usize {
        self.start.len() - 1
    }

    /// Vertex ranges for parallel work: one per pool thread, or one for fewer than
    /// 16k vertices.
    fn vertex_blocks(vertex_count: usize) -> Vec<std::ops::Range<usize>> {
        let blocks = rayon::current_num_threads().min(vertex_count >> 14).max(1);
        let block = vertex_count.div_ceil(blocks).max(1);
        (0..vertex_count)
            .step_by(block)
            .map(|v| v..(v + block).min(vertex_count))
            .collect()
    }

    /// The runs of the valid triangles' half-edges (indices in range, three distinct
    /// vertices), each sorted by (larger vertex, half-edge id).
    pub(crate) fn build(mesh: &TriMesh) -> Self {
        let mut runs = HalfEdgeRuns::unsorted(mesh);
        runs.sort_runs();
        runs
    }

    /// Sort every vertex's run by (larger vertex, half-edge id); blocks of vertices in
    /// parallel.
    fn sort_runs(&mut self) {
        let start = &self.start;
        let mut blocks = Vec::new();
        let mut rest = self.slots.as_mut_slice();
        for range in Self::vertex_blocks(start.len() - 1) {
            let (block, tail) = rest.split_at_mut((start[range.end] - start[range.start]) as usize);
            blocks.push((range, block));
            rest = tail;
        }
        blocks.into_par_iter().for_each(|(range, block)| {
            let base = start[range.start];
            for v in range {
                sort_run(&mut block[(start[v] - base) as usize..(start[v + 1] - base) as usize]);
            }
        });
    }

    /// Half-edges of valid triangles.
    pub(crate) fn half_edge_count(&self) -> usize {
        self.slots.len()
    }

    /// Call `f(min, max, slots)` for every edge in ascending `(min, max)` order, where
    /// `slots` are its `(max, half-edge id)` entries, half-edge ids ascending.
    pub(crate) fn for_each_edge(&self, f: impl FnMut(u32, u32, &[(u32, u32)])) {
        self.for_each_edge_of(0..self.vertex_count(), f);
    }

    /// [`Self::for_each_edge`] over the edges whose smaller vertex is in `vertices`.
    pub(crate) fn for_each_edge_of(
        &self,
        vertices: std::ops::Range<usize>,
        mut f: impl FnMut(u32, u32, &[(u32, u32)]),
    ) {
        for v in vertices {
            let mut run = self.run(v);
            while let Some(&(other, _)) = run.first() {
                let len = run.iter().take_while(|s| s.0 == other).count();
                f(v as u32, other, &run[..len]);
                run = &run[len..];
            }
        }
    }
}

/// Sort a vertex's run in place. Runs hold about six half-edges, where an insertion
/// sort's every comparison is a coin-toss branch; up to [`RANK_SORT_MAX`] entries each
/// entry's place is instead counted without branches (its rank: the entries smaller
/// than it; the `(other, half-edge)` entries are distinct) and it is written there.
fn sort_run(run: &mut [(u32, u32)]) {
    if run.len() > RANK_SORT_MAX {
        run.sort_unstable();
        return;
    }
    let mut sorted = [(0u32, 0u32); RANK_SORT_MAX];
    let key = |&(other, half_edge): &(u32, u32)| (other as u64) << 32 | half_edge as u64;
    for x in run.iter() {
        let rank: usize = run.iter().map(|y| (key(y) < key(x)) as usize).sum();
        sorted[rank] = *x;
    }
    run.copy_from_slice(&sorted[..run.len()]);
}

/// The longest run [`sort_run`] ranks (n² comparisons); longer ones are sorted.
const RANK_SORT_MAX: usize = 16;

/// Connected components of triangles joined by shared edges. Returns the component of
/// each triangle (numbered in order of first triangle) and the number of components.
pub fn connected_components(adjacency: &EdgeAdjacency) -> (Vec<u32>, usize) {
    let n = adjacency.triangle_edges.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            let grand = parent[parent[x as usize] as usize];
            parent[x as usize] = grand;
            x = grand;
        }
        x
    }
    for e in 0..adjacency.edges.len() as u32 {
        let tris = adjacency.triangles_of(e);
        for w in tris.windows(2) {
            let (a, b) = (find(&mut parent, w[0]), find(&mut parent, w[1]));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let mut label = vec![u32::MAX; n];
    let mut count = 0;
    let component = (0..n as u32)
        .map(|t| {
            let root = find(&mut parent, t) as usize;
            if label[root] == u32::MAX {
                label[root] = count as u32;
                count += 1;
            }
            label[root]
        })
        .collect();
    (component, count)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn tetrahedron() -> TriMesh {
        TriMesh::new(
            vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
        )
    }

    #[test]
    fn tetrahedron_is_closed_and_manifold() {
        let adj = EdgeAdjacency::build(&tetrahedron());
        assert_eq!(adj.edges.len(), 6);
        assert_eq!(adj.manifold_edge_count(), 6);
        assert_eq!(adj.boundary_edge_count(), 0);
        assert_eq!(adj.edges[0], [0, 1]);
        assert_eq!(adj.triangles_of(0), &[0, 1]);
        // Triangle 0 = [0, 2, 1]: sides (0,2), (2,1), (1,0).
        assert_eq!(
            adj.triangle_edges[0].map(|e| adj.edges[e as usize]),
            [[0, 2], [1, 2], [0, 1]]
        );
        assert_eq!(connected_components(&adj).1, 1);
    }

    #[test]
    fn fin_edge_is_nonmanifold_and_degenerate_sides_are_not_edges() {
        let mut m = tetrahedron();
        m.positions.push(Vec3::new(1.0, 1.0, 1.0));
        m.triangles.push([0, 1, 4]); // third triangle on edge (0, 1)
        m.triangles.push([2, 2, 3]); // repeated vertex: no edges
        m.triangles.push([0, 1, 7]); // out of range: no edges
        let adj = EdgeAdjacency::build(&m);
        assert_eq!(adj.nonmanifold_edge_count(), 1);
        assert_eq!(adj.triangles_of(0), &[0, 1, 4]);
        assert_eq!(adj.boundary_edge_count(), 2); // (0,4) and (1,4)
        assert_eq!(adj.triangle_edges[5], [NO_EDGE; 3]);
        assert_eq!(adj.triangle_edges[6], [NO_EDGE; 3]);
        let (component, count) = connected_components(&adj);
        assert_eq!(count, 3);
        assert_eq!(component[4], 0);
        assert_eq!(component[5], 1);
        assert_eq!(component[6], 2);
    }
}

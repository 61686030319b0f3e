//! Greedy triangle pairing by edge bounding-box surface area (Aman & Fenney, "Fast
//! Triangle Pairing for Ray Tracing", Imagination, HPG 2024).
//!
//! The published procedure: one record per half-edge (BBSA, first vertex = the smaller
//! index, second vertex, triangle); sort descending by [BBSA, first, second] so that
//! twins are neighbours and long diagonal edges come first; scan the table and pair two
//! neighbouring records with the same key when neither triangle is paired yet.
//! [`sorted_half_edge_table`] and [`pair_sah_reference`] are that procedure, written
//! plainly (a comparison sort of all 3T records): the reference the tests hold the fast
//! route to.
//!
//! The fast route, [`pair_sah`], gives the same pairing (asserted by tests) with no
//! sort at all. Twins come from a counting sort of the half-edges by blocks of
//! smaller vertices, then by vertex within a block in cache (module `suitor`). Then,
//! instead of sorting the couples and scanning them, the Suitor algorithm finds the
//! same matching: the scan's order is a strict total order on couples, and under one
//! the greedy matching is the unique locally dominant one. Cost: O(T + V) time; 12
//! bytes per half-edge for the blocks, 4 for the links, 1 per triangle for the
//! matching. The twin search splits its work over the rayon pool's threads, and so
//! does the matching when there is more than one (parallel Suitor, module `suitor`).
//!
//! The loops of the twin search are also written by hand in AVX-512, taken when the
//! CPU has it (detected at run time): ranking the triangles' sides 16 at a time,
//! writing their half-edges out by block, and finding the twins of a whole block 16
//! half-edges at a time, each compared with its 30 neighbours in the block sorted by
//! run. They are the hot kernels of the technique, and a compiler does not find them
//! (built for the CPU, the scalar code runs no faster). The scalar loops are the reference: tests
//! run both and hold each to the published procedure.

#[cfg(target_arch = "x86_64")]
mod avx512;

use super::suitor::{
    match_greedily, rank_of_side, side_ranks, Couples, EdgeKeys, HalfEdge, Links, RankedSides,
    MAX_LINKED_TRIANGLES,
};
use super::{edge_bbsa, ActiveTriangles, Pairing, UNPAIRED};
use crate::mesh::{has_edges, triangle_part_len, SharedSlice, TriMesh};
use crate::simd::has_avx512;

/// One record of the paper's half-edge table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfEdgeRecord {
    /// Half the surface area of the edge's box ([`edge_bbsa`]).
    pub bbsa: f32,
    /// The smaller vertex index of the edge.
    pub first: u32,
    /// The larger vertex index.
    pub second: u32,
    /// The triangle the half-edge belongs to.
    pub triangle: u32,
}

impl HalfEdgeRecord {
    fn key(&self) -> (u32, u32, u32) {
        (self.bbsa.to_bits(), self.first, self.second)
    }
}

/// The half-edge table in input order: sides `(a, b)`, `(b, c)`, `(c, a)` of every
/// active triangle.
pub fn half_edge_table(mesh: &TriMesh) -> Vec<HalfEdgeRecord> {
    let active = ActiveTriangles::new(mesh);
    let mut table = Vec::with_capacity(3 * mesh.triangle_count());
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if !active.get(t) {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let (first, second) = (a.min(b), a.max(b));
            table.push(HalfEdgeRecord {
                bbsa: edge_bbsa(
                    mesh.positions[first as usize],
                    mesh.positions[second as usize],
                ),
                first,
                second,
                triangle: t as u32,
            });
        }
    }
    table
}

/// The table sorted descending by [BBSA, first, second]; equal keys keep input order.
pub fn sorted_half_edge_table(mesh: &TriMesh) -> Vec<HalfEdgeRecord> {
    let mut table = half_edge_table(mesh);
    table.sort_by_key(|r| std::cmp::Reverse(r.key()));
    table
}

/// Whether triangles `a` and `b` traverse edge `{first, second}` in opposite directions.
#[inline]
fn opposite(mesh: &TriMesh, a: u32, b: u32, [first, second]: [u32; 2]) -> bool {
    // The edge runs first → second in a triangle exactly when `second` follows `first`.
    let runs_forward = |t: u32| {
        let tri = mesh.triangles[t as usize];
        let k = tri.iter().position(|&v| v == first).unwrap_or(0);
        tri[(k + 1) % 3] == second
    };
    runs_forward(a) != runs_forward(b)
}

/// Pair `a` and `b` when both are free and `edge` runs opposite ways in them.
#[inline]
fn try_pair(mesh: &TriMesh, partner: &mut [u32], a: u32, b: u32, edge: [u32; 2]) {
    if a != b
        && partner[a as usize] == UNPAIRED
        && partner[b as usize] == UNPAIRED
        && opposite(mesh, a, b, edge)
    {
        partner[a as usize] = b;
        partner[b as usize] = a;
    }
}

/// The published procedure, plainly: sort the whole table, scan neighbours.
pub fn pair_sah_reference(mesh: &TriMesh) -> Pairing {
    let table = sorted_half_edge_table(mesh);
    let mut partner = vec![UNPAIRED; mesh.triangle_count()];
    for w in table.windows(2) {
        if w[0].key() == w[1].key() {
            try_pair(
                mesh,
                &mut partner,
                w[0].triangle,
                w[1].triangle,
                [w[0].first, w[0].second],
            );
        }
    }
    Pairing::from_partners(&partner)
}

/// The same pairing as [`pair_sah_reference`], fast: twins found by blocks of vertices,
/// then the Suitor algorithm instead of a sort and a scan. (Meshes past the fast
/// route's index limits, 2³¹ − 1 vertices or 2³⁰ triangles, take the reference.)
///
/// A couple's key is `[BBSA bits, first vertex, second vertex, rank on its edge]`
/// (most significant first): the table's sort key, and for the couples of one edge of
/// three or more half-edges, the earlier couple in table order ranks higher. Keys are
/// distinct, so the locally dominant matching Suitor finds is the scan's.
pub fn pair_sah(mesh: &TriMesh) -> Pairing {
    pair_sah_with(mesh, has_avx512())
}

/// [`pair_sah`], with the twin search's AVX-512 kernels when `avx512` (which the CPU
/// must have) or its scalar loops (the reference that tests hold the kernels to).
pub(super) fn pair_sah_with(mesh: &TriMesh, avx512: bool) -> Pairing {
    if mesh.positions.len() > MAX_VERTICES || mesh.triangle_count() > MAX_LINKED_TRIANGLES {
        return pair_sah_reference(mesh);
    }
    let keys = VertexKeys { mesh };
    let couples = Couples::link(&keys, keys.rank_sides(avx512), avx512);
    match_greedily(couples, |t| keys.side_keys(t).unwrap_or_default(), avx512)
}

/// The most vertices [`pair_sah`]'s fast route takes: a [`VertexHalfEdge`] keeps the
/// direction in the top bit of the vertex index.
const MAX_VERTICES: usize = (1 << 31) - 1;

/// Vertices per block of the twin search: a block's half-edges (about six per vertex,
/// 12 bytes each) and its run counts stay in the core's cache while it is searched.
const BLOCK_VERTICES: usize = 1 << BLOCK_SHIFT;
/// log2 [`BLOCK_VERTICES`].
const BLOCK_SHIFT: u32 = 12;

/// The twin search of indexed input: blocks of [`BLOCK_VERTICES`] smaller vertices, a
/// run per smaller vertex.
struct VertexKeys<'m> {
    mesh: &'m TriMesh,
}

impl VertexKeys<'_> {
    /// The couple keys of triangle `t`'s sides, if it takes part (valid indices,
    /// finite corners).
    #[inline(always)]
    fn side_keys(&self, t: usize) -> Option<[u128; 3]> {
        let mesh = self.mesh;
        let tri = mesh.triangles[t];
        if !has_edges(&tri, mesh.positions.len()) {
            return None;
        }
        let corners = tri.map(|v| mesh.positions[v as usize]);
        if !corners.iter().all(|c| c.is_finite()) {
            return None;
        }
        let key = |k: usize| {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let bbsa = edge_bbsa(corners[k], corners[(k + 1) % 3]);
            couple_key(bbsa, a.min(b), a.max(b), 0)
        };
        Some([key(0), key(1), key(2)])
    }

    /// The ranks of triangle `t`'s sides' keys (as in [`side_ranks`]), or `None` for a
    /// triangle that takes no part.
    #[inline]
    fn side_ranks(&self, t: usize) -> Option<u8> {
        self.side_keys(t).as_ref().map(side_ranks)
    }

    /// The first pass of [`Couples::link`], with [`VertexKeys::rank_and_count_avx512`]
    /// when `avx512` (which the CPU must have).
    fn rank_sides(&self, avx512: bool) -> RankedSides {
        let n = self.mesh.triangle_count();
        let part_len = triangle_part_len(n);
        let parts = rayon::iter::repeat_n((), n.div_ceil(part_len));
        RankedSides::by_parts(n, self.blocks(), parts, |p, (), ranks, count| {
            let done = if avx512 {
                // SAFETY: `avx512` says the CPU has the features.
                unsafe { self.rank_and_count_avx512(p * part_len, ranks, count) }
            } else {
                0
            };
            for (i, r) in ranks.iter_mut().enumerate().skip(done) {
                let t = p * part_len + i;
                if let Some(rank) = self.side_ranks(t) {
                    *r = rank;
                    for (_, b) in self.half_edges(t, rank) {
                        count[b] += 1;
                    }
                }
            }
        })
    }
}

impl EdgeKeys for VertexKeys<'_> {
    type HalfEdge = VertexHalfEdge;

    fn blocks(&self) -> usize {
        self.mesh.positions.len().div_ceil(BLOCK_VERTICES).max(1)
    }

    fn runs(&self, b: usize, _: usize) -> usize {
        BLOCK_VERTICES.min(self.mesh.positions.len() - b * BLOCK_VERTICES)
    }

    /// In the blocks of their smaller vertices.
    #[inline]
    fn half_edges(&self, t: usize, ranks: u8) -> [(VertexHalfEdge, usize); 3] {
        let tri = self.mesh.triangles[t];
        std::array::from_fn(|k| {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let h = VertexHalfEdge {
                smaller: a.min(b),
                other: a.max(b) | if a < b { VertexHalfEdge::FORWARD } else { 0 },
                link: (t as u32) << 2 | rank_of_side(ranks, k as u32),
            };
            (h, h.smaller as usize / BLOCK_VERTICES)
        })
    }

    #[inline]
    fn run(&self, h: &VertexHalfEdge, _: usize) -> usize {
        h.smaller as usize % BLOCK_VERTICES
    }

    /// The larger vertex: a run's half-edges share the smaller.
    fn exact_edge(&self, h: &VertexHalfEdge) -> u128 {
        h.edge() as u128
    }

    fn extra_key(&self, h: &VertexHalfEdge, rank: u32) -> u128 {
        let [p, q] = [h.smaller, h.larger()].map(|v| self.mesh.positions[v as usize]);
        couple_key(edge_bbsa(p, q), h.smaller, h.larger(), rank)
    }

    /// Whether the two run opposite ways.
    #[inline]
    fn may_couple(&self, a: &VertexHalfEdge, b: &VertexHalfEdge) -> bool {
        (a.other ^ b.other) & VertexHalfEdge::FORWARD != 0
    }

    /// The kernel is [`avx512::couple_block_avx512`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,popcnt")]
    unsafe fn couple_block_avx512(
        &self,
        sorted: &[VertexHalfEdge],
        links: &Links,
        words: &mut Vec<u32>,
        declined: &mut Vec<u32>,
    ) -> bool {
        // SAFETY: the caller keeps the trait method's contract, which is the kernel's.
        unsafe { avx512::couple_block_avx512(sorted, links, words, declined) }
    }

    /// The kernel is [`avx512::write_out_avx512`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,popcnt,bmi2")]
    unsafe fn write_out_avx512(
        &self,
        first: usize,
        ranks: &[u8],
        cursor: &mut [u32],
        destination: &SharedSlice<VertexHalfEdge>,
    ) -> usize {
        // SAFETY: the caller keeps the trait method's contract, which is the kernel's.
        unsafe { avx512::write_out_avx512(self, first, ranks, cursor, destination) }
    }
}

/// A half-edge on its way to its smaller vertex's run (three words in this order, which
/// the AVX-512 kernels write and load).
#[derive(Clone, Copy, Default)]
#[repr(C)]
struct VertexHalfEdge {
    /// The smaller vertex.
    smaller: u32,
    /// The larger vertex; the top bit is set when the half-edge runs from the smaller.
    other: u32,
    /// The link to its side (its triangle and the side's rank, as [`NO_LINK`]
    /// describes).
    link: u32,
}

impl VertexHalfEdge {
    const FORWARD: u32 = 1 << 31;

    /// The larger vertex.
    #[inline]
    fn larger(self) -> u32 {
        self.other & !Self::FORWARD
    }
}

impl HalfEdge for VertexHalfEdge {
    type Edge = u32;
    /// A larger vertex past every vertex.
    const NO_EDGE: u32 = !Self::FORWARD;
    const WINDOW: usize = 16;

    #[inline]
    fn edge(&self) -> u32 {
        self.larger()
    }

    #[inline]
    fn triangle(&self) -> u32 {
        self.link >> 2
    }

    #[inline]
    fn rank(&self, _: &[u8]) -> u32 {
        self.link & 3
    }
}

/// The key of the couple of rank `rank` (0 on an edge of two half-edges) on edge
/// `(first, second)` with box area `bbsa`: above 0, as `first < second`.
#[inline]
fn couple_key(bbsa: f32, first: u32, second: u32, rank: u32) -> u128 {
    (bbsa.to_bits() as u128) << 96 | (first as u128) << 64 | (second as u128) << 32 | rank as u128
}

//! Greedy pairing on position-only input with compressed 16-byte edge keys (Aman &
//! Fenney, "Fast Triangle Pairing for Ray Tracing", Imagination, HPG 2024, §"edge key
//! compression").
//!
//! Without shared vertex indices an edge is known by where it is: its key is its box
//! surface area and its midpoint, each quantised to 24 bits, and the record adds the
//! 32-bit half-edge id: 16 bytes. The BBSA keeps its float order by taking the top 24
//! bits of its (positive) IEEE bits, a relative precision of 2⁻¹⁵; midpoints are
//! quantised linearly in the mesh's box. The published procedure sorts the table
//! descending by [BBSA, midpoint] and scans it as in [`super::greedy`]
//! ([`pair_sah_compressed_reference`], plainly).
//!
//! Quantisation can give two different edges one key. A scan that paired them would
//! pair triangles that do not touch, so a candidate pair must also share the edge's two
//! corner positions exactly, in opposite directions; the published procedure takes
//! the key on trust.
//!
//! The fast route, [`pair_sah_compressed`], gives the same pairing with no sort, as
//! the indexed route does (module `suitor`): the half-edges go to blocks by the cell
//! of space their midpoint is in, and to runs within a block by a 32-bit signature of
//! their key, which they carry in its place; twins are the half-edges of one signature
//! in a run that join the same corners opposite ways (so of one key), and the Suitor
//! algorithm (on several threads, its parallel form) finds the scan's matching. A
//! block's triangles are near each other in space, and so, in a scanned mesh's order,
//! in memory: the corner check of each couple is done there, its reads prefetched as
//! the block is sorted. The keys are computed twice, to count and to write out the
//! half-edges, and kept nowhere. Where the CPU has AVX-512, they are computed 16
//! triangles at a time (`Quantiser::group_keys_avx512`) and a block's twins are found
//! 16 half-edges at a time (the `couple_block_avx512` of `PositionKeys`); the scalar
//! loops are the reference. Cost: O(T) time; 8 bytes per half-edge for the blocks
//! (signature and id), 4 for the links.

#[cfg(target_arch = "x86_64")]
mod avx512;

use super::suitor::{
    match_greedily, rank_of_side, side_ranks, Couples, EdgeKeys, HalfEdge, Links, RankedSides,
    MAX_LINKED_TRIANGLES,
};
use super::{edge_bbsa, ActiveTriangles, Pairing, UNPAIRED};
use crate::geom::Aabb;
use crate::mesh::{triangle_part_len, SharedSlice, TriMesh};
use crate::simd::has_avx512;
use glam::Vec3;
use rayon::prelude::*;

/// Bits per quantised key field.
const FIELD_BITS: u32 = 24;
/// The largest quantised midpoint coordinate.
const FIELD_MAX: f32 = ((1u32 << FIELD_BITS) - 1) as f32;

/// Greedy pairing keyed by position: vertex indices are used only to read corners.
/// The same pairing as [`pair_sah_compressed_reference`] (which meshes past 2³⁰
/// triangles take).
pub fn pair_sah_compressed(mesh: &TriMesh) -> Pairing {
    pair_sah_compressed_with(mesh, has_avx512())
}

/// [`pair_sah_compressed`], with the AVX-512 keys when `avx512` (which the CPU must
/// have) or the scalar keys (the reference that tests hold them to).
pub(super) fn pair_sah_compressed_with(mesh: &TriMesh, avx512: bool) -> Pairing {
    if mesh.triangle_count() > MAX_LINKED_TRIANGLES {
        return pair_sah_compressed_reference(mesh);
    }
    let (keys, ranked) = PositionKeys::new(mesh, avx512);
    let couples = Couples::link(&keys, ranked, avx512);
    match_greedily(
        couples,
        |t| keys.side_keys(t).map(|key| couple_key(key, 0)),
        avx512,
    )
}

/// The published procedure, plainly: the records sorted by key, runs of equal keys
/// scanned from the largest, neighbours in table order paired when both are free.
pub fn pair_sah_compressed_reference(mesh: &TriMesh) -> Pairing {
    let active = ActiveTriangles::new(mesh);
    let quantiser = Quantiser::new(mesh);
    let n = mesh.triangle_count();
    let mut records: Vec<u128> = Vec::with_capacity(3 * n);
    for t in (0..n).filter(|&t| active.get(t)) {
        for (k, key) in quantiser.side_keys(mesh, t).into_iter().enumerate() {
            records.push(key_bits(key) << 32 | (3 * t + k) as u128);
        }
    }
    // Ascending by key, then id: equal keys stay in table order.
    records.sort_unstable();
    let mut partner = vec![UNPAIRED; n];
    // Walk runs of equal keys from the largest; within a run, in table order.
    let mut end = records.len();
    while end > 0 {
        let key = records[end - 1] >> 32;
        let mut start = end - 1;
        while start > 0 && records[start - 1] >> 32 == key {
            start -= 1;
        }
        for w in records[start..end].windows(2) {
            let (ha, hb) = (w[0] as u32 as usize, w[1] as u32 as usize);
            let (a, b) = (ha / 3, hb / 3);
            if a != b
                && partner[a] == UNPAIRED
                && partner[b] == UNPAIRED
                && corners_opposite(mesh, [a, ha % 3], [b, hb % 3])
            {
                partner[a] = b as u32;
                partner[b] = a as u32;
            }
        }
        end = start;
    }
    Pairing::from_partners(&partner)
}

/// Whether half-edges `a` and `b`, each `[triangle, side]`, join the same two corner
/// positions, opposite ways. (Side `k` runs from corner `k` to the next.) Corners that
/// are one vertex are one position, read only where they are not.
#[inline]
fn corners_opposite(mesh: &TriMesh, a: [usize; 2], b: [usize; 2]) -> bool {
    let vertex = |[t, k]: [usize; 2], offset: usize| mesh.triangles[t][(k + offset) % 3];
    let [a0, a1, b0, b1] = [vertex(a, 0), vertex(a, 1), vertex(b, 0), vertex(b, 1)];
    let same = |u: u32, v: u32| u == v || mesh.positions[u as usize] == mesh.positions[v as usize];
    same(a0, b1) && same(a1, b0)
}

/// The 96-bit key in three words, most significant first: [BBSA, x, y, z], 24 bits
/// each.
pub(super) type EdgeKey = [u32; 3];

/// The quantised midpoint `[x, y, z]` of a key (as [`Quantiser::key`] packs it).
#[inline]
fn midpoint_fields([high, middle, low]: EdgeKey) -> [u32; 3] {
    [high << 16 | middle >> 16, middle << 8 | low >> 24, low].map(|f| f & 0xff_ffff)
}

/// The key as one number (its order is the key's).
#[inline]
fn key_bits([high, middle, low]: EdgeKey) -> u128 {
    (high as u128) << 64 | (middle as u128) << 32 | low as u128
}

/// The key of the couple of rank `rank` (0 on an edge of two half-edges) on the edge
/// with key `key`: above 0, as the matching needs, though an edge key may be 0.
#[inline]
fn couple_key(key: EdgeKey, rank: u32) -> u128 {
    key_bits(key) << 32 | (rank as u128 + 1)
}

/// The quantisation of edge keys in the box of the mesh's finite positions (which holds
/// every triangle that takes part; one pass over the vertices where the triangles'
/// boxes would take three gathers per triangle), and the grid of cells of that box
/// that blocks the twin search.
pub(super) struct Quantiser {
    min: Vec3,
    scale: Vec3,
    /// Cells per axis of the grid, log2.
    cell_bits: u32,
}

impl Quantiser {
    fn new(mesh: &TriMesh) -> Self {
        // A surface crosses about (cells per axis)² cells.
        let cell_bits = ((3 * mesh.triangle_count() / BLOCK_HALF_EDGES)
            .max(1)
            .ilog2()
            / 2)
        .min(8);
        // A plain loop per chunk: the pool's per-element fold closure was not always
        // inlined (a call per vertex).
        let bounds = mesh
            .positions
            .par_chunks(1 << 14)
            .map(|chunk| {
                let mut b = Aabb::EMPTY;
                for &p in chunk {
                    if p.is_finite() {
                        b = b.grown_by_point(p);
                    }
                }
                b
            })
            .reduce(|| Aabb::EMPTY, Aabb::union);
        Self {
            min: bounds.min,
            scale: Vec3::splat(FIELD_MAX) / bounds.extent().max(Vec3::splat(f32::MIN_POSITIVE)),
            cell_bits,
        }
    }

    /// How many cells the grid has.
    fn cells(&self) -> usize {
        1 << (3 * self.cell_bits)
    }

    /// The cell of the midpoint of the edge with key `key`.
    #[inline]
    fn cell(&self, key: EdgeKey) -> usize {
        let [x, y, z] = midpoint_fields(key).map(|f| f as usize >> (FIELD_BITS - self.cell_bits));
        (x << self.cell_bits | y) << self.cell_bits | z
    }

    /// The key of edge `p–q` (symmetric in `p` and `q`).
    #[inline]
    fn key(&self, p: Vec3, q: Vec3) -> EdgeKey {
        // Nearest step, by truncating `x + 0.5` (`f32::round` is a library call on
        // baseline x86-64); NaN lands on 0. In range, a cast to i32 is one
        // instruction, where one to u32 goes through i64.
        let mid = ((p + q) * 0.5 - self.min) * self.scale;
        let [x, y, z] = mid
            .to_array()
            .map(|f| (f.clamp(0.0, FIELD_MAX) + 0.5) as i32 as u32);
        let bbsa = edge_bbsa(p, q).to_bits() >> (31 - FIELD_BITS);
        [bbsa << 8 | x >> 16, x << 16 | y >> 8, y << 24 | z]
    }

    /// The keys of triangle `t`'s sides, one that takes part.
    #[inline]
    fn side_keys(&self, mesh: &TriMesh, t: usize) -> [EdgeKey; 3] {
        let c = mesh.corners(t);
        [0, 1, 2].map(|k| self.key(c[k], c[(k + 1) % 3]))
    }
}

/// The 32-bit signature of key `[x, y, z]` is `a·x ⊕ b·y ⊕ z` (wrapping) with these
/// `[a, b]`.
const SIGNATURE_FACTORS: [u32; 2] = [0x9E37_79B1, 0x85EB_CA77];

/// The signature of `key`, which its half-edges carry in its place: two half-edges
/// of one signature that join the same corners opposite ways have one key, as a key
/// is a function of the two corners' positions; others are told apart by their keys
/// ([`EdgeKeys::exact_edge`]), read again only then.
#[inline]
fn signature([x, y, z]: EdgeKey) -> u32 {
    let [a, b] = SIGNATURE_FACTORS;
    a.wrapping_mul(x) ^ b.wrapping_mul(y) ^ z
}

/// Half-edges per block of the twin search, roughly: a cell of space. A block's
/// half-edges (8 bytes each) stay in the core's L2 cache; smaller blocks mean more of
/// them, each a stream that the write-out by block keeps open (2¹¹ was slower).
const BLOCK_HALF_EDGES: usize = 1 << 13;

/// The twin search of position-only input: blocks by the cell of space the edge's
/// midpoint is in, runs within a block by a hash of the key.
pub(super) struct PositionKeys<'m> {
    mesh: &'m TriMesh,
    /// The keys' quantisation, whose cells are the blocks.
    pub(super) quantiser: Quantiser,
    /// Whether the corners are read to check couples: vertices not shared (more
    /// vertices than triangles, as in a triangle soup), so twins' corners are
    /// different vertices, whose positions [`corners_opposite`] compares.
    corners_read: bool,
}

impl<'m> PositionKeys<'m> {
    /// The keys of `mesh`'s half-edges, and the first pass of [`Couples::link`] on
    /// them, with [`Quantiser::rank_and_count_avx512`] when `avx512` (which the CPU
    /// must have). The keys are not kept: the write-out computes them again, as that
    /// costs less than writing 12 bytes a half-edge to fresh memory and reading them
    /// back.
    pub(super) fn new(mesh: &'m TriMesh, avx512: bool) -> (Self, RankedSides) {
        let quantiser = Quantiser::new(mesh);
        let active = ActiveTriangles::new(mesh);
        let n = mesh.triangle_count();
        // A multiple of 16: parts of whole groups.
        let part_len = triangle_part_len(n);
        let parts = rayon::iter::repeat_n((), n.div_ceil(part_len));
        let ranked = RankedSides::by_parts(n, quantiser.cells(), parts, |p, (), ranks, count| {
            let first = p * part_len;
            let done = if avx512 {
                // SAFETY: `avx512` says the CPU has the features; the part's triangles
                // are the mesh's.
                unsafe { quantiser.rank_and_count_avx512(mesh, first, ranks, count) }
            } else {
                0
            };
            for (i, r) in ranks.iter_mut().enumerate().skip(done) {
                if active.get(first + i) {
                    let keys = quantiser.side_keys(mesh, first + i);
                    *r = side_ranks(&keys);
                    for key in keys {
                        count[quantiser.cell(key)] += 1;
                    }
                }
            }
        });
        let keys = Self {
            mesh,
            quantiser,
            corners_read: mesh.positions.len() > n,
        };
        (keys, ranked)
    }

    /// The keys of triangle `t`'s sides, one that takes part.
    #[inline]
    pub(super) fn side_keys(&self, t: usize) -> [EdgeKey; 3] {
        self.quantiser.side_keys(self.mesh, t)
    }

    /// The key of half-edge `h`.
    #[inline]
    fn key(&self, h: &PositionHalfEdge) -> EdgeKey {
        let [t, k] = h.triangle_side();
        self.side_keys(t)[k]
    }
}

impl EdgeKeys for PositionKeys<'_> {
    type HalfEdge = PositionHalfEdge;

    fn blocks(&self) -> usize {
        self.quantiser.cells()
    }

    /// A power of two, a run for every 2–4 half-edges: in the scalar search's 8-wide
    /// window, fewer runs cost less than the narrower window they would allow (one run
    /// per 1–2 half-edges in a 4-wide window was slower). The block kernel's window is as fast with one run per
    /// 2–4 as per 4–8, and runs longer than 16, which it declines, are rarer.
    fn runs(&self, _: usize, len: usize) -> usize {
        (len / 4).next_power_of_two()
    }

    /// In the cells of the edges' midpoints.
    #[inline]
    fn half_edges(&self, t: usize, _: u8) -> [(PositionHalfEdge, usize); 3] {
        let keys = self.side_keys(t);
        std::array::from_fn(|k| {
            let h = PositionHalfEdge {
                signature: signature(keys[k]),
                id: (t as u32) << 2 | k as u32,
            };
            (h, self.quantiser.cell(keys[k]))
        })
    }

    /// Bits of the signature, mixed.
    #[inline]
    fn run(&self, h: &PositionHalfEdge, runs: usize) -> usize {
        ((h.signature as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) as usize & (runs - 1)
    }

    fn exact_edge(&self, h: &PositionHalfEdge) -> u128 {
        key_bits(self.key(h))
    }

    fn extra_key(&self, h: &PositionHalfEdge, rank: u32) -> u128 {
        couple_key(self.key(h), rank)
    }

    /// The kernel is [`avx512::write_out_avx512`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,popcnt")]
    unsafe fn write_out_avx512(
        &self,
        first: usize,
        ranks: &[u8],
        cursor: &mut [u32],
        destination: &SharedSlice<PositionHalfEdge>,
    ) -> usize {
        // SAFETY: the caller keeps the trait method's contract, which is the kernel's.
        unsafe { avx512::write_out_avx512(self, first, ranks, cursor, destination) }
    }

    /// The kernel is [`avx512::couple_block_avx512`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,popcnt")]
    unsafe fn couple_block_avx512(
        &self,
        sorted: &[PositionHalfEdge],
        links: &Links,
        words: &mut Vec<u32>,
        declined: &mut Vec<u32>,
    ) -> bool {
        // SAFETY: the caller keeps the trait method's contract, which is the kernel's.
        unsafe { avx512::couple_block_avx512(self, sorted, links, words, declined) }
    }

    /// The triangle and its rank byte at stage 0, its corners at stage 1 (the triangle
    /// is in cache by then) when they will be read: the block's corner checks then find
    /// them there, where their misses were the twin search's largest cost (on welded
    /// input, prefetching the corners too cost more than it saved). The rank bytes are
    /// fetched too: the block kernel gathers them.
    #[inline]
    fn prefetch_couple(&self, h: &PositionHalfEdge, stage: u32, ranks: &[u8]) {
        let [t, k] = h.triangle_side();
        if stage == 0 {
            crate::prefetch(&self.mesh.triangles[t]);
            crate::prefetch(&ranks[t]);
        } else if self.corners_read {
            let tri = self.mesh.triangles[t];
            crate::prefetch(&self.mesh.positions[tri[k] as usize]);
            crate::prefetch(&self.mesh.positions[tri[(k + 1) % 3] as usize]);
        }
    }

    /// Of different triangles, joining the same corners opposite ways.
    #[inline]
    fn may_couple(&self, a: &PositionHalfEdge, b: &PositionHalfEdge) -> bool {
        a.triangle() != b.triangle()
            && corners_opposite(self.mesh, a.triangle_side(), b.triangle_side())
    }
}

/// A half-edge and its key's [`signature`] (two words in this order, which the AVX-512
/// kernels store and load): 8 bytes where the key would make 16, and no read of the
/// key when the blocks are searched (keeping the keys, and reading each half-edge's key
/// back by id in the blocks' pass, was slower).
#[derive(Clone, Copy, Default)]
#[repr(C)]
pub(super) struct PositionHalfEdge {
    signature: u32,
    /// Side `k` of triangle `t`, as `t << 2 | k`.
    id: u32,
}

impl PositionHalfEdge {
    /// `[t, k]`: side `k` of triangle `t`.
    #[inline]
    fn triangle_side(&self) -> [usize; 2] {
        [(self.id >> 2) as usize, (self.id & 3) as usize]
    }
}

impl HalfEdge for PositionHalfEdge {
    /// The signature.
    type Edge = u32;
    /// A signature that a half-edge may have too: a spare lane that matches it is a
    /// twin that `may_couple` turns down, or makes the run [`couple_run`]'s.
    const NO_EDGE: u32 = u32::MAX;
    const WINDOW: usize = 8;

    #[inline]
    fn edge(&self) -> u32 {
        self.signature
    }

    #[inline]
    fn triangle(&self) -> u32 {
        self.id >> 2
    }

    #[inline]
    fn rank(&self, ranks: &[u8]) -> u32 {
        rank_of_side(ranks[(self.id >> 2) as usize], self.id & 3)
    }
}

#[cfg(test)]
mod tests {
    use super::super::suitor::{couple_runs, NO_LINK};
    use super::*;
    use crate::mesh::SharedSlice;

    /// The quad's two triangles, [0, 1, 2] and [2, 1, 3]; the half-edges of its
    /// shared edge, side 1 of triangle 0 (1 → 2) and side 0 of triangle 1 (2 → 1);
    /// and side 1 of triangle 1 (1 → 3) given their signature, as if two keys
    /// collided.
    fn quad_with_a_stranger() -> (TriMesh, [PositionHalfEdge; 3]) {
        let quad = TriMesh::new(
            vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE],
            vec![[0, 1, 2], [2, 1, 3]],
        );
        let (keys, _) = PositionKeys::new(&quad, false);
        let half_edge = |t: usize, k: usize| keys.half_edges(t, 0)[k].0;
        let [first, second] = [half_edge(0, 1), half_edge(1, 0)];
        assert_eq!(first.signature, second.signature);
        let stranger = PositionHalfEdge {
            signature: first.signature,
            ..half_edge(1, 1)
        };
        assert_ne!(keys.key(&stranger), keys.key(&first));
        (quad, [first, second, stranger])
    }

    /// Searches `block` (one run) as the AVX-512 kernel, when `avx512`, or as the
    /// scalar search does: whether the kernel took it, the places it declined, and
    /// the links written.
    fn search(
        mesh: &TriMesh,
        block: &[PositionHalfEdge],
        avx512: bool,
    ) -> (bool, Vec<u32>, Vec<u32>) {
        let (keys, ranked) = PositionKeys::new(mesh, avx512);
        let mut across = vec![NO_LINK; 6];
        let links = Links {
            across: SharedSlice(across.as_mut_ptr()),
            ranks: &ranked.side_ranks,
        };
        let (mut words, mut declined, mut extra) = (Vec::new(), Vec::new(), Vec::new());
        let done = if avx512 {
            // SAFETY: the CPU has the features; `across` is this thread's.
            unsafe { keys.couple_block_avx512(block, &links, &mut words, &mut declined) }
        } else {
            couple_runs(block, &[block.len() as u32], &keys, &links, &mut extra);
            assert!(extra.is_empty());
            true
        };
        (done, declined, across)
    }

    /// The links of the quad's shared edge: each side's slot is its rank's, and names
    /// the other triangle and its rank.
    fn shared_edge_links(mesh: &TriMesh) -> Vec<u32> {
        let (_, ranked) = PositionKeys::new(mesh, false);
        let ranks = &ranked.side_ranks;
        let [rank_first, rank_second] = [rank_of_side(ranks[0], 1), rank_of_side(ranks[1], 0)];
        let mut expected = vec![NO_LINK; 6];
        expected[rank_first as usize] = 1 << 2 | rank_second;
        expected[3 + rank_second as usize] = rank_first;
        expected
    }

    /// The block kernel couples two half-edges of one signature only when they join
    /// the same corners opposite ways (and so have one key), and declines a half-edge
    /// with two matches, leaving the run to the exact search.
    #[test]
    fn block_kernel_couples_one_signature_by_corners() {
        if !has_avx512() {
            return;
        }
        let (quad, [first, second, stranger]) = quad_with_a_stranger();
        let unlinked = vec![NO_LINK; 6];
        assert_eq!(
            search(&quad, &[first, second], true),
            (true, vec![], shared_edge_links(&quad))
        );
        assert_eq!(
            search(&quad, &[first, stranger], true),
            (true, vec![], unlinked.clone())
        );
        assert_eq!(
            search(&quad, &[first, second, stranger], true),
            (true, vec![0, 1, 2], unlinked)
        );
    }

    /// The scalar search tells a run's edges apart by their keys where signatures
    /// collide: the shared edge's two half-edges couple, the stranger stays alone.
    #[test]
    fn scalar_search_tells_keys_of_one_signature_apart() {
        let (quad, [first, second, stranger]) = quad_with_a_stranger();
        let linked = (true, vec![], shared_edge_links(&quad));
        assert_eq!(search(&quad, &[first, second, stranger], false), linked);
        assert_eq!(search(&quad, &[stranger, first, second], false), linked);
        assert_eq!(
            search(&quad, &[first, stranger], false),
            (true, vec![], vec![NO_LINK; 6])
        );
    }
}

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
//! of space their midpoint is in, and to runs within a block by a hash of their key;
//! twins are the half-edges of one key in a run, and the Suitor algorithm (on several
//! threads, its parallel form) finds the scan's matching. A block's triangles are
//! near each other in space, and so, in a scanned mesh's order, in memory: the corner
//! check of each couple is done there, its reads prefetched as the block is sorted.
//! Where the CPU has AVX-512, the keys are computed 16 triangles at a time
//! (`Quantiser::keys_avx512`) and a block's twins are found 16 half-edges at a time
//! (the `couple_block_avx512` of `PositionKeys`); the scalar loops are the reference.
//! Cost: O(T) time; 12 bytes per half-edge for the keys, 4 for the blocks (ids), 4 for
//! the links.

#[cfg(target_arch = "x86_64")]
use super::suitor::{
    append_lanes_avx512, block_words_avx512, decline_lanes_avx512, edge_bbsa_avx512,
    for_each_block_avx512, lanes_at_avx512, load_block_group, load_group_avx512, load_records,
    load_triangles_avx512, rank_and_count_lanes, rank_of_side_lanes, records_of_lanes_avx512,
    window_matches_avx512, write_links_avx512, MAX_GATHER_VERTICES,
};
use super::suitor::{
    has_avx512, match_greedily, rank_of_side, side_ranks, Couples, EdgeKeys, HalfEdge, Links,
    RankedSides, MAX_LINKED_TRIANGLES,
};
use super::{edge_bbsa, ActiveTriangles, Pairing, UNPAIRED};
use crate::geom::Aabb;
use crate::mesh::{triangle_part_len, SharedSlice, TriMesh};
use crate::pages::vec_on_huge_pages;
use glam::Vec3;
use rayon::prelude::*;
use std::mem::MaybeUninit;

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
        |t| [0, 1, 2].map(|k| couple_key(keys.side_key(t, k), 0)),
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
        let corners = mesh.corners(t);
        for k in 0..3 {
            let key = quantiser.key(corners[k], corners[(k + 1) % 3]);
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
struct Quantiser {
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
        // inlined (a call per vertex, 4 ms on the dragon).
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

    /// [`Quantiser::cell`] in AVX-512 lanes, of three sides' keys (`[side][word]`).
    ///
    /// # Safety
    /// The CPU has AVX-512 F.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn cells_avx512(
        &self,
        keys: &[[std::arch::x86_64::__m512i; 3]; 3],
    ) -> [std::arch::x86_64::__m512i; 3] {
        use std::arch::x86_64::*;
        let field = _mm512_set1_epi32((1 << FIELD_BITS) - 1);
        let cell_shift = _mm512_set1_epi32((FIELD_BITS - self.cell_bits) as i32);
        let cell_bits = _mm512_set1_epi32(self.cell_bits as i32);
        // As `midpoint_fields`, then `cell`.
        let cell = |[high, middle, low]: [__m512i; 3]| {
            let fields = [
                _mm512_or_si512(
                    _mm512_slli_epi32::<16>(high),
                    _mm512_srli_epi32::<16>(middle),
                ),
                _mm512_or_si512(_mm512_slli_epi32::<8>(middle), _mm512_srli_epi32::<24>(low)),
                low,
            ];
            let coordinate =
                |f: usize| _mm512_srlv_epi32(_mm512_and_si512(fields[f], field), cell_shift);
            let [x, y, z] = [coordinate(0), coordinate(1), coordinate(2)];
            let xy = _mm512_or_si512(_mm512_sllv_epi32(x, cell_bits), y);
            _mm512_or_si512(_mm512_sllv_epi32(xy, cell_bits), z)
        };
        [cell(keys[0]), cell(keys[1]), cell(keys[2])]
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

    /// The keys of the sides of triangles `first..`, 16 at a time, into `sides` (laid
    /// out as [`key_slot`] says; [`EXCLUDED_KEY`]s for a triangle that takes no part),
    /// as [`Quantiser::key`] gives them: the same floating-point operations in the same
    /// order, lane-wise, so the same bits. While they are in registers, the triangles
    /// are ranked into `ranks` (one byte each, from `first`) and their half-edges
    /// counted by cell into `count`, lane-wise as the scalar pass does
    /// ([`rank_and_count_lanes`]): on the dragon, one core, Zen 4, the first pass of
    /// [`Couples::link`] took 3.5–5.8 ms on its own, reading the keys back. Returns how
    /// many triangles it keyed (a multiple of 16, whole groups of the mesh's
    /// triangles; none past [`MAX_GATHER_VERTICES`] vertices).
    ///
    /// # Safety
    /// The CPU has AVX-512 F and POPCNT; `first` is a multiple of 16 and `sides`
    /// holds the sides of triangles from `first`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,popcnt")]
    unsafe fn keys_avx512(
        &self,
        mesh: &TriMesh,
        first: usize,
        sides: &mut [MaybeUninit<EdgeKey>],
        ranks: &mut [u8],
        count: &mut [u32],
    ) -> usize {
        use std::arch::x86_64::*;
        if mesh.positions.len() > MAX_GATHER_VERTICES {
            return 0;
        }
        let done = ranks.len() / 16 * 16;
        let words = sides.as_mut_ptr() as *mut i32;
        let [min, scale] = [self.min, self.scale].map(|v| v.to_array().map(|c| _mm512_set1_ps(c)));
        let (zero, half) = (_mm512_setzero_ps(), _mm512_set1_ps(0.5));
        let field_max = _mm512_set1_ps(FIELD_MAX);
        for g in (0..done).step_by(16) {
            let (_, corner, active) = load_triangles_avx512(mesh, first + g);
            let side_keys = |k: usize| {
                let (p, q) = (&corner[k], &corner[(k + 1) % 3]);
                // As `key`; `max` gives 0 for NaN, which lands on 0 all the same.
                let field = |axis: usize| {
                    let sum = _mm512_mul_ps(_mm512_add_ps(p[axis], q[axis]), half);
                    let mid = _mm512_mul_ps(_mm512_sub_ps(sum, min[axis]), scale[axis]);
                    let clamped = _mm512_min_ps(_mm512_max_ps(mid, zero), field_max);
                    _mm512_cvttps_epi32(_mm512_add_ps(clamped, half))
                };
                let [x, y, z] = [field(0), field(1), field(2)];
                let bbsa = _mm512_srli_epi32::<{ 31 - FIELD_BITS }>(_mm512_castps_si512(
                    edge_bbsa_avx512(p, q),
                ));
                let key = [
                    _mm512_or_si512(_mm512_slli_epi32::<8>(bbsa), _mm512_srli_epi32::<16>(x)),
                    _mm512_or_si512(_mm512_slli_epi32::<16>(x), _mm512_srli_epi32::<8>(y)),
                    _mm512_or_si512(_mm512_slli_epi32::<24>(y), z),
                ];
                let excluded = |word| _mm512_mask_blend_epi32(active, _mm512_set1_epi32(-1), word);
                let key = [excluded(key[0]), excluded(key[1]), excluded(key[2])];
                let at = words.add(9 * g + 48 * k);
                for (v, words) in records_of_lanes_avx512(key).into_iter().enumerate() {
                    _mm512_storeu_si512(at.add(16 * v) as *mut __m512i, words);
                }
                key
            };
            let keys = [side_keys(0), side_keys(1), side_keys(2)];
            let cells = self.cells_avx512(&keys);
            rank_and_count_lanes(&keys, cells, active, &mut ranks[g..g + 16], count);
        }
        done
    }
}

/// Where the key of side `k` of triangle `t` is in [`PositionKeys::keys`]: by groups
/// of 16 triangles (`16g..16g + 16`), in each the 16 keys of side 0, then of side 1,
/// then of side 2. The AVX-512 passes load and store one side's keys of a group as
/// three vectors, where keys in triangle order took a gather or scatter per word. On
/// the dragon, one core, Zen 4, phase timers side by side: keys 17–19 → 15–17 ms,
/// first pass 11.4 → 3.5–5.8, write-out 10–11.5 → 3.8–7.0; reading a block's keys
/// back by id, which now takes a line per side, 10.5–10.9 → 14.4–16.1.
#[inline]
fn key_slot(t: usize, k: usize) -> usize {
    3 * (t & !15) + 16 * k + (t & 15)
}

/// The most triangles the block kernel gathers corners from: vertex `3t + corner` of
/// the triangles must fit a gather's i32 offset, as `3v + axis` of the positions does.
#[cfg(target_arch = "x86_64")]
const MAX_GATHER_TRIANGLES: usize = MAX_GATHER_VERTICES;

/// The key of every side of a triangle that takes no part (no real key: its BBSA
/// field would be a NaN's). The AVX-512 keys write it as words of -1.
const EXCLUDED_KEY: EdgeKey = [u32::MAX; 3];

/// The block kernel's 32-bit signature of key `[x, y, z]` is `a·x ⊕ b·y ⊕ z` (wrapping)
/// with these `[a, b]`.
const SIGNATURE_FACTORS: [u32; 2] = [0x9E37_79B1, 0x85EB_CA77];

/// Half-edges per block of the twin search, roughly: a cell of space. A block's
/// half-edges (16 bytes each) stay in the core's L2 cache; smaller blocks mean more of
/// them, each a stream that the write-out by block keeps open (side by side on the
/// dragon, one core: 2¹¹ took 5% longer in all).
const BLOCK_HALF_EDGES: usize = 1 << 13;

/// How many ids ahead [`PositionKeys`]' `block_half_edges` prefetches keys (32 and 64
/// gained less, 256 and 512 no more).
const KEYS_AHEAD: usize = 128;

/// The twin search of position-only input: blocks by the cell of space the edge's
/// midpoint is in, runs within a block by a hash of the key.
pub(super) struct PositionKeys<'m> {
    mesh: &'m TriMesh,
    /// The key of side `k` of triangle `t` at [`key_slot`]`(t, k)`, [`EXCLUDED_KEY`]
    /// for a triangle that takes no part (and past the last triangle, to a whole
    /// group).
    pub(super) keys: Vec<EdgeKey>,
    /// The keys' quantisation, whose cells are the blocks.
    quantiser: Quantiser,
    /// Whether the corners are read to check couples: vertices not shared (more
    /// vertices than triangles, as in a triangle soup), so twins' corners are
    /// different vertices, whose positions [`corners_opposite`] compares.
    corners_read: bool,
}

impl<'m> PositionKeys<'m> {
    /// The keys of `mesh`'s half-edges, and the first pass of [`Couples::link`] done
    /// on them as they are made, with [`Quantiser::keys_avx512`] when `avx512` (which
    /// the CPU must have).
    pub(super) fn new(mesh: &'m TriMesh, avx512: bool) -> (Self, RankedSides) {
        let quantiser = Quantiser::new(mesh);
        let active = ActiveTriangles::new(mesh);
        let n = mesh.triangle_count();
        // A multiple of 16: parts of whole groups.
        let part_len = triangle_part_len(n);
        let len = 3 * n.next_multiple_of(16);
        // Written once, in place of a fill and then the keys.
        let mut keys: Vec<EdgeKey> = vec_on_huge_pages(len);
        let parts = keys.spare_capacity_mut()[..len].par_chunks_mut(3 * part_len);
        let ranked = RankedSides::by_parts(n, quantiser.cells(), parts, |p, part, ranks, count| {
            let first = p * part_len;
            let done = if avx512 {
                // SAFETY: `avx512` says the CPU has the features; the part starts a
                // group.
                unsafe { quantiser.keys_avx512(mesh, first, part, ranks, count) }
            } else {
                0
            };
            for (g, group) in part.chunks_exact_mut(48).enumerate().skip(done / 16) {
                for lane in 0..16 {
                    let t = first + 16 * g + lane;
                    let sides = if t < n && active.get(t) {
                        let c = mesh.corners(t);
                        [0, 1, 2].map(|k| quantiser.key(c[k], c[(k + 1) % 3]))
                    } else {
                        [EXCLUDED_KEY; 3]
                    };
                    for (k, &key) in sides.iter().enumerate() {
                        group[16 * k + lane].write(key);
                    }
                    if sides[0] != EXCLUDED_KEY {
                        ranks[16 * g + lane] = side_ranks(&sides);
                        for key in sides {
                            count[quantiser.cell(key)] += 1;
                        }
                    }
                }
            }
        });
        // SAFETY: every key was written.
        unsafe { keys.set_len(len) };
        let keys = Self {
            mesh,
            keys,
            quantiser,
            corners_read: mesh.positions.len() > n,
        };
        (keys, ranked)
    }

    /// The key of side `k` of triangle `t`.
    #[inline]
    pub(super) fn side_key(&self, t: usize, k: usize) -> EdgeKey {
        self.keys[key_slot(t, k)]
    }

    /// The blocks of the sides of triangles `first..first + 16` in AVX-512 lanes
    /// (`[side]`), as [`EdgeKeys::block`] computes them.
    ///
    /// # Safety
    /// The CPU has AVX-512 F; `first` is a multiple of 16 and the triangles are the
    /// mesh's.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn blocks_avx512(&self, first: usize) -> [std::arch::x86_64::__m512i; 3] {
        let group = &self.keys[key_slot(first, 0)..key_slot(first, 0) + 48];
        let base = group.as_ptr() as *const i32;
        let side_keys = |k: usize| load_records::<3>(base.add(48 * k), 16);
        self.quantiser
            .cells_avx512(&[side_keys(0), side_keys(1), side_keys(2)])
    }

    /// A hash of `key` (its high half picks the run).
    #[inline]
    fn hash([high, middle, low]: EdgeKey) -> u64 {
        let x = ((high as u64) << 32 | middle as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        (x ^ low as u64).wrapping_mul(0xBF58_476D_1CE4_E5B9)
    }
}

impl EdgeKeys for PositionKeys<'_> {
    type HalfEdge = PositionHalfEdge;

    fn blocks(&self) -> usize {
        self.quantiser.cells()
    }

    /// A power of two, a run for every 2–4 half-edges: in the scalar search's 8-wide
    /// window, fewer runs cost less than the narrower window they would allow (side
    /// by side on the dragon, one run per 1–2 half-edges in a 4-wide window took
    /// 6–8% longer in all). The block kernel's window is as fast with one run per
    /// 2–4 as per 4–8, and runs longer than 16, which it declines, are rarer.
    fn runs(&self, _: usize, len: usize) -> usize {
        (len / 4).next_power_of_two()
    }

    #[inline]
    fn half_edges(&self, t: usize, _: u8) -> [PositionHalfEdge; 3] {
        std::array::from_fn(|k| PositionHalfEdge {
            key: self.side_key(t, k),
            id: (t as u32) << 2 | k as u32,
        })
    }

    /// The half-edge's id: its key is read again from [`PositionKeys::keys`] rather
    /// than moved (a record is 16 bytes, an id 4). Side by side on the dragon, one
    /// core: the write-out took 10 ms, not 20, and the blocks' pass 5 more; 92 ms in
    /// all, not 99.
    type Entry = u32;

    #[inline]
    fn entry(h: &PositionHalfEdge) -> u32 {
        h.id
    }

    /// The keys, prefetched [`KEYS_AHEAD`] ids ahead: a block's ids ascend, but its
    /// cell of space gathers triangles from far apart in a scanned mesh's order, whose
    /// keys the hardware does not see coming (on the dragon, one core, the blocks' pass
    /// took 44 ms, not 49).
    fn block_half_edges<'a>(
        &self,
        ids: &'a [u32],
        rebuilt: &'a mut Vec<PositionHalfEdge>,
    ) -> &'a [PositionHalfEdge] {
        rebuilt.clear();
        // Side k of triangle t: id 4t + k.
        let key = |id: u32| &self.keys[key_slot((id >> 2) as usize, (id & 3) as usize)];
        for &id in &ids[..KEYS_AHEAD.min(ids.len())] {
            crate::prefetch(key(id));
        }
        rebuilt.extend(ids.iter().enumerate().map(|(i, &id)| {
            if let Some(&next) = ids.get(i + KEYS_AHEAD) {
                crate::prefetch(key(next));
            }
            PositionHalfEdge { key: *key(id), id }
        }));
        rebuilt
    }

    /// The cell of the edge's midpoint.
    #[inline]
    fn block(&self, h: &PositionHalfEdge) -> usize {
        self.quantiser.cell(h.key)
    }

    #[inline]
    fn run(&self, h: &PositionHalfEdge, runs: usize) -> usize {
        (Self::hash(h.key) >> 32) as usize & (runs - 1)
    }

    fn extra_key(&self, h: &PositionHalfEdge, rank: u32) -> u128 {
        couple_key(h.key, rank)
    }

    /// Sixteen triangles at a time: their blocks computed again
    /// ([`PositionKeys::blocks_avx512`]), then, block by block
    /// ([`for_each_block_avx512`]), each side's ids in the block compressed to the
    /// block's cursor. On the dragon, one core, side by side: 7.8 ms, where the scalar
    /// pass takes 8.6 (its keys' reads, which this gathers again, are most of it).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,popcnt")]
    unsafe fn write_out_avx512(
        &self,
        first: usize,
        ranks: &[u8],
        cursor: &mut [u32],
        destination: &SharedSlice<u32>,
    ) -> usize {
        use std::arch::x86_64::*;
        let destination = destination.0 as *mut i32;
        let done = ranks.len() / 16 * 16;
        for g in (0..done).step_by(16) {
            let blocks = self.blocks_avx512(first + g);
            let (triangle, _, active) = load_group_avx512(first + g, &ranks[g..]);
            let id = |k: i32| _mm512_or_epi32(triangle, _mm512_set1_epi32(k));
            let ids = [id(0), id(1), id(2)];
            for_each_block_avx512(&blocks, active, |b, in_b| {
                let at = (0..3).fold(cursor[b] as usize, |at, k| {
                    append_lanes_avx512(destination, at, in_b[k], ids[k])
                });
                cursor[b] = at as u32;
            });
        }
        done
    }

    /// The whole block, 16 half-edges at a time, as the indexed kernel does it, on
    /// the 32-bit signature of each key ([`window_matches_avx512`] compares words): a
    /// half-edge with one match of the same key has a twin; one with more matches,
    /// or one of another key (signatures collide), is declined. Each group's
    /// corners' vertices and links are gathered once, and its half-edges' twins'
    /// taken from those of its group and the groups either side. Twins are couples
    /// when of different triangles and joining the same corners opposite ways
    /// ([`EdgeKeys::may_couple`]: one vertex each, or where not, one position,
    /// gathered). Each couple writes its own slot with its twin's link, in one scatter
    /// for 16 half-edges.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,popcnt")]
    unsafe fn couple_block_avx512(
        &self,
        sorted: &[PositionHalfEdge],
        links: &Links,
        words: &mut Vec<u32>,
        declined: &mut Vec<u32>,
    ) -> bool {
        use std::arch::x86_64::*;
        let mesh = self.mesh;
        if mesh.positions.len() > MAX_GATHER_VERTICES
            || mesh.triangle_count() > MAX_GATHER_TRIANGLES
        {
            return false;
        }
        let len = sorted.len();
        let records = sorted.as_ptr() as *const i32;
        let none = _mm512_set1_epi32(-1);
        let [a, b] = SIGNATURE_FACTORS.map(|f| _mm512_set1_epi32(f as i32));
        // Half-edges p to p + 15: their keys and ids, and the lanes that are in the
        // block; past its end, EXCLUDED_KEY, which no half-edge in a block has.
        let load = |p: usize| {
            let ([high, middle, low, id], lanes) = load_block_group::<4>(records, len, p);
            let in_block = |w| _mm512_mask_blend_epi32(lanes, none, w);
            let key = [in_block(high), in_block(middle), in_block(low)];
            (key, id, lanes)
        };
        let word = block_words_avx512(words, len, |p| {
            let (key, ..) = load(p);
            let ab = _mm512_xor_si512(_mm512_mullo_epi32(key[0], a), _mm512_mullo_epi32(key[1], b));
            _mm512_xor_si512(ab, key[2])
        });
        let vertices = mesh.triangles.as_ptr() as *const i32;
        let ranks = links.ranks.as_ptr() as *const i32;
        let (zero, one, three) = (
            _mm512_setzero_si512(),
            _mm512_set1_epi32(1),
            _mm512_set1_epi32(3),
        );
        // A group's key words, triangles, the vertices its sides run from and to, and
        // their links; the lanes in the block.
        let group = |p: usize| {
            let (key, id, lanes) = load(p);
            // Side k of triangle t (id 4t + k) runs from vertex 3t + k of the
            // triangles to vertex 3t + next(k).
            let (t, k) = (_mm512_srli_epi32::<2>(id), _mm512_and_epi32(id, three));
            let first_corner = _mm512_sub_epi32(id, t);
            let wraps = _mm512_cmpeq_epi32_mask(k, _mm512_set1_epi32(2));
            let next_corner = _mm512_mask_sub_epi32(
                _mm512_add_epi32(first_corner, one),
                wraps,
                first_corner,
                _mm512_set1_epi32(2),
            );
            let vertex = |corner| _mm512_mask_i32gather_epi32::<4>(zero, lanes, corner, vertices);
            let [from, to] = [vertex(first_corner), vertex(next_corner)];
            // Its side's rank: the byte of each triangle (four gathered from there),
            // then its two bits of side k.
            let bytes = _mm512_mask_i32gather_epi32::<1>(zero, lanes, t, ranks);
            let link = _mm512_or_epi32(_mm512_slli_epi32::<2>(t), rank_of_side_lanes(bytes, k));
            ([key[0], key[1], key[2], t, from, to, link], lanes)
        };
        let coordinates = mesh.positions.as_ptr() as *const f32;
        let position = |v: __m512i, lanes| {
            let offset = _mm512_mullo_epi32(v, three);
            [0, 1, 2].map(|axis| {
                let at = _mm512_add_epi32(offset, _mm512_set1_epi32(axis));
                _mm512_mask_i32gather_ps::<4>(_mm512_setzero_ps(), lanes, at, coordinates)
            })
        };
        let mut window = [
            ([none, none, none, zero, zero, zero, zero], 0),
            group(0),
            group(16),
        ];
        for p in (0..len).step_by(16) {
            let ([high, middle, low, t, from, to, link], lanes) = window[1];
            let (single, several, at) = window_matches_avx512(word, p, lanes);
            // By value: borrowed, the window went through the stack, whose 512-bit
            // reloads of just-stored vectors stalled (Zen 4: search 16 -> 19 ms).
            let [(before, _), (this, _), (after, _)] = window;
            let twin =
                move |field: usize| lanes_at_avx512([before[field], this[field], after[field]], at);
            let same_key = _mm512_mask_cmpeq_epi32_mask(single, high, twin(0))
                & _mm512_cmpeq_epi32_mask(middle, twin(1))
                & _mm512_cmpeq_epi32_mask(low, twin(2));
            let (twin_from, twin_to) = (twin(4), twin(5));
            // The twin runs from `to` to `from`: its corners are one vertex each, or
            // where not, one position.
            let apart = _mm512_mask_cmpneq_epi32_mask(same_key, t, twin(3));
            let mut opposite = apart
                & _mm512_cmpeq_epi32_mask(from, twin_to)
                & _mm512_cmpeq_epi32_mask(to, twin_from);
            let by_position = apart & !opposite;
            if by_position != 0 {
                let same = |p: [__m512; 3], q: [__m512; 3]| {
                    (0..3).fold(by_position, |m, axis| {
                        _mm512_mask_cmp_ps_mask::<_CMP_EQ_OQ>(m, p[axis], q[axis])
                    })
                };
                let [p_from, p_to, q_from, q_to] =
                    [from, to, twin_from, twin_to].map(|v| position(v, by_position));
                opposite |= same(p_from, q_to) & same(p_to, q_from);
            }
            write_links_avx512(links, opposite, link, twin(6));
            decline_lanes_avx512(declined, p, several | single & !same_key);
            window = [window[1], window[2], group(p + 32)];
        }
        true
    }

    /// The triangle and its rank byte at stage 0, its corners at stage 1 (the triangle
    /// is in cache by then) when they will be read: the block's corner checks then find
    /// them there, where their misses were the twin search's largest cost. On the
    /// dragon, one core, the runs' search took 34 ms as a soup (63 without prefetches)
    /// and, welded, 27 with the triangles prefetched (35 without; prefetching the
    /// corners too cost 6 ms more than it saved). The rank bytes, which the block kernel
    /// gathers: 79.6 against 81.8 ms in all (side by side, min of eight).
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

/// A half-edge and its key (four words in this order, which the block kernel loads).
#[derive(Clone, Copy, Default)]
#[repr(C)]
pub(super) struct PositionHalfEdge {
    key: EdgeKey,
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
    type Edge = EdgeKey;
    const NO_EDGE: EdgeKey = EXCLUDED_KEY;
    const WINDOW: usize = 8;

    #[inline]
    fn edge(&self) -> EdgeKey {
        self.key
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
    use super::super::suitor::NO_LINK;
    use super::*;
    use crate::mesh::SharedSlice;

    /// The block kernel couples two half-edges only when their keys are equal, not
    /// just their signatures: two of the quad's shared edge, keyed apart with one
    /// signature, are declined (their run left to the exact search), and nothing is
    /// written.
    #[test]
    fn block_kernel_tells_keys_with_one_signature_apart() {
        if !has_avx512() {
            return;
        }
        let quad = TriMesh::new(
            vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE],
            vec![[0, 1, 2], [2, 1, 3]],
        );
        let (keys, ranked) = PositionKeys::new(&quad, true);
        // Side 1 of triangle 0 (1 → 2) and side 0 of triangle 1 (2 → 1).
        let [first, second] = [[0, 1], [1, 0]].map(|[t, k]| PositionHalfEdge {
            key: keys.side_key(t, k),
            id: (t << 2 | k) as u32,
        });
        assert_eq!(first.key, second.key);
        let [a, b] = SIGNATURE_FACTORS;
        let signature = |[x, y, z]: EdgeKey| a.wrapping_mul(x) ^ b.wrapping_mul(y) ^ z;
        let [x, y, _] = first.key;
        let mut twin_in_signature = PositionHalfEdge {
            key: [x + 1, y, 0],
            ..second
        };
        twin_in_signature.key[2] = signature(first.key) ^ signature(twin_in_signature.key);
        assert_eq!(signature(twin_in_signature.key), signature(first.key));
        let padded = ranked.side_ranks;
        let ranks = [padded[0], padded[1]];
        let search = |block: &[PositionHalfEdge]| {
            let mut across = vec![NO_LINK; 6];
            let links = Links {
                across: SharedSlice(across.as_mut_ptr()),
                ranks: &padded,
            };
            let (mut words, mut declined) = (Vec::new(), Vec::new());
            // SAFETY: the CPU has the features; `across` is this thread's.
            let done =
                unsafe { keys.couple_block_avx512(block, &links, &mut words, &mut declined) };
            (done, declined, across)
        };
        // Each side's slot is its rank's, and names the other triangle and its rank.
        let [rank_first, rank_second] = [rank_of_side(ranks[0], 1), rank_of_side(ranks[1], 0)];
        let mut expected = vec![NO_LINK; 6];
        expected[rank_first as usize] = 1 << 2 | rank_second;
        expected[3 + rank_second as usize] = rank_first;
        assert_eq!(search(&[first, second]), (true, vec![], expected));
        assert_eq!(
            search(&[first, twin_in_signature]),
            (true, vec![0, 1], vec![NO_LINK; 6])
        );
    }
}

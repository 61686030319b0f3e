//! The AVX-512 kernels of position-keyed pairing (`compressed.rs`): the parent's scalar loops, 16
//! triangles or half-edges at a time. The scalar code is the reference the tests hold
//! them to; every function here needs a CPU with AVX-512 F (and POPCNT and BMI2 where
//! its `target_feature` says), as [`crate::simd::has_avx512`] detects.

use super::*;
use crate::pair::suitor::avx512::{
    block_words_avx512, decline_lanes_avx512, edge_bbsa_avx512, for_each_block_avx512,
    lanes_at_avx512, load_block_group, load_group_avx512, load_triangles_avx512,
    rank_and_count_lanes, rank_of_side_lanes, window_matches_avx512, write_links_avx512,
};
use crate::pair::suitor::MAX_GATHER_VERTICES;

/// How many triangles ahead [`Quantiser::group_keys_avx512`] prefetches corners: its
/// gathers waited on them without it, and farther ahead did no better.
const CORNERS_AHEAD: usize = 64;

/// The most triangles the block kernel gathers corners from: vertex `3t + corner` of
/// the triangles must fit a gather's i32 offset, as `3v + axis` of the positions does.
const MAX_GATHER_TRIANGLES: usize = MAX_GATHER_VERTICES;

/// [`signature`] in AVX-512 lanes, of keys in three words (`[word]`).
///
/// # Safety
/// The CPU has AVX-512 F.
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn signature_avx512(
    [x, y, z]: [std::arch::x86_64::__m512i; 3],
) -> std::arch::x86_64::__m512i {
    use std::arch::x86_64::*;
    let [a, b] = SIGNATURE_FACTORS.map(|f| _mm512_set1_epi32(f as i32));
    let ab = _mm512_xor_si512(_mm512_mullo_epi32(x, a), _mm512_mullo_epi32(y, b));
    _mm512_xor_si512(ab, z)
}

/// Store the half-edges of the lanes `lanes` of `signatures` and `ids` packed at
/// `destination + at` (counted in half-edges); returns the index past them.
///
/// # Safety
/// The CPU has AVX-512 F and POPCNT; the slots are this thread's.
#[target_feature(enable = "avx512f,popcnt")]
#[inline]
pub(super) unsafe fn append_half_edges_avx512(
    destination: *mut i32,
    at: usize,
    lanes: std::arch::x86_64::__mmask16,
    signatures: std::arch::x86_64::__m512i,
    ids: std::arch::x86_64::__m512i,
) -> usize {
    use std::arch::x86_64::*;
    let n = lanes.count_ones() as usize;
    let signature = _mm512_maskz_compress_epi32(lanes, signatures);
    let id = _mm512_maskz_compress_epi32(lanes, ids);
    let words = 2 * n;
    let store = |h: usize, words: usize| {
        let half = _mm512_loadu_si512(HALF_EDGE_LANES[h].as_ptr() as *const __m512i);
        let interleaved = _mm512_permutex2var_epi32(signature, half, id);
        let mask = ((1u32 << words.min(16)) - 1) as __mmask16;
        _mm512_mask_storeu_epi32(destination.add(2 * at + 16 * h), mask, interleaved);
    };
    store(0, words);
    if n > 8 {
        store(1, words - 16);
    }
    at + n
}

/// The permutes of [`append_half_edges_avx512`]: word `i` of the `h`-th half of 16
/// half-edges' words is field `i % 2` of lane `8h + i / 2` (the second field's lanes
/// numbered from 16).
const HALF_EDGE_LANES: [[i32; 16]; 2] = {
    let mut lanes = [[0; 16]; 2];
    let mut m = 0;
    while m < 32 {
        let (h, i) = (m / 16, m % 16);
        lanes[h][i] = (8 * h + i / 2 + 16 * (i % 2)) as i32;
        m += 1;
    }
    lanes
};

/// The kernel of [`EdgeKeys::write_out_avx512`] for [`PositionKeys`].
///
/// Sixteen triangles at a time: their keys computed again
/// ([`Quantiser::group_keys_avx512`]), and from them their blocks and signatures,
/// then, block by block ([`for_each_block_avx512`]), each side's half-edges in the
/// block compressed to the block's cursor ([`append_half_edges_avx512`]). None past
/// [`MAX_GATHER_VERTICES`] vertices.
#[target_feature(enable = "avx512f,popcnt")]
pub(super) unsafe fn write_out_avx512(
    position_keys: &PositionKeys<'_>,
    first: usize,
    ranks: &[u8],
    cursor: &mut [u32],
    destination: &SharedSlice<PositionHalfEdge>,
) -> usize {
    use std::arch::x86_64::*;
    if position_keys.mesh.positions.len() > MAX_GATHER_VERTICES {
        return 0;
    }
    let destination = destination.0 as *mut i32;
    let done = ranks.len() / 16 * 16;
    for g in (0..done).step_by(16) {
        let (keys, _) = position_keys
            .quantiser
            .group_keys_avx512(position_keys.mesh, first + g);
        let blocks = position_keys.quantiser.cells_avx512(&keys);
        let signatures = [
            signature_avx512(keys[0]),
            signature_avx512(keys[1]),
            signature_avx512(keys[2]),
        ];
        let (triangle, _, active) = load_group_avx512(first + g, &ranks[g..]);
        let id = |k: i32| _mm512_or_epi32(triangle, _mm512_set1_epi32(k));
        let ids = [id(0), id(1), id(2)];
        for_each_block_avx512(&blocks, active, |b, in_b| {
            let at = (0..3).fold(cursor[b] as usize, |at, k| {
                append_half_edges_avx512(destination, at, in_b[k], signatures[k], ids[k])
            });
            cursor[b] = at as u32;
        });
    }
    done
}

/// The kernel of [`EdgeKeys::couple_block_avx512`] for [`PositionKeys`].
///
/// The whole block, 16 half-edges at a time, as the indexed kernel does it, on
/// the signatures ([`window_matches_avx512`] compares words): a half-edge with one
/// match may have a twin; one with more matches is declined. Each group's
/// corners' vertices and links are gathered once, and its half-edges' matches'
/// taken from those of its group and the groups either side. A match is a
/// couple when of a different triangle and joining the same corners opposite
/// ways ([`EdgeKeys::may_couple`]: one vertex each, or where not, one position,
/// gathered): then it has the same key, and is the twin. Each couple writes its
/// own slot with its twin's link, in one scatter for 16 half-edges.
#[target_feature(enable = "avx512f,popcnt")]
pub(super) unsafe fn couple_block_avx512(
    position_keys: &PositionKeys<'_>,
    sorted: &[PositionHalfEdge],
    links: &Links,
    words: &mut Vec<u32>,
    declined: &mut Vec<u32>,
) -> bool {
    use std::arch::x86_64::*;
    let mesh = position_keys.mesh;
    if mesh.positions.len() > MAX_GATHER_VERTICES || mesh.triangle_count() > MAX_GATHER_TRIANGLES {
        return false;
    }
    let len = sorted.len();
    let records = sorted.as_ptr() as *const i32;
    let none = _mm512_set1_epi32(-1);
    let word = block_words_avx512(words, len, |p| {
        let ([signature, _], _) = load_block_group::<2>(records, len, p);
        signature
    });
    let vertices = mesh.triangles.as_ptr() as *const i32;
    let ranks = links.ranks.as_ptr() as *const i32;
    let (zero, one, three) = (
        _mm512_setzero_si512(),
        _mm512_set1_epi32(1),
        _mm512_set1_epi32(3),
    );
    // A group's triangles (-1 past the block), the vertices its sides run from and
    // to, and their links; the lanes in the block.
    let group = |p: usize| {
        let ([_, id], lanes) = load_block_group::<2>(records, len, p);
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
        let t = _mm512_mask_blend_epi32(lanes, none, t);
        ([t, from, to, link], lanes)
    };
    let coordinates = mesh.positions.as_ptr() as *const f32;
    let position = |v: __m512i, lanes| {
        let offset = _mm512_mullo_epi32(v, three);
        [0, 1, 2].map(|axis| {
            let at = _mm512_add_epi32(offset, _mm512_set1_epi32(axis));
            _mm512_mask_i32gather_ps::<4>(_mm512_setzero_ps(), lanes, at, coordinates)
        })
    };
    let mut window = [([none, zero, zero, zero], 0), group(0), group(16)];
    for p in (0..len).step_by(16) {
        let ([t, from, to, link], lanes) = window[1];
        let (single, several, at) = window_matches_avx512(word, p, lanes);
        // By value: borrowed, the window went through the stack, whose 512-bit
        // reloads of just-stored vectors stalled.
        let [(before, _), (this, _), (after, _)] = window;
        let twin =
            move |field: usize| lanes_at_avx512([before[field], this[field], after[field]], at);
        // The match is another triangle's, in the block, and runs from `to` to
        // `from`: its corners are one vertex each, or where not, one position.
        let twin_t = twin(0);
        let apart = _mm512_mask_cmpneq_epi32_mask(single, t, twin_t)
            & _mm512_cmpneq_epi32_mask(twin_t, none);
        let (twin_from, twin_to) = (twin(1), twin(2));
        let mut opposite =
            apart & _mm512_cmpeq_epi32_mask(from, twin_to) & _mm512_cmpeq_epi32_mask(to, twin_from);
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
        write_links_avx512(links, opposite, link, twin(3));
        decline_lanes_avx512(declined, p, several);
        window = [window[1], window[2], group(p + 32)];
    }
    true
}

impl Quantiser {
    /// [`Quantiser::cell`] in AVX-512 lanes, of three sides' keys (`[side][word]`).
    ///
    /// # Safety
    /// The CPU has AVX-512 F.
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(super) unsafe fn cells_avx512(
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

    /// The keys of the sides of triangles `first..first + 16` in AVX-512 lanes
    /// (`[side][word]`), as [`Quantiser::key`] gives them: the same floating-point
    /// operations in the same order, lane-wise, so the same bits; and the lanes that
    /// take part (as `ActiveTriangles::get` says). The corners of the group
    /// [`CORNERS_AHEAD`] triangles on are prefetched.
    ///
    /// # Safety
    /// The CPU has AVX-512 F; the mesh has those triangles and at most
    /// [`MAX_GATHER_VERTICES`] vertices.
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(in crate::pair) unsafe fn group_keys_avx512(
        &self,
        mesh: &TriMesh,
        first: usize,
    ) -> (
        [[std::arch::x86_64::__m512i; 3]; 3],
        std::arch::x86_64::__mmask16,
    ) {
        use std::arch::x86_64::*;
        if let Some(ahead) = mesh
            .triangles
            .get(first + CORNERS_AHEAD..first + CORNERS_AHEAD + 16)
        {
            for &v in ahead.as_flattened() {
                if let Some(p) = mesh.positions.get(v as usize) {
                    crate::prefetch(p);
                }
            }
        }
        let (_, corner, active) = load_triangles_avx512(mesh, first);
        let splat = |v: Vec3| {
            [
                _mm512_set1_ps(v.x),
                _mm512_set1_ps(v.y),
                _mm512_set1_ps(v.z),
            ]
        };
        let [min, scale] = [splat(self.min), splat(self.scale)];
        let (zero, half) = (_mm512_setzero_ps(), _mm512_set1_ps(0.5));
        let field_max = _mm512_set1_ps(FIELD_MAX);
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
            [
                _mm512_or_si512(_mm512_slli_epi32::<8>(bbsa), _mm512_srli_epi32::<16>(x)),
                _mm512_or_si512(_mm512_slli_epi32::<16>(x), _mm512_srli_epi32::<8>(y)),
                _mm512_or_si512(_mm512_slli_epi32::<24>(y), z),
            ]
        };
        ([side_keys(0), side_keys(1), side_keys(2)], active)
    }

    /// The first pass of [`Couples::link`] for triangles `first..` (as many as
    /// `ranks`, their bytes), for a prefix of whole groups of 16: their keys
    /// ([`Quantiser::group_keys_avx512`]) ranked and their half-edges counted by cell
    /// into `count` while in registers, lane-wise as the scalar pass does
    /// ([`rank_and_count_lanes`]). Returns the prefix's length (0 past
    /// [`MAX_GATHER_VERTICES`] vertices).
    ///
    /// # Safety
    /// The CPU has AVX-512 F and POPCNT; the triangles are the mesh's.
    #[target_feature(enable = "avx512f,popcnt")]
    pub(super) unsafe fn rank_and_count_avx512(
        &self,
        mesh: &TriMesh,
        first: usize,
        ranks: &mut [u8],
        count: &mut [u32],
    ) -> usize {
        if mesh.positions.len() > MAX_GATHER_VERTICES {
            return 0;
        }
        let done = ranks.len() / 16 * 16;
        for g in (0..done).step_by(16) {
            let (keys, active) = self.group_keys_avx512(mesh, first + g);
            let cells = self.cells_avx512(&keys);
            rank_and_count_lanes(&keys, cells, active, &mut ranks[g..g + 16], count);
        }
        done
    }
}

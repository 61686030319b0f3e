//! The AVX-512 kernels of indexed pairing (`greedy.rs`): the parent's scalar loops, 16
//! triangles or half-edges at a time. The scalar code is the reference the tests hold
//! them to; every function here needs a CPU with AVX-512 F (and POPCNT and BMI2 where
//! its `target_feature` says), as [`crate::simd::has_avx512`] detects.

use super::*;
use crate::pair::suitor::avx512::{
    append_lanes_avx512, block_words_avx512, decline_lanes_avx512, edge_bbsa_avx512,
    for_each_block_avx512, lanes_at_avx512, load_block_group, load_group_avx512, load_records,
    load_triangles_avx512, rank_and_count_lanes, rank_of_side_lanes, records_of_lanes_avx512,
    window_matches_avx512, write_links_avx512,
};
use crate::pair::suitor::MAX_GATHER_VERTICES;

/// The kernel of [`EdgeKeys::couple_block_avx512`] for [`VertexKeys`].
///
/// The whole block, 16 half-edges at a time. Each half-edge's edge is one word:
/// its larger vertex above its run (its smaller vertex in the block), so that two
/// edges of a block share a word only when their larger vertices differ by a
/// multiple of 2²⁰. Each word is compared with its neighbours'
/// ([`window_matches_avx512`]); a half-edge with one match of the same larger
/// vertex has a twin. Twins that run opposite ways ([`EdgeKeys::may_couple`]) are
/// couples: each writes its own slot (`3t + rank` is `link - t`) with its twin's
/// link, in one scatter for 16 half-edges. A half-edge with more matches, or one
/// of another larger vertex, is declined. One kernel per block, not per run: a
/// kernel per run, with `vpconflictd` (about 20 cycles) and two scatters a run, took
/// twice as long.
#[target_feature(enable = "avx512f,popcnt")]
pub(super) unsafe fn couple_block_avx512(
    sorted: &[VertexHalfEdge],
    links: &Links,
    words: &mut Vec<u32>,
    declined: &mut Vec<u32>,
) -> bool {
    use std::arch::x86_64::*;
    let len = sorted.len();
    let records = sorted.as_ptr() as *const i32;
    let larger_mask = _mm512_set1_epi32(VertexHalfEdge::NO_EDGE as i32);
    // Half-edges p to p + 15 as [smaller, other, link], and the lanes that are
    // in the block; past its end, a larger vertex that no half-edge has.
    let load = |p: usize| {
        let ([smaller, other, link], lanes) = load_block_group::<3>(records, len, p);
        let other = _mm512_mask_blend_epi32(lanes, larger_mask, other);
        ([smaller, other, link], lanes)
    };
    let word = block_words_avx512(words, len, |p| {
        let ([smaller, other, _], _) = load(p);
        let run = _mm512_and_epi32(smaller, _mm512_set1_epi32(BLOCK_VERTICES as i32 - 1));
        _mm512_or_epi32(_mm512_slli_epi32::<BLOCK_SHIFT>(other), run)
    });
    let mut window = [
        (
            [_mm512_setzero_si512(), larger_mask, _mm512_setzero_si512()],
            0,
        ),
        load(0),
        load(16),
    ];
    for p in (0..len).step_by(16) {
        let ([_, other, link], lanes) = window[1];
        let (one, several, at) = window_matches_avx512(word, p, lanes);
        // By value: borrowed, the window went through the stack, whose 512-bit
        // reloads of just-stored vectors stalled.
        let [(before, _), (this, _), (after, _)] = window;
        let twin =
            move |field: usize| lanes_at_avx512([before[field], this[field], after[field]], at);
        let differ = _mm512_xor_epi32(other, twin(1));
        let twins = _mm512_mask_testn_epi32_mask(one, differ, larger_mask);
        let opposite = _mm512_mask_test_epi32_mask(
            twins,
            differ,
            _mm512_set1_epi32(VertexHalfEdge::FORWARD as i32),
        );
        write_links_avx512(links, opposite, link, twin(2));
        decline_lanes_avx512(declined, p, several | one & !twins);
        window = [window[1], window[2], load(p + 32)];
    }
    true
}

/// The kernel of [`EdgeKeys::write_out_avx512`] for [`VertexKeys`].
///
/// Sixteen triangles at a time: their half-edges built lane-wise, one side at a
/// time, and interleaved into records; then, block by block
/// ([`for_each_block_avx512`]: mostly one or two), each side's records in the
/// block compressed to the block's cursor, where the scalar pass moves three
/// cursors a triangle in a chain.
#[target_feature(enable = "avx512f,popcnt,bmi2")]
pub(super) unsafe fn write_out_avx512(
    vertex_keys: &VertexKeys<'_>,
    first: usize,
    ranks: &[u8],
    cursor: &mut [u32],
    destination: &SharedSlice<VertexHalfEdge>,
) -> usize {
    use std::arch::x86_64::*;
    let destination = destination.0 as *mut i32;
    let done = ranks.len() / 16 * 16;
    for g in (0..done).step_by(16) {
        let t = first + g;
        let v = load_records::<3>(
            vertex_keys.mesh.triangles[t..t + 16].as_ptr() as *const i32,
            16,
        );
        let (triangle, rank_bytes, active) = load_group_avx512(t, &ranks[g..]);
        let mut records = [[_mm512_setzero_si512(); 3]; 3];
        let mut blocks = [_mm512_setzero_si512(); 3];
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            let (smaller, larger) = (_mm512_min_epu32(a, b), _mm512_max_epu32(a, b));
            let other = _mm512_mask_or_epi32(
                larger,
                _mm512_cmplt_epu32_mask(a, b),
                larger,
                _mm512_set1_epi32(VertexHalfEdge::FORWARD as i32),
            );
            let side = _mm512_set1_epi32(k as i32);
            let link = _mm512_or_epi32(triangle, rank_of_side_lanes(rank_bytes, side));
            records[k] = records_of_lanes_avx512([smaller, other, link]);
            blocks[k] = _mm512_srli_epi32::<BLOCK_SHIFT>(smaller);
        }
        for_each_block_avx512(&blocks, active, |b, in_b| {
            let mut at = 3 * cursor[b] as usize;
            for (records, in_b) in records.iter().zip(in_b) {
                // A lane's record is three words.
                let words = _pdep_u64(in_b as u64, 0x2492_4924_9249) * 7;
                for (r, &record) in records.iter().enumerate() {
                    let in_r = (words >> (16 * r)) as __mmask16;
                    at = append_lanes_avx512(destination, at, in_r, record);
                }
            }
            cursor[b] = (at / 3) as u32;
        });
    }
    done
}

impl VertexKeys<'_> {
    /// [`VertexKeys::rank_sides`] of triangles `first..` (as many as `ranks`, their bytes),
    /// for a prefix of them, 16 triangles at a time: their corners gathered, the checks of
    /// [`VertexKeys::side_keys`] and the comparisons of [`side_ranks`] on their keys (box
    /// area bits, then smaller vertex, then larger) done lane-wise, with the same
    /// floating-point operations in the same order, so the bytes are the scalar pass's.
    /// Only the block counts are added up one by one, where the scalar pass branches,
    /// checks and builds 128-bit keys per triangle. Returns the prefix's length.
    ///
    /// # Safety
    /// The CPU has AVX-512 F and POPCNT ([`crate::simd::has_avx512`]).
    #[target_feature(enable = "avx512f,popcnt")]
    pub(super) unsafe fn rank_and_count_avx512(
        &self,
        first: usize,
        ranks: &mut [u8],
        count: &mut [u32],
    ) -> usize {
        use std::arch::x86_64::*;
        let mesh = self.mesh;
        if mesh.positions.len() > MAX_GATHER_VERTICES {
            return 0;
        }
        let done = ranks.len() / 16 * 16;
        for g in (0..done).step_by(16) {
            let (v, corner, active) = load_triangles_avx512(mesh, first + g);
            // Side k's key, as `side_keys`: box area bits, smaller and larger vertex.
            let key = |k: usize| {
                let bbsa = edge_bbsa_avx512(&corner[k], &corner[(k + 1) % 3]);
                let (a, b) = (v[k], v[(k + 1) % 3]);
                [
                    _mm512_castps_si512(bbsa),
                    _mm512_min_epu32(a, b),
                    _mm512_max_epu32(a, b),
                ]
            };
            let keys = [key(0), key(1), key(2)];
            // Each half-edge's block: that of its smaller vertex.
            let block = |k: usize| _mm512_srli_epi32::<BLOCK_SHIFT>(keys[k][1]);
            let blocks = [block(0), block(1), block(2)];
            rank_and_count_lanes(&keys, blocks, active, &mut ranks[g..g + 16], count);
        }
        done
    }
}

//! The AVX-512 building blocks of pairing's twin search and Suitor matching, shared by
//! both pairing methods: loads and stores of records in lanes, the block kernel that
//! compares each half-edge with its neighbours in a sorted block, link writes, and the
//! settling and read-out of the matching 16 triangles at a time. Each mirrors a scalar
//! loop of `suitor.rs`, which is the reference the tests hold it to. Every function
//! here needs a CPU with AVX-512 F (and POPCNT and BMI2 where it says), as
//! [`crate::simd::has_avx512`] detects.

use super::*;

/// [`rank_of_side`] in AVX-512 lanes: the rank of side `k` in each lane's rank byte
/// (`ranks`, one a 32-bit lane).
///
/// # Safety
/// The CPU has AVX-512 F.
#[target_feature(enable = "avx512f")]
#[inline]
pub(in crate::pair) unsafe fn rank_of_side_lanes(
    ranks: std::arch::x86_64::__m512i,
    k: std::arch::x86_64::__m512i,
) -> std::arch::x86_64::__m512i {
    use std::arch::x86_64::*;
    _mm512_and_epi32(
        _mm512_srlv_epi32(ranks, _mm512_add_epi32(k, k)),
        _mm512_set1_epi32(3),
    )
}

/// The words of each of `count` (at most 16) records of `W` (2 to 4) 32-bit words at
/// `base`: word `w` of record `i` in lane `i` of vector `w` (0 in lanes from `count`
/// on). Up to `W` masked loads, so nothing past the records is read.
///
/// # Safety
/// The CPU has AVX-512 F; the records are readable.
#[target_feature(enable = "avx512f")]
#[inline]
pub(in crate::pair) unsafe fn load_records<const W: usize>(
    base: *const i32,
    count: usize,
) -> [std::arch::x86_64::__m512i; W] {
    use std::arch::x86_64::*;
    debug_assert!(count <= 16 && (2..=4).contains(&W));
    let words = (W * count) as u32;
    let word_mask = |from: u32| ((1u64 << (words.clamp(from, from + 16) - from)) - 1) as __mmask16;
    // Vector v holds words 16v to 16v + 15; a fourth of 3-word records is all zeros.
    // (Closures in the AVX-512 kernels are called, not passed to `array::map` or
    // `from_fn`, whose bodies lack the target features: there some stayed calls,
    // with their vectors passed through memory.)
    let vector = |v: usize| {
        let from = 16 * v as u32;
        if v < W {
            _mm512_maskz_loadu_epi32(word_mask(from), base.wrapping_add(from as usize))
        } else {
            _mm512_setzero_si512()
        }
    };
    let v = [vector(0), vector(1), vector(2), vector(3)];
    let lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    let mut words = [_mm512_setzero_si512(); W];
    for (w, word) in words.iter_mut().enumerate() {
        let index = _mm512_add_epi32(
            _mm512_mullo_epi32(lane, _mm512_set1_epi32(W as i32)),
            _mm512_set1_epi32(w as i32),
        );
        *word = _mm512_mask_blend_epi32(
            _mm512_cmpge_epi32_mask(index, _mm512_set1_epi32(32)),
            _mm512_permutex2var_epi32(v[0], index, v[1]),
            _mm512_permutex2var_epi32(v[2], index, v[3]),
        );
    }
    words
}

/// [`load_records`] the other way for 16 three-word records: word `w` of the record
/// in lane `i` of `fields[w]` made word `3i + w` of the three vectors (to store, or
/// to append lane by lane). Two permutes a vector.
///
/// # Safety
/// The CPU has AVX-512 F.
#[target_feature(enable = "avx512f")]
#[inline]
pub(in crate::pair) unsafe fn records_of_lanes_avx512(
    [first, second, third]: [std::arch::x86_64::__m512i; 3],
) -> [std::arch::x86_64::__m512i; 3] {
    use std::arch::x86_64::*;
    let lanes = |v: usize, of_third: bool| {
        let indices = &RECORD_LANES[v][of_third as usize];
        _mm512_loadu_si512(indices.as_ptr() as *const __m512i)
    };
    let vector = |v: usize| {
        let of_first_two = _mm512_permutex2var_epi32(first, lanes(v, false), second);
        _mm512_permutex2var_epi32(of_first_two, lanes(v, true), third)
    };
    [vector(0), vector(1), vector(2)]
}

/// Triangles `first..first + 16` of `mesh` in AVX-512 lanes: their vertex indices
/// (`[corner]`), their corners (`[corner][axis]`, 0 in lanes that take no part), and
/// the lanes that take part, as `ActiveTriangles::get` says: indices in range, three
/// distinct vertices ([`has_edges`](crate::mesh::has_edges)), finite corners.
///
/// # Safety
/// The CPU has AVX-512 F; the mesh has at most [`MAX_GATHER_VERTICES`] vertices.
#[target_feature(enable = "avx512f")]
#[inline]
pub(in crate::pair) unsafe fn load_triangles_avx512(
    mesh: &crate::mesh::TriMesh,
    first: usize,
) -> (
    [std::arch::x86_64::__m512i; 3],
    [[std::arch::x86_64::__m512; 3]; 3],
    std::arch::x86_64::__mmask16,
) {
    use std::arch::x86_64::*;
    debug_assert!(mesh.positions.len() <= MAX_GATHER_VERTICES);
    let triangles = mesh.triangles[first..first + 16].as_ptr() as *const i32;
    let coordinates = mesh.positions.as_ptr() as *const f32;
    let vertex_count = _mm512_set1_epi32(mesh.positions.len() as i32);
    let v = load_records::<3>(triangles, 16);
    let mut active = _mm512_cmplt_epu32_mask(v[0], vertex_count)
        & _mm512_cmplt_epu32_mask(v[1], vertex_count)
        & _mm512_cmplt_epu32_mask(v[2], vertex_count)
        & _mm512_cmpneq_epi32_mask(v[0], v[1])
        & _mm512_cmpneq_epi32_mask(v[1], v[2])
        & _mm512_cmpneq_epi32_mask(v[2], v[0]);
    // The corners, of lanes with valid indices only; finite ones.
    let mut corner = [[_mm512_setzero_ps(); 3]; 3];
    for (c, &vertex) in corner.iter_mut().zip(&v) {
        let offset = _mm512_mullo_epi32(vertex, _mm512_set1_epi32(3));
        for (axis, x) in c.iter_mut().enumerate() {
            let at = _mm512_add_epi32(offset, _mm512_set1_epi32(axis as i32));
            *x = _mm512_mask_i32gather_ps::<4>(_mm512_setzero_ps(), active, at, coordinates);
        }
    }
    let exponent = _mm512_set1_epi32(0x7f80_0000);
    for x in corner.iter().flatten() {
        let bits = _mm512_and_si512(_mm512_castps_si512(*x), exponent);
        active = _mm512_mask_cmpneq_epi32_mask(active, bits, exponent);
    }
    (v, corner, active)
}

/// [`edge_bbsa`](crate::pair::edge_bbsa) of the edges `p–q` in AVX-512 lanes
/// (`[axis]`), with the same floating-point operations in the same order, so the same
/// bits.
///
/// # Safety
/// The CPU has AVX-512 F.
#[target_feature(enable = "avx512f")]
#[inline]
pub(in crate::pair) unsafe fn edge_bbsa_avx512(
    p: &[std::arch::x86_64::__m512; 3],
    q: &[std::arch::x86_64::__m512; 3],
) -> std::arch::x86_64::__m512 {
    use std::arch::x86_64::*;
    let magnitude = _mm512_set1_epi32(0x7fff_ffff);
    let along = |axis: usize| {
        let difference = _mm512_castps_si512(_mm512_sub_ps(q[axis], p[axis]));
        _mm512_castsi512_ps(_mm512_and_si512(difference, magnitude))
    };
    let d = [along(0), along(1), along(2)];
    _mm512_add_ps(
        _mm512_add_ps(_mm512_mul_ps(d[0], d[1]), _mm512_mul_ps(d[1], d[2])),
        _mm512_mul_ps(d[2], d[0]),
    )
}

/// The first pass of [`Couples::link`] for 16 triangles in AVX-512 lanes, as the
/// scalar pass does it: `keys[k]` is the key of side k in three words, most
/// significant first (compared unsigned), and `blocks[k]` the block of its half-edge.
/// Writes the triangles' bytes of `ranks` ([`side_ranks`], or
/// [`EXCLUDED`] in lanes not `active`) and counts the active ones' half-edges into
/// `count` block by block: the 48 half-edges of 16 neighbouring triangles are mostly
/// in one or two blocks, and one count per block, of the lanes compared with it,
/// beats 48 increments in a chain.
///
/// # Safety
/// The CPU has AVX-512 F and POPCNT.
#[target_feature(enable = "avx512f,popcnt")]
#[inline]
pub(in crate::pair) unsafe fn rank_and_count_lanes(
    keys: &[[std::arch::x86_64::__m512i; 3]; 3],
    blocks: [std::arch::x86_64::__m512i; 3],
    active: std::arch::x86_64::__mmask16,
    ranks: &mut [u8],
    count: &mut [u32],
) {
    use std::arch::x86_64::*;
    let less = |x: &[__m512i; 3], y: &[__m512i; 3]| {
        let below = |i: usize| _mm512_cmplt_epu32_mask(x[i], y[i]);
        let equal = |i: usize| _mm512_cmpeq_epi32_mask(x[i], y[i]);
        below(0) | equal(0) & (below(1) | equal(1) & below(2))
    };
    let mut byte = _mm512_setzero_si512();
    for k in 0..3 {
        let one = _mm512_set1_epi32(1 << (2 * k));
        for j in [(k + 1) % 3, (k + 2) % 3] {
            byte = _mm512_mask_add_epi32(byte, less(&keys[k], &keys[j]), byte, one);
        }
    }
    let byte = _mm512_mask_blend_epi32(active, _mm512_set1_epi32(EXCLUDED as i32), byte);
    _mm_storeu_si128(
        ranks[..16].as_mut_ptr() as *mut __m128i,
        _mm512_cvtepi32_epi8(byte),
    );
    for_each_block_avx512(&blocks, active, |b, in_b| {
        count[b] += in_b.iter().map(|m| m.count_ones()).sum::<u32>();
    });
}

/// Triangles `first..first + 16` in AVX-512 lanes, for a pass after the first: `4t`,
/// their bytes of side ranks (`ranks[..16]`), and the lanes that take part (not
/// [`EXCLUDED`]).
///
/// # Safety
/// The CPU has AVX-512 F; `ranks` has 16 bytes.
#[target_feature(enable = "avx512f")]
#[inline]
pub(in crate::pair) unsafe fn load_group_avx512(
    first: usize,
    ranks: &[u8],
) -> (
    std::arch::x86_64::__m512i,
    std::arch::x86_64::__m512i,
    std::arch::x86_64::__mmask16,
) {
    use std::arch::x86_64::*;
    debug_assert!(ranks.len() >= 16);
    let lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    let triangle = _mm512_slli_epi32::<2>(_mm512_add_epi32(_mm512_set1_epi32(first as i32), lane));
    let bytes = _mm512_cvtepu8_epi32(_mm_loadu_si128(ranks.as_ptr() as *const __m128i));
    let active = _mm512_cmpneq_epi32_mask(bytes, _mm512_set1_epi32(EXCLUDED as i32));
    (triangle, bytes, active)
}

/// Store the lanes `lanes` of `words` packed at `destination + at`; returns the index
/// past them.
///
/// # Safety
/// The CPU has AVX-512 F and POPCNT; the slots are this thread's.
#[target_feature(enable = "avx512f,popcnt")]
#[inline]
pub(in crate::pair) unsafe fn append_lanes_avx512(
    destination: *mut i32,
    at: usize,
    lanes: std::arch::x86_64::__mmask16,
    words: std::arch::x86_64::__m512i,
) -> usize {
    use std::arch::x86_64::*;
    let n = lanes.count_ones() as usize;
    _mm512_mask_storeu_epi32(
        destination.add(at),
        ((1u32 << n) - 1) as __mmask16,
        _mm512_maskz_compress_epi32(lanes, words),
    );
    at + n
}

/// Calls `f(b, in_b)` once for each block `b` among the lanes `active` of `blocks`
/// (the blocks of 16 triangles' sides 0, 1, 2), with the lanes in it of each side,
/// `in_b`. The blocks come in the order of their first lane (side 0's lanes before
/// side 1's).
///
/// # Safety
/// The CPU has AVX-512 F.
#[target_feature(enable = "avx512f")]
#[inline]
pub(in crate::pair) unsafe fn for_each_block_avx512(
    blocks: &[std::arch::x86_64::__m512i; 3],
    active: std::arch::x86_64::__mmask16,
    mut f: impl FnMut(usize, [std::arch::x86_64::__mmask16; 3]),
) {
    use std::arch::x86_64::*;
    let mut block = [[0u32; 16]; 3];
    for (lanes, &b) in block.iter_mut().zip(blocks) {
        _mm512_storeu_si512(lanes.as_mut_ptr() as *mut __m512i, b);
    }
    let mut left = [active; 3];
    while let Some(k) = (0..3).find(|&k| left[k] != 0) {
        let b = block[k][left[k].trailing_zeros() as usize];
        let in_side = |j: usize| {
            _mm512_mask_cmpeq_epi32_mask(left[j], blocks[j], _mm512_set1_epi32(b as i32))
        };
        let in_b = [in_side(0), in_side(1), in_side(2)];
        for (left, in_b) in left.iter_mut().zip(in_b) {
            *left &= !in_b;
        }
        f(b as usize, in_b);
    }
}

/// [`EdgeKeys::couple_block_avx512`] on a block sorted by run, run `r` ending at
/// `ends[r]`, then [`couple_run`] on the runs it declines and on those longer than
/// [`BLOCK_WINDOW`]. False where the keys have no such kernel.
///
/// # Safety
/// As [`EdgeKeys::couple_block_avx512`].
pub(super) unsafe fn couple_block<K: EdgeKeys>(
    sorted: &[K::HalfEdge],
    ends: &[u32],
    keys: &K,
    links: &Links,
    extra: &mut Vec<ExtraCouple>,
    words: &mut Vec<u32>,
    declined: &mut Vec<u32>,
) -> bool {
    declined.clear();
    if !keys.couple_block_avx512(sorted, links, words, declined) {
        return false;
    }
    let runs = ends.len();
    for h in declined.iter_mut() {
        *h = keys.run(&sorted[*h as usize], runs) as u32;
    }
    let mut from = 0;
    for (r, &end) in ends.iter().enumerate() {
        if end - from > BLOCK_WINDOW as u32 {
            declined.push(r as u32);
        }
        from = end;
    }
    declined.sort_unstable();
    declined.dedup();
    for &r in declined.iter() {
        let from = r.checked_sub(1).map_or(0, |r| ends[r as usize]);
        couple_run(
            &sorted[from as usize..ends[r as usize] as usize],
            keys,
            links,
            extra,
        );
    }
    true
}

/// Writes the words that [`window_matches_avx512`] compares, one per half-edge of a
/// block of `len`, into `words`: `word(p)` gives those of half-edges `p..p + 16`, kept
/// in the block's lanes. Before them, [`BLOCK_WINDOW`] words, and after the last
/// group, twice that, of -1: past the block, words that no half-edge has, or that
/// the kernels check like any other. Returns where half-edge 0's word is.
///
/// # Safety
/// The CPU has AVX-512 F.
#[target_feature(enable = "avx512f")]
#[inline]
pub(in crate::pair) unsafe fn block_words_avx512(
    words: &mut Vec<u32>,
    len: usize,
    mut word: impl FnMut(usize) -> std::arch::x86_64::__m512i,
) -> *const i32 {
    use std::arch::x86_64::*;
    let groups = len.div_ceil(16);
    words.clear();
    words.reserve(16 * groups + 3 * BLOCK_WINDOW);
    let start = words.as_mut_ptr() as *mut i32;
    let none = _mm512_set1_epi32(-1);
    let store = |at: usize, v| _mm512_storeu_si512(start.add(at) as *mut __m512i, v);
    store(0, none);
    for g in 0..groups {
        let p = 16 * g;
        store(
            BLOCK_WINDOW + p,
            _mm512_mask_blend_epi32(block_lanes(len, p), none, word(p)),
        );
    }
    for at in [0, 16].map(|a| BLOCK_WINDOW + 16 * groups + a) {
        store(at, none);
    }
    words.set_len(16 * groups + 3 * BLOCK_WINDOW);
    start.add(BLOCK_WINDOW)
}

/// The lanes of half-edges `p..p + 16` that are in a block of `len` (none past its end).
#[inline]
pub(in crate::pair) fn block_lanes(len: usize, p: usize) -> std::arch::x86_64::__mmask16 {
    ((1u32 << len.saturating_sub(p).min(16)) - 1) as std::arch::x86_64::__mmask16
}

/// Half-edges `p..p + 16` of a block of `len` records of `W` words at `records`, as
/// [`load_records`] gives them (0 past the block's end), and the lanes in the block.
///
/// # Safety
/// The CPU has AVX-512 F; the block's records are readable.
#[target_feature(enable = "avx512f")]
#[inline]
pub(in crate::pair) unsafe fn load_block_group<const W: usize>(
    records: *const i32,
    len: usize,
    p: usize,
) -> (
    [std::arch::x86_64::__m512i; W],
    std::arch::x86_64::__mmask16,
) {
    let count = len.saturating_sub(p).min(16);
    let words = load_records::<W>(records.wrapping_add(W * p), count);
    (words, block_lanes(len, p))
}

/// Each word of half-edges `p..p + 16` of a block (those of `lanes`) compared with the
/// [`BLOCK_WINDOW`] − 1 before it and after it, at `word` as [`block_words_avx512`]
/// wrote them: every match adds 64 plus its signed distance to a sum, which then
/// tells at once no match, one match and where, or more. Returns the lanes with one
/// match, those with more, and in the first, the match's lane from lane 0 of half-edge
/// `p`'s group of 16: −15 to 30.
///
/// # Safety
/// The CPU has AVX-512 F; `word` is as [`block_words_avx512`] returns it, and `p` a
/// multiple of 16 in the block.
#[target_feature(enable = "avx512f")]
#[inline]
pub(in crate::pair) unsafe fn window_matches_avx512(
    word: *const i32,
    p: usize,
    lanes: std::arch::x86_64::__mmask16,
) -> (
    std::arch::x86_64::__mmask16,
    std::arch::x86_64::__mmask16,
    std::arch::x86_64::__m512i,
) {
    use std::arch::x86_64::*;
    let load = |at: *const i32| _mm512_loadu_si512(at as *const __m512i);
    let edge = load(word.add(p));
    let mut matches = _mm512_setzero_si512();
    for d in 1..BLOCK_WINDOW {
        for (at, distance) in [
            (word.add(p + d), d as i32),
            (word.add(p).sub(d), -(d as i32)),
        ] {
            matches = _mm512_mask_add_epi32(
                matches,
                _mm512_cmpeq_epi32_mask(edge, load(at)),
                matches,
                _mm512_set1_epi32(64 + distance),
            );
        }
    }
    // One match: 64 plus its distance, 49 to 79; two or more: 98 or more.
    let one = _mm512_mask_cmple_epu32_mask(
        lanes,
        _mm512_sub_epi32(matches, _mm512_set1_epi32(49)),
        _mm512_set1_epi32(30),
    );
    let several = _mm512_mask_cmpgt_epu32_mask(lanes, matches, _mm512_set1_epi32(79));
    let lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    let at = _mm512_add_epi32(lane, _mm512_sub_epi32(matches, _mm512_set1_epi32(64)));
    (one, several, at)
}

/// The lanes `at` (−16 to 31, as [`window_matches_avx512`] gives them) of three
/// consecutive groups of 16, `[before, here, after]`.
///
/// # Safety
/// The CPU has AVX-512 F.
#[target_feature(enable = "avx512f")]
#[inline]
pub(in crate::pair) unsafe fn lanes_at_avx512(
    [before, here, after]: [std::arch::x86_64::__m512i; 3],
    at: std::arch::x86_64::__m512i,
) -> std::arch::x86_64::__m512i {
    use std::arch::x86_64::*;
    let ahead = _mm512_cmpge_epi32_mask(at, _mm512_setzero_si512());
    let at_before = _mm512_add_epi32(at, _mm512_set1_epi32(16));
    _mm512_mask_blend_epi32(
        ahead,
        _mm512_permutex2var_epi32(before, at_before, here),
        _mm512_permutex2var_epi32(here, at, after),
    )
}

/// The places `p + lane` of the lanes `lanes` of half-edges `p..p + 16`, appended to
/// `declined`.
///
/// # Safety
/// The CPU has AVX-512 F and POPCNT.
#[target_feature(enable = "avx512f,popcnt")]
#[inline]
pub(in crate::pair) unsafe fn decline_lanes_avx512(
    declined: &mut Vec<u32>,
    p: usize,
    lanes: std::arch::x86_64::__mmask16,
) {
    use std::arch::x86_64::*;
    if lanes != 0 {
        declined.reserve(16);
        let lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
        let place = _mm512_add_epi32(_mm512_set1_epi32(p as i32), lane);
        let destination = declined.as_mut_ptr() as *mut i32;
        declined.set_len(append_lanes_avx512(
            destination,
            declined.len(),
            lanes,
            place,
        ));
    }
}

/// Link the half-edges of lanes `coupled` to their twins in AVX-512 lanes, as
/// [`Links::write`] does: a half-edge whose link is `link` (its triangle and its
/// side's rank) and whose twin's is `twin_link`. A link names its side's slot as
/// well: `3t + rank` is `link - t`. One scatter.
///
/// # Safety
/// The CPU has AVX-512 F; the slots are this thread's.
#[target_feature(enable = "avx512f")]
#[inline]
pub(in crate::pair) unsafe fn write_links_avx512(
    links: &Links,
    coupled: std::arch::x86_64::__mmask16,
    link: std::arch::x86_64::__m512i,
    twin_link: std::arch::x86_64::__m512i,
) {
    use std::arch::x86_64::*;
    let slot = _mm512_sub_epi32(link, _mm512_srli_epi32::<2>(link));
    let across = links.across.0 as *mut i32;
    _mm512_mask_i32scatter_epi32::<4>(across, coupled, slot, twin_link);
}

/// [`settle_mutual_best`] for whole groups of 16 triangles: their best sides' links
/// loaded (three vectors, one permutation), the offers written as bytes and the
/// proposers compressed. Returns how many triangles it did.
///
/// # Safety
/// The CPU has AVX-512 F and POPCNT; `proposers` has room for `state.len()` more.
#[target_feature(enable = "avx512f,popcnt")]
pub(super) unsafe fn settle_mutual_best_avx512(
    links: &[u32],
    state: &mut [u8],
    first: usize,
    proposers: &mut Vec<u32>,
) -> usize {
    use std::arch::x86_64::*;
    let lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    // Lane i takes word 3i of 48: lanes 0 to 10 from the first two vectors, the rest
    // from the third.
    let from_two = _mm512_mullo_epi32(lane, _mm512_set1_epi32(3));
    let with_third = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 17, 20, 23, 26, 29);
    let done = state.len() / 16 * 16;
    for g in (0..done).step_by(16) {
        let words = links.as_ptr().add(3 * (first + g)) as *const __m512i;
        let [a, b, c] = [0, 1, 2].map(|v| _mm512_loadu_si512(words.add(v)));
        let best =
            _mm512_permutex2var_epi32(_mm512_permutex2var_epi32(a, from_two, b), with_third, c);
        let proposing = _mm512_test_epi32_mask(best, _mm512_set1_epi32(3));
        let offer = _mm512_maskz_mov_epi32(proposing, _mm512_set1_epi32(NO_SUITOR as i32));
        _mm_storeu_si128(
            state.as_mut_ptr().add(g) as *mut __m128i,
            _mm512_cvtepi32_epi8(offer),
        );
        let t = _mm512_add_epi32(_mm512_set1_epi32((first + g) as i32), lane);
        let destination = proposers.as_mut_ptr() as *mut i32;
        proposers.set_len(append_lanes_avx512(
            destination,
            proposers.len(),
            proposing,
            t,
        ));
    }
    done
}

/// The pairs after [`propose`], as [`suitor_partner`] finds them, 16 triangles at a
/// time: the suitors' links and their states gathered, the triangles left alone and
/// the pairs compressed into their lists.
///
/// # Safety
/// The CPU has AVX-512 F and POPCNT; `state` has [`RANKS_PADDING`] bytes after the
/// `n` triangles' (a gather of four bytes at the last stays in it), and `3n` fits an
/// `i32`.
#[target_feature(enable = "avx512f,popcnt")]
pub(super) unsafe fn suitor_pairs_avx512(links: &[u32], state: &[u8], n: usize) -> Pairing {
    use std::arch::x86_64::*;
    debug_assert!(state.len() >= n + RANKS_PADDING && 3 * n <= i32::MAX as usize);
    // Pairs never number more than n / 2, and a store of 8 at the count stays in
    // these; triangles left alone, 16 at the count, in n, as the count is at most g.
    let mut pairs: Vec<[u32; 2]> = Vec::with_capacity(n / 2 + 8);
    let mut unpaired: Vec<u32> = Vec::with_capacity(n);
    let lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    // [t, u] of lanes 0 to 7, then 8 to 15, from the lanes of t and u.
    let interleave = [0, 8].map(|from| {
        _mm512_or_epi32(
            _mm512_srli_epi32::<1>(_mm512_add_epi32(lane, _mm512_set1_epi32(2 * from))),
            _mm512_slli_epi32::<4>(_mm512_and_epi32(lane, _mm512_set1_epi32(1))),
        )
    });
    let last = _mm512_set1_epi32(n as i32 - 1);
    let three = _mm512_set1_epi32(3);
    let done = n / 16 * 16;
    for g in (0..done).step_by(16) {
        let t = _mm512_add_epi32(_mm512_set1_epi32(g as i32), lane);
        let rank = _mm512_cvtepu8_epi32(_mm_loadu_si128(state.as_ptr().add(g) as *const __m128i));
        let suited = _mm512_cmpneq_epi32_mask(rank, three);
        let slot = _mm512_add_epi32(
            _mm512_add_epi32(_mm512_add_epi32(t, t), t),
            _mm512_min_epu32(rank, _mm512_set1_epi32(2)),
        );
        let link = _mm512_i32gather_epi32::<4>(slot, links.as_ptr() as *const i32);
        let u = _mm512_min_epu32(_mm512_srli_epi32::<2>(link), last);
        let u_state = _mm512_i32gather_epi32::<1>(u, state.as_ptr() as *const i32);
        let mutual = _mm512_mask_cmpeq_epi32_mask(
            suited,
            _mm512_and_epi32(u_state, _mm512_set1_epi32(0xff)),
            _mm512_and_epi32(link, three),
        );
        let alone = !mutual;
        let destination = unpaired.as_mut_ptr() as *mut i32;
        unpaired.set_len(append_lanes_avx512(destination, unpaired.len(), alone, t));
        let first = _mm512_mask_cmpgt_epu32_mask(mutual, u, t);
        for (half, interleave) in [first as u8, (first >> 8) as u8]
            .into_iter()
            .zip(interleave)
        {
            let count = pairs.len();
            _mm512_storeu_si512(
                pairs.as_mut_ptr().add(count) as *mut __m512i,
                _mm512_maskz_compress_epi64(half, _mm512_permutex2var_epi32(t, interleave, u)),
            );
            pairs.set_len(count + half.count_ones() as usize);
        }
    }
    for t in done..n {
        match suitor_partner(links, &state[..n], t) {
            UNPAIRED => unpaired.push(t as u32),
            u if u as usize > t => pairs.push([t as u32, u]),
            _ => {}
        }
    }
    unpaired.shrink_to_fit();
    Pairing { pairs, unpaired }
}

/// The permutes of [`records_of_lanes_avx512`]: for vector `v`, whose word `i` is
/// word `m % 3` of lane `m / 3` (`m = 16v + i`), the lanes of the first two fields
/// (the second's numbered from 16), then those of the first permute and the third
/// field (from 16).
const RECORD_LANES: [[[i32; 16]; 2]; 3] = {
    let mut lanes = [[[0; 16]; 2]; 3];
    let mut m = 0;
    while m < 48 {
        let (v, i, lane, word) = (m / 16, m % 16, (m / 3) as i32, m % 3);
        lanes[v][0][i] = if word == 1 { 16 + lane } else { lane };
        lanes[v][1][i] = if word == 2 { 16 + lane } else { i as i32 };
        m += 1;
    }
    lanes
};

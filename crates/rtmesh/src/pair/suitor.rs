//! Greedy matching without sorting: the Suitor algorithm (Manne & Halappanavar, "New
//! Effective Multithreaded Matching Algorithms", IPDPS 2014).
//!
//! The greedy scan of the pairing paper takes couples of triangles in descending key
//! order and keeps a couple when both triangles are still free. When the keys are
//! distinct (a strict total order), that matching is the unique *locally dominant* one,
//! and Suitor finds it with no order over all couples: each triangle proposes to its
//! neighbour with the largest key whose current suitor offers less, displacing that
//! suitor, which proposes again. Two triangles that are each other's suitors at the
//! end are a pair. Every displacement raises a triangle's best offer, so the work is
//! a few proposals per triangle; the reads follow the mesh's own order, which keeps
//! them in cache, where a global sort's scan jumps all over the couples.
//!
//! The dual graph is kept per side of every triangle ([`Couples`]): the twin
//! half-edge across it, or a mark that the side's edge has three or more half-edges,
//! whose couples are listed apart with their keys ([`ExtraCouple`]). Twins are found
//! block by block in cache ([`Couples::link`]); the pairing method says how its
//! half-edges are keyed and blocked ([`EdgeKeys`]: by smaller vertex for indexed
//! input, by cell of space and key hash for position keys), and ranks each triangle's
//! sides first ([`RankedSides`]). The hot loops, ranking the triangles' sides and
//! searching the runs, take a pairing method's own AVX-512 kernels where it has them
//! and the CPU too (its ranking's, [`EdgeKeys::couple_block_avx512`]); the scalar
//! loops are the reference the tests hold them to. Twins are written as links ([`Links`]), listed in the order of each
//! triangle's keys, which carry the couple's rank at the other end. When no edge has
//! more than two half-edges, a triangle's whole matching state is then one byte, the
//! rank of its suitor's couple, and a proposal reads one link and one byte at best
//! ([`propose`]), which on several threads proposes from parts of the triangles at
//! once, with atomic states. Before that, the couples that are the best of both their
//! triangles are settled without proposals ([`settle_mutual_best`]), and after it the
//! pairs are read out, both 16 triangles at a time where the CPU has AVX-512. Else
//! keys are `u128`s from the pairing method, computed when a triangle proposes.
//! Cost: O(T) time (O(E · max degree) proposals at worst, and O(L log L) for a run of
//! L half-edges past the window); 12 or 4 bytes per half-edge for the blocks, 4 for
//! the links and 1 per triangle for the state.

use super::{Pairing, UNPAIRED};
use crate::mesh::{part_cursors, triangle_part_len, SharedSlice};
use crate::pages::{filled_on_huge_pages, vec_on_huge_pages};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU8, Ordering::Relaxed};

/// A couple seen from one of its triangles, as [`Couples::across`] lists it: the
/// triangle `v` at the other end, and the couple's rank among `v`'s sides (0 for its
/// largest key), as `v << 2 | rank`; or this, for a side with no couple (no link has
/// rank 3).
pub(super) const NO_LINK: u32 = u32::MAX;
/// [`Couples::across`] value of a side whose edge has three or more half-edges: its
/// couples are in [`Couples::extra`] (rank 3, so no link, and not [`NO_LINK`]).
const SHARED_BY_MORE: u32 = !4;
/// The most triangles that links name.
pub(super) const MAX_LINKED_TRIANGLES: usize = 1 << 30;
/// The couples (pairable neighbours across an edge) of every triangle.
pub(super) struct Couples {
    /// Slot `3t + j` of triangle `t` is its side of rank `j`'s: the link to the
    /// triangle across it (as [`NO_LINK`] describes), or [`NO_LINK`] or [`SHARED_BY_MORE`]. Sides with no couple may tie
    /// in rank (and share a slot, leaving one [`NO_LINK`]); sides with one may not, as
    /// their key is their edge's.
    across: Vec<u32>,
    /// The couples on edges of three or more half-edges, once from each triangle,
    /// sorted by triangle.
    extra: Vec<ExtraCouple>,
    /// Per triangle, the rank of each side's key among its three (0 for the largest)
    /// in two bits, sides 0, 1, 2 from the lowest; [`EXCLUDED`] for a triangle that
    /// takes no part. Then [`RANKS_PADDING`] bytes, which the matching's state keeps.
    side_ranks: Vec<u8>,
}

/// A half-edge as [`Couples::link`] sorts and compares it.
pub(super) trait HalfEdge: Copy + Default + Send + Sync {
    /// What tells the edges of one run apart: the edge, or a signature of it that
    /// equal edges share, where two half-edges of one signature that
    /// [`EdgeKeys::may_couple`] are sure to be on one edge ([`EdgeKeys::exact_edge`]
    /// tells the rest apart).
    type Edge: Copy + Ord;
    /// An edge that no half-edge has (the spare lanes of a window).
    const NO_EDGE: Self::Edge;
    /// Runs up to this long (at most [`MAX_WINDOW`]) are searched in a fixed window.
    const WINDOW: usize;
    /// The half-edge's edge.
    fn edge(&self) -> Self::Edge;
    /// The half-edge's triangle.
    fn triangle(&self) -> u32;
    /// The rank of its side's key among its triangle's three (0 for the largest), read
    /// from `ranks` (the bytes of [`Couples::side_ranks`]) where the half-edge does not
    /// carry it.
    fn rank(&self, ranks: &[u8]) -> u32;
    /// The link to this half-edge's side, as [`NO_LINK`] describes it.
    #[inline]
    fn link(&self, ranks: &[u8]) -> u32 {
        self.triangle() << 2 | self.rank(ranks)
    }
}

/// How a pairing method keys the half-edges for [`Couples::link`]: blocks of runs, such
/// that every edge's half-edges land in one run of one block, and a block's half-edges
/// fit the core's cache.
pub(super) trait EdgeKeys: Sync {
    /// The half-edges.
    type HalfEdge: HalfEdge;
    /// How many blocks (at least one).
    fn blocks(&self) -> usize;
    /// How many runs block `b`, of `len` half-edges, has.
    fn runs(&self, b: usize, len: usize) -> usize;
    /// The half-edges of triangle `t`, one that takes part, whose sides' ranks are
    /// `ranks`, each with its block.
    fn half_edges(&self, t: usize, ranks: u8) -> [(Self::HalfEdge, usize); 3];
    /// The run of half-edge `h` in its block, which has `runs` runs.
    fn run(&self, h: &Self::HalfEdge, runs: usize) -> usize;
    /// The key of the `rank`-th couple from the end on an edge of three or more
    /// half-edges, `h` among them.
    fn extra_key(&self, h: &Self::HalfEdge, rank: u32) -> u128;
    /// Half-edge `h`'s edge exactly, by which [`couple_run`] groups a run: its
    /// [`HalfEdge::edge`], or where that is a signature, the key it signs.
    fn exact_edge(&self, h: &Self::HalfEdge) -> u128;
    /// Whether `a` and `b`, two half-edges of one [`HalfEdge::edge`], may be a couple.
    fn may_couple(&self, a: &Self::HalfEdge, b: &Self::HalfEdge) -> bool;
    /// Prefetch what [`EdgeKeys::may_couple`] and linking will read of `h`, where that
    /// is not in the half-edge (its triangle's byte of `ranks`, [`Links::ranks`], is
    /// one): [`Couples::link`] calls stage 0 as it counts a block's runs, and stage 1
    /// as it sorts the block, before it searches the runs. None by default.
    #[inline]
    fn prefetch_couple(&self, _h: &Self::HalfEdge, _stage: u32, _ranks: &[u8]) {}
    /// The twins of a whole block sorted by run in AVX-512, for keys that have such a
    /// kernel (else false, having done nothing), where runs of at most
    /// [`BLOCK_WINDOW`] half-edges are sure to be right (each is searched in a window
    /// about each half-edge: [`window_matches_avx512`]): the links of the couples it
    /// finds written, as [`couple_pairs`] writes them, and the half-edges whose runs
    /// it leaves to [`couple_run`] listed in `declined` (by place in `sorted`), those
    /// with an edge of three or more half-edges among them. `words` is scratch space.
    ///
    /// # Safety
    /// The CPU has AVX-512 F and POPCNT ([`has_avx512`]); the block's slots in `links`
    /// are this thread's.
    unsafe fn couple_block_avx512(
        &self,
        _sorted: &[Self::HalfEdge],
        _links: &Links,
        _words: &mut Vec<u32>,
        _declined: &mut Vec<u32>,
    ) -> bool {
        false
    }
    /// The second pass of [`Couples::link`] in AVX-512, for keys that have such a
    /// kernel, over a prefix of the triangles from `first`, whose bytes of `ranks` the
    /// first pass wrote: each one's half-edges written at its block's
    /// `cursor`, into `destination`, and the cursor moved past them. A triangle's
    /// half-edges stay in side order, and groups of triangles in order, but a group's
    /// sides 0 may come before its sides 1. Returns the prefix's length (0 where there
    /// is no kernel); the scalar pass does the rest.
    ///
    /// # Safety
    /// The CPU has AVX-512 F, POPCNT and BMI2 ([`has_avx512`]); the cursors give every
    /// half-edge its own slot of `destination`.
    unsafe fn write_out_avx512(
        &self,
        _first: usize,
        _ranks: &[u8],
        _cursor: &mut [u32],
        _destination: &SharedSlice<Self::HalfEdge>,
    ) -> usize {
        0
    }
}

/// The longest fixed window of [`couple_pairs`].
const MAX_WINDOW: usize = 16;

/// The rank of side `k` in a triangle's rank byte `ranks`.
#[inline]
pub(super) fn rank_of_side(ranks: u8, k: u32) -> u32 {
    (ranks as u32 >> (2 * k)) & 3
}

/// [`rank_of_side`] in AVX-512 lanes: the rank of side `k` in each lane's rank byte
/// (`ranks`, one a 32-bit lane).
///
/// # Safety
/// The CPU has AVX-512 F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn rank_of_side_lanes(
    ranks: std::arch::x86_64::__m512i,
    k: std::arch::x86_64::__m512i,
) -> std::arch::x86_64::__m512i {
    use std::arch::x86_64::*;
    _mm512_and_epi32(
        _mm512_srlv_epi32(ranks, _mm512_add_epi32(k, k)),
        _mm512_set1_epi32(3),
    )
}

/// The rank byte of a triangle whose sides have keys `keys`.
#[inline]
pub(super) fn side_ranks<K: PartialOrd>(keys: &[K; 3]) -> u8 {
    let rank = |k: usize| (keys[k] < keys[(k + 1) % 3]) as u8 + (keys[k] < keys[(k + 2) % 3]) as u8;
    rank(0) | rank(1) << 2 | rank(2) << 4
}

/// [`Couples::side_ranks`] of a triangle that takes no part.
pub(super) const EXCLUDED: u8 = 0xff;

impl Couples {
    /// The couples of the half-edges that `keys` gives: two half-edges couple when they
    /// are the only two on their edge and [`EdgeKeys::may_couple`]. On an edge of three
    /// or more, neighbours in half-edge id order that may couple do, listed in
    /// [`Couples::extra`]: the `i`-th with key `extra_key(h, n - 1 - i)` for `n`
    /// half-edges, so that earlier couples rank higher.
    ///
    /// Three passes. The first, `ranked`, ranked every triangle's sides and counted its
    /// half-edges per block; the second writes them out by block (a triangle's three
    /// take one read of each cursor, not three in a chain). The third takes a block at
    /// a time, in cache: a counting sort on the run gathers each run's half-edges (in
    /// the order written, which keeps each triangle's in side order), among which every
    /// edge's are found by comparing edges. Parts of the triangles, then blocks, on the
    /// pool's threads. When `avx512` (which the CPU must have: [`has_avx512`]), the passes
    /// take the kernels [`EdgeKeys::write_out_avx512`] and
    /// [`EdgeKeys::couple_block_avx512`], where the keys have them.
    pub(super) fn link<K: EdgeKeys>(keys: &K, ranked: RankedSides, avx512: bool) -> Self {
        let RankedSides {
            side_ranks,
            counts: mut cursors,
        } = ranked;
        let n = side_ranks.len() - RANKS_PADDING;
        let blocks = keys.blocks();
        let part_len = triangle_part_len(n);
        // Parts in order within a block.
        let block_start = part_cursors(&mut cursors, blocks);
        // Pass 2: write the half-edges out by block.
        let half_edge_count = block_start[blocks] as usize;
        let mut by_block: Vec<K::HalfEdge> = vec_on_huge_pages(half_edge_count);
        let destination = SharedSlice(by_block.as_mut_ptr());
        let destination = &destination;
        side_ranks[..n]
            .par_chunks(part_len)
            .zip(cursors)
            .enumerate()
            .for_each(|(p, (ranks, mut cursor))| {
                let done = if avx512 {
                    // SAFETY: `avx512` says the CPU has the features; the counts give
                    // every half-edge its own slot.
                    unsafe { keys.write_out_avx512(p * part_len, ranks, &mut cursor, destination) }
                } else {
                    0
                };
                for (i, &r) in ranks.iter().enumerate().skip(done) {
                    if r == EXCLUDED {
                        continue;
                    }
                    let [(h0, b0), (h1, b1), (h2, b2)] = keys.half_edges(p * part_len + i, r);
                    let (h, b) = ([h0, h1, h2], [b0, b1, b2]);
                    let c = [
                        cursor[b[0]],
                        cursor[b[1]] + (b[1] == b[0]) as u32,
                        cursor[b[2]] + (b[2] == b[0]) as u32 + (b[2] == b[1]) as u32,
                    ];
                    for k in 0..3 {
                        // SAFETY: the counts give every half-edge its own slot below
                        // `half_edge_count`.
                        unsafe { destination.0.add(c[k] as usize).write(h[k]) };
                        cursor[b[k]] = c[k] + 1;
                    }
                }
            });
        // SAFETY: the cursors covered every slot exactly once.
        unsafe { by_block.set_len(half_edge_count) };
        // Pass 3: the blocks.
        let mut across = filled_on_huge_pages(3 * n, NO_LINK);
        let links = Links {
            across: SharedSlice(across.as_mut_ptr()),
            ranks: &side_ranks,
        };
        let links = &links;
        let extras: Vec<Vec<ExtraCouple>> = (0..blocks)
            .into_par_iter()
            .fold(BlockScratch::<K>::default, |mut scratch, b| {
                let BlockScratch {
                    extra,
                    sorted,
                    start,
                    words,
                    declined,
                } = &mut scratch;
                let block = &by_block[block_start[b] as usize..block_start[b + 1] as usize];
                let runs = keys.runs(b, block.len());
                let next = block_start[b + 1] as usize..block_start[(b + 2).min(blocks)] as usize;
                sort_by_run(keys, block, runs, &by_block[next], links, start, sorted);
                // `start[r]` is now where run r ends.
                let ends = &start[..runs];
                // SAFETY: `avx512` says the CPU has the features.
                #[cfg(target_arch = "x86_64")]
                let coupled = avx512
                    && unsafe { couple_block(sorted, ends, keys, links, extra, words, declined) };
                #[cfg(not(target_arch = "x86_64"))]
                let coupled = false;
                if !coupled {
                    couple_runs(sorted, ends, keys, links, extra);
                }
                scratch
            })
            .map(|scratch| scratch.extra)
            .collect();
        let mut extra = extras.concat();
        extra.sort_unstable_by_key(|e| e.triangle);
        Couples {
            across,
            extra,
            side_ranks,
        }
    }
}

/// The first pass of [`Couples::link`], which each pairing method does its own way:
/// every triangle's side ranks, and its half-edges counted per block, by parts of the
/// triangles ([`triangle_part_len`]).
#[derive(Debug, PartialEq)]
pub(super) struct RankedSides {
    /// [`Couples::side_ranks`], padding included.
    pub(super) side_ranks: Vec<u8>,
    /// Per part, its half-edges per block.
    pub(super) counts: Vec<Vec<u32>>,
}

impl RankedSides {
    /// The sides of `n` triangles ranked and counted into `blocks` blocks by parts on
    /// the pool's threads: `rank_part(p, item, ranks, count)` does part `p`, with its
    /// item of `items` (one per part), its ranks (which start [`EXCLUDED`]) and its
    /// counts (which start at 0).
    pub(super) fn by_parts<T: Send>(
        n: usize,
        blocks: usize,
        items: impl IndexedParallelIterator<Item = T>,
        rank_part: impl Fn(usize, T, &mut [u8], &mut [u32]) + Sync,
    ) -> Self {
        let mut side_ranks = vec![EXCLUDED; n + RANKS_PADDING];
        let counts = side_ranks[..n]
            .par_chunks_mut(triangle_part_len(n))
            .zip(items)
            .enumerate()
            .map(|(p, (ranks, item))| {
                let mut count = vec![0u32; blocks];
                rank_part(p, item, ranks, &mut count);
                count
            })
            .collect();
        Self { side_ranks, counts }
    }
}

/// Counting sort of a block's half-edges on their run (of `runs`): into `sorted`,
/// with `start[r]` where run `r` ends. The block is taken in [`SORT_PARTS`] parts at
/// once, each with its own cursors, so that the chains of increments of one cursor
/// (neighbouring half-edges often share a run) interleave: on the dragon, one core,
/// the blocks' pass took 15.6 → 14.0 ms with two. While it sorts, the next block's
/// half-edges, `next`, are fetched from the shared cache, a line in step with each
/// line read (20.6 → 19.0 ms). As it places a half-edge, the line of its triangle's
/// slots in `links` is fetched, where the block kernel's scatter of links missed
/// (side by side on the dragon, compressed keys, one core, Zen 4: medians of eight
/// runs 60.7 → 58.0 ms in all; fetched as it counts, or with write intent, no gain).
#[inline(always)]
fn sort_by_run<K: EdgeKeys>(
    keys: &K,
    block: &[K::HalfEdge],
    runs: usize,
    next: &[K::HalfEdge],
    links: &Links,
    start: &mut Vec<u32>,
    sorted: &mut Vec<K::HalfEdge>,
) {
    const PARTS: usize = SORT_PARTS;
    let ranks = links.ranks;
    // Half-edge i of each part, and the last part's remainder.
    let part = block.len() / PARTS;
    let rest = &block[PARTS * part..];
    let ith = |i: usize| std::array::from_fn::<_, PARTS, _>(|p| &block[p * part + i]);
    // Part p's cursor of run r is cursor[p * runs + r].
    start.clear();
    start.resize(PARTS * runs, 0u32);
    let cursor = &mut start[..];
    for i in 0..part {
        for (p, h) in ith(i).into_iter().enumerate() {
            keys.prefetch_couple(h, 0, ranks);
            cursor[p * runs + keys.run(h, runs)] += 1;
        }
    }
    for h in rest {
        keys.prefetch_couple(h, 0, ranks);
        cursor[(PARTS - 1) * runs + keys.run(h, runs)] += 1;
    }
    let mut at = 0;
    for r in 0..runs {
        for p in 0..PARTS {
            let count = std::mem::replace(&mut cursor[p * runs + r], at);
            at += count;
        }
    }
    sorted.clear();
    sorted.resize(block.len(), K::HalfEdge::default());
    let sorted = &mut sorted[..];
    let mut place = |p: usize, h: &K::HalfEdge| {
        keys.prefetch_couple(h, 1, ranks);
        crate::prefetch_address(links.across.0.wrapping_add(3 * h.triangle() as usize));
        let c = &mut cursor[p * runs + keys.run(h, runs)];
        sorted[*c as usize] = *h;
        *c += 1;
    };
    let line = 64 / std::mem::size_of::<K::HalfEdge>().max(1);
    for i in 0..part {
        if i % line == 0 {
            for e in (0..PARTS).filter_map(|p| next.get(p * part + i)) {
                crate::prefetch(e);
            }
        }
        for (p, h) in ith(i).into_iter().enumerate() {
            place(p, h);
        }
    }
    for h in rest {
        place(PARTS - 1, h);
    }
    // Each run ends where the last part's cursor is.
    start.copy_within((PARTS - 1) * runs.., 0);
    start.truncate(runs);
}

/// How many parts of a block [`sort_by_run`] sorts at once (four were no faster).
const SORT_PARTS: usize = 2;

/// What the blocks' pass of [`Couples::link`] reuses from block to block on one thread.
struct BlockScratch<K: EdgeKeys> {
    /// The couples on edges of three or more half-edges found so far.
    extra: Vec<ExtraCouple>,
    /// The block's half-edges sorted by run.
    sorted: Vec<K::HalfEdge>,
    /// The runs' starts, then ends.
    start: Vec<u32>,
    /// Scratch space of [`EdgeKeys::couple_block_avx512`].
    words: Vec<u32>,
    /// The runs that [`EdgeKeys::couple_block_avx512`] declined.
    declined: Vec<u32>,
}

impl<K: EdgeKeys> Default for BlockScratch<K> {
    fn default() -> Self {
        BlockScratch {
            extra: Vec::new(),
            sorted: Vec::new(),
            start: Vec::new(),
            words: Vec::new(),
            declined: Vec::new(),
        }
    }
}

/// Whether this CPU has AVX-512 F, and POPCNT and BMI2 (as every such CPU does), for
/// the AVX-512 kernels of [`EdgeKeys`] (detected once, then a cached flag).
pub(crate) fn has_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("popcnt")
            && std::arch::is_x86_feature_detected!("bmi2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The words of each of `count` (at most 16) records of `W` (2 to 4) 32-bit words at
/// `base`: word `w` of record `i` in lane `i` of vector `w` (0 in lanes from `count`
/// on). Up to `W` masked loads, so nothing past the records is read.
///
/// # Safety
/// The CPU has AVX-512 F; the records are readable.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn load_records<const W: usize>(
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
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn records_of_lanes_avx512(
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

/// The most vertices [`load_triangles_avx512`] takes: gathers take i32 offsets, and
/// `3v + axis` must fit.
pub(super) const MAX_GATHER_VERTICES: usize = (i32::MAX / 3) as usize;

/// Triangles `first..first + 16` of `mesh` in AVX-512 lanes: their vertex indices
/// (`[corner]`), their corners (`[corner][axis]`, 0 in lanes that take no part), and
/// the lanes that take part, as `ActiveTriangles::get` says: indices in range, three
/// distinct vertices ([`has_edges`](crate::mesh::has_edges)), finite corners.
///
/// # Safety
/// The CPU has AVX-512 F; the mesh has at most [`MAX_GATHER_VERTICES`] vertices.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn load_triangles_avx512(
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

/// [`edge_bbsa`](super::edge_bbsa) of the edges `p–q` in AVX-512 lanes
/// (`[axis]`), with the same floating-point operations in the same order, so the same
/// bits.
///
/// # Safety
/// The CPU has AVX-512 F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn edge_bbsa_avx512(
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
/// beats 48 increments in a chain (the dragon's first pass, one core: 6.8 → 5.3 ms).
///
/// # Safety
/// The CPU has AVX-512 F and POPCNT.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,popcnt")]
#[inline]
pub(super) unsafe fn rank_and_count_lanes(
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
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn load_group_avx512(
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
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,popcnt")]
#[inline]
pub(super) unsafe fn append_lanes_avx512(
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
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn for_each_block_avx512(
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
#[cfg(target_arch = "x86_64")]
unsafe fn couple_block<K: EdgeKeys>(
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

/// The longest run whose twins [`EdgeKeys::couple_block_avx512`] is sure to find: the
/// window of [`window_matches_avx512`] reaches the rest of the run from any of its
/// half-edges.
pub(super) const BLOCK_WINDOW: usize = 16;

/// Writes the words that [`window_matches_avx512`] compares, one per half-edge of a
/// block of `len`, into `words`: `word(p)` gives those of half-edges `p..p + 16`, kept
/// in the block's lanes. Before them, [`BLOCK_WINDOW`] words, and after the last
/// group, twice that, of -1: past the block, words that no half-edge has, or that
/// the kernels check like any other. Returns where half-edge 0's word is.
///
/// # Safety
/// The CPU has AVX-512 F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn block_words_avx512(
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
#[cfg(target_arch = "x86_64")]
#[inline]
pub(super) fn block_lanes(len: usize, p: usize) -> std::arch::x86_64::__mmask16 {
    ((1u32 << len.saturating_sub(p).min(16)) - 1) as std::arch::x86_64::__mmask16
}

/// Half-edges `p..p + 16` of a block of `len` records of `W` words at `records`, as
/// [`load_records`] gives them (0 past the block's end), and the lanes in the block.
///
/// # Safety
/// The CPU has AVX-512 F; the block's records are readable.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn load_block_group<const W: usize>(
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
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn window_matches_avx512(
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
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn lanes_at_avx512(
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
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,popcnt")]
#[inline]
pub(super) unsafe fn decline_lanes_avx512(
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

/// Couple the runs of a block sorted by run, run `r` ending at `ends[r]`
/// ([`couple_pairs`], or [`couple_run`] where that declines).
pub(super) fn couple_runs<K: EdgeKeys>(
    sorted: &[K::HalfEdge],
    ends: &[u32],
    keys: &K,
    links: &Links,
    extra: &mut Vec<ExtraCouple>,
) {
    let mut from = 0;
    for &end in ends {
        let run = &sorted[from..end as usize];
        from = end as usize;
        if !couple_pairs(run, keys, links) {
            couple_run(run, keys, links, extra);
        }
    }
}

/// Couple the half-edges of one run when it is at most [`HalfEdge::WINDOW`] long and
/// every edge in it has at most two: two on one edge couple when they may, and their
/// links are written. Returns false, having written nothing that [`couple_run`] will
/// not write again, otherwise.
#[inline(always)]
fn couple_pairs<K: EdgeKeys>(run: &[K::HalfEdge], keys: &K, links: &Links) -> bool {
    type H<K> = <K as EdgeKeys>::HalfEdge;
    if run.len() > H::<K>::WINDOW {
        return false;
    }
    // The edges in a fixed window (an edge no half-edge has in the spare lanes),
    // compared all at once: lanes where e's edge is.
    let mut edges = [H::<K>::NO_EDGE; MAX_WINDOW];
    for (l, e) in edges.iter_mut().zip(run) {
        *l = e.edge();
    }
    let mut at_most_two = true;
    for (i, e) in run.iter().enumerate() {
        let lanes = edges[..H::<K>::WINDOW]
            .iter()
            .enumerate()
            .fold(0u32, |m, (j, &l)| m | ((l == e.edge()) as u32) << j);
        // `count_ones` is a library routine on baseline x86-64: with e's own lane
        // cleared, one more lane means a twin, two or more a shared edge.
        let others = lanes & !(1 << i);
        let one_other = (others != 0) & (others & others.wrapping_sub(1) == 0);
        at_most_two &= others & others.wrapping_sub(1) == 0;
        let other = run[(others.trailing_zeros() as usize).min(run.len() - 1)];
        if one_other && keys.may_couple(&other, e) {
            // SAFETY: the run's half-edges are written by this thread only.
            unsafe { links.write(e, &other) };
        }
    }
    at_most_two
}

/// Write the couples of a whole run into `links` and `extra`, as [`Couples::link`]
/// describes. The run's half-edges are sorted by edge, then triangle (a stable sort:
/// one triangle's stay in side order), so each edge's are in id order and a long run
/// (a fan's centre is the smaller vertex of thousands of edges) costs O(L log L), not
/// O(L²).
fn couple_run<K: EdgeKeys>(
    run: &[K::HalfEdge],
    keys: &K,
    links: &Links,
    extra: &mut Vec<ExtraCouple>,
) {
    let mut by_edge: Vec<usize> = (0..run.len()).collect();
    let edge: Vec<u128> = run.iter().map(|h| keys.exact_edge(h)).collect();
    by_edge.sort_by_key(|&i| (edge[i], run[i].triangle()));
    for on_edge in by_edge.chunk_by(|&a, &b| edge[a] == edge[b]) {
        match *on_edge {
            [_] => {}
            [i, j] => {
                if keys.may_couple(&run[i], &run[j]) {
                    // SAFETY: the run's half-edges are written by this thread only.
                    unsafe {
                        links.write(&run[i], &run[j]);
                        links.write(&run[j], &run[i]);
                    }
                }
            }
            _ => {
                let extra_before = extra.len();
                let first = &run[on_edge[0]];
                for (rank, w) in on_edge.windows(2).enumerate() {
                    if keys.may_couple(&run[w[0]], &run[w[1]]) {
                        let key = keys.extra_key(first, (on_edge.len() - 1 - rank) as u32);
                        let (a, b) = (run[w[0]].triangle(), run[w[1]].triangle());
                        extra.push(ExtraCouple {
                            triangle: a,
                            neighbour: b,
                            key,
                        });
                        extra.push(ExtraCouple {
                            triangle: b,
                            neighbour: a,
                            key,
                        });
                    }
                }
                // Sides on an edge of only unpairable half-edges have no couple.
                if extra.len() > extra_before {
                    for &j in on_edge {
                        // SAFETY: as above.
                        unsafe { links.mark_shared(&run[j]) };
                    }
                }
            }
        }
    }
}

/// Where [`Couples::link`] writes the couples it finds: [`Couples::across`], through a
/// pointer that the blocks' threads share, and the side ranks that place and name the
/// links.
pub(super) struct Links<'a> {
    /// [`Couples::across`].
    pub(super) across: SharedSlice<u32>,
    /// [`Couples::side_ranks`], then [`RANKS_PADDING`] bytes.
    pub(super) ranks: &'a [u8],
}

/// Bytes after the side ranks in [`Links::ranks`], so that an AVX-512 gather of four
/// bytes at any triangle's reads no further than the slice.
pub(super) const RANKS_PADDING: usize = 3;

impl Links<'_> {
    /// Link `from`'s side to `to`'s.
    ///
    /// # Safety
    /// `from`'s slot is this thread's.
    #[inline]
    unsafe fn write<H: HalfEdge>(&self, from: &H, to: &H) {
        let slot = 3 * from.triangle() as usize + from.rank(self.ranks) as usize;
        self.across.0.add(slot).write(to.link(self.ranks));
    }

    /// Mark `h`'s side as on an edge of three or more half-edges.
    ///
    /// # Safety
    /// As [`Links::write`].
    #[inline]
    unsafe fn mark_shared<H: HalfEdge>(&self, h: &H) {
        let slot = 3 * h.triangle() as usize + h.rank(self.ranks) as usize;
        self.across.0.add(slot).write(SHARED_BY_MORE);
    }
}

/// Link the half-edges of lanes `coupled` to their twins in AVX-512 lanes, as
/// [`Links::write`] does: a half-edge whose link is `link` (its triangle and its
/// side's rank) and whose twin's is `twin_link`. A link names its side's slot as
/// well: `3t + rank` is `link - t`. One scatter.
///
/// # Safety
/// The CPU has AVX-512 F; the slots are this thread's.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) unsafe fn write_links_avx512(
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

/// A couple on an edge of three or more half-edges, seen from `triangle`.
#[derive(Clone, Copy, Debug)]
pub(super) struct ExtraCouple {
    /// The proposing triangle.
    triangle: u32,
    /// The triangle across the edge.
    neighbour: u32,
    /// The couple's key.
    key: u128,
}

/// The greedy matching of `couples` by descending key, where `side_keys(t)` gives the
/// keys of triangle `t`'s three sides (called only for triangles with a couple on a side
/// that is not [`SHARED_BY_MORE`]). Keys must be distinct between couples and above 0.
/// With AVX-512 kernels for the mutual best couples and the pairs when `avx512` (which
/// the CPU must have).
pub(super) fn match_greedily(
    couples: Couples,
    side_keys: impl Fn(usize) -> [u128; 3],
    avx512: bool,
) -> Pairing {
    let n = couples.across.len() / 3;
    debug_assert!(n <= MAX_LINKED_TRIANGLES);
    if !couples.extra.is_empty() {
        return match_by_keys(&couples, side_keys);
    }
    let Couples {
        across: links,
        side_ranks: mut state,
        ..
    } = couples;
    let part_len = triangle_part_len(n);
    // Every part's mutual best couples settled before any triangle proposes.
    let proposers: Vec<Vec<u32>> = state[..n]
        .par_chunks_mut(part_len)
        .enumerate()
        .map(|(p, state)| settle_mutual_best(&links, state, p * part_len, avx512))
        .collect();
    let proposers = |p: usize| proposers[p].iter().map(|&t| t as usize);
    if rayon::current_num_threads() > 1 {
        // SAFETY: `AtomicU8` has the size, alignment and bit validity of `u8`, and
        // `state` is borrowed mutably for as long as `offers` lives.
        let offers = unsafe { &*(state.as_mut_slice() as *mut [u8] as *const [AtomicU8]) };
        (0..n.div_ceil(part_len))
            .into_par_iter()
            .for_each(|p| propose(&links, &mut { offers }, proposers(p)));
    } else {
        for p in 0..n.div_ceil(part_len) {
            propose(&links, state.as_mut_slice(), proposers(p));
        }
    }
    #[cfg(target_arch = "x86_64")]
    if avx512 && 3 * n <= i32::MAX as usize {
        // SAFETY: `avx512` says the CPU has the features; slots fit the gathers' i32
        // offsets.
        return unsafe { suitor_pairs_avx512(&links, &state, n) };
    }
    Pairing::from_partner_fn(n, |t| suitor_partner(&links, &state[..n], t))
}

/// Settle the couples that are the best of both their triangles (rank 0 at each end:
/// the greedy matching takes them, as no couple outranks them, and their triangles
/// never propose), for the triangles `first..` whose states are `state`: their offers
/// are 0, the others' [`NO_SUITOR`]. Returns the others, which then propose. On the
/// dragon, 58% of the triangles are settled. When `avx512` (which the CPU must have),
/// 16 triangles at a time ([`settle_mutual_best_avx512`]).
fn settle_mutual_best(links: &[u32], state: &mut [u8], first: usize, avx512: bool) -> Vec<u32> {
    let mut proposers = Vec::with_capacity(state.len());
    let done = match avx512 {
        // SAFETY: `avx512` says the CPU has the features.
        #[cfg(target_arch = "x86_64")]
        true => unsafe { settle_mutual_best_avx512(links, state, first, &mut proposers) },
        _ => 0,
    };
    for (i, offer) in state.iter_mut().enumerate().skip(done) {
        let t = first + i;
        let mutual = links[3 * t] & 3 == 0;
        *offer = if mutual { 0 } else { NO_SUITOR };
        if !mutual {
            proposers.push(t as u32);
        }
    }
    proposers
}

/// [`settle_mutual_best`] for whole groups of 16 triangles: their best sides' links
/// loaded (three vectors, one permutation), the offers written as bytes and the
/// proposers compressed. Returns how many triangles it did.
///
/// # Safety
/// The CPU has AVX-512 F and POPCNT; `proposers` has room for `state.len()` more.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,popcnt")]
unsafe fn settle_mutual_best_avx512(
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
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,popcnt")]
unsafe fn suitor_pairs_avx512(links: &[u32], state: &[u8], n: usize) -> Pairing {
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

/// Suitor when every couple is across a side ([`Couples::extra`] is empty): each of
/// `proposers` proposes in turn, then each triangle it displaces. Its sides' links
/// are in the order of its keys, so it proposes across the first one whose triangle
/// takes it: one whose suitor's couple has a larger rank there, or that has no
/// suitor. A triangle's offer is the rank in it of its suitor's couple, or
/// [`NO_SUITOR`]: the rank names the side, and so the suitor, which is the triangle
/// across it. All the state is one byte a triangle, and a proposal reads one link and
/// one byte when its best couple is accepted (on the dragon, 10 ms where the rank
/// comparisons of twins' sides took 20, one core).
///
/// On several threads, parts of the proposers go at once with [`AtomicU8`] offers
/// (the parallel Suitor of Manne & Halappanavar): an offer is replaced only if it is
/// still the one that was beaten, else the proposer reads it again. Offers only ever
/// fall, so one read late still tells a refusal truly, and the matching is the one
/// thread's.
fn propose<S: Offers + ?Sized>(
    links: &[u32],
    offers: &mut S,
    proposers: impl IntoIterator<Item = usize>,
) {
    for first in proposers {
        let mut proposer = first;
        let mut side = 0;
        while side < 3 {
            let link = links[3 * proposer + side];
            if link == NO_LINK {
                side += 1;
                continue;
            }
            let (v, rank) = ((link >> 2) as usize, (link & 3) as u8);
            let offer = offers.offer(v);
            if rank >= offer {
                side += 1;
            } else if offers.replace(v, offer, rank) {
                if offer == NO_SUITOR {
                    break;
                }
                proposer = (links[3 * v + offer as usize] >> 2) as usize;
                side = 0;
            }
        }
    }
}

/// The offers that [`propose`] reads and replaces, per triangle.
trait Offers {
    /// The rank in `v` of its suitor's couple, or [`NO_SUITOR`].
    fn offer(&self, v: usize) -> u8;
    /// Replace `v`'s offer `was` by `rank`, unless it is no longer `was` (then false).
    fn replace(&mut self, v: usize, was: u8, rank: u8) -> bool;
}

impl Offers for [u8] {
    #[inline(always)]
    fn offer(&self, v: usize) -> u8 {
        self[v]
    }

    #[inline(always)]
    fn replace(&mut self, v: usize, _: u8, rank: u8) -> bool {
        self[v] = rank;
        true
    }
}

/// Offers shared between threads; `Relaxed` suffices, as each offer is one atomic
/// value and the threads' results meet when the pool joins.
impl Offers for &[AtomicU8] {
    #[inline(always)]
    fn offer(&self, v: usize) -> u8 {
        self[v].load(Relaxed)
    }

    #[inline(always)]
    fn replace(&mut self, v: usize, was: u8, rank: u8) -> bool {
        self[v]
            .compare_exchange(was, rank, Relaxed, Relaxed)
            .is_ok()
    }
}

/// Triangle `t`'s partner after [`propose`]: its suitor, when
/// it is its suitor's suitor. Read without a branch (clamped when t has no suitor).
#[inline]
fn suitor_partner(links: &[u32], state: &[u8], t: usize) -> u32 {
    let rank = state[t];
    let link = links[3 * t + rank.min(2) as usize];
    let u = ((link >> 2) as usize).min(state.len() - 1);
    let mutual = (rank != NO_SUITOR) & (state[u] == (link & 3) as u8);
    if mutual {
        u as u32
    } else {
        UNPAIRED
    }
}

/// [`propose`]'s state of a triangle with no suitor (and the rank worse than all).
const NO_SUITOR: u8 = 3;

/// Suitor with whole keys: `offer[t]` is the key of `t`'s suitor's couple.
fn match_by_keys(couples: &Couples, side_keys: impl Fn(usize) -> [u128; 3]) -> Pairing {
    let n = couples.across.len() / 3;
    // suitor[t]: 1 + the triangle proposing to t (0: none); offer[t]: its couple's key.
    let mut suitor = filled_on_huge_pages(n, 0u32);
    let mut offer = filled_on_huge_pages(n, 0u128);
    for first in 0..n {
        let mut proposer = first;
        loop {
            let (mut best_key, mut best) = (0u128, usize::MAX);
            let across: [u32; 3] = std::array::from_fn(|j| couples.across[3 * proposer + j]);
            let coupled = across.map(|a| a != NO_LINK && a != SHARED_BY_MORE);
            if coupled.contains(&true) {
                // Slot j's key is the j-th largest: a side with a couple ties with none.
                let mut keys = side_keys(proposer);
                keys.sort_unstable_by(|a, b| b.cmp(a));
                // Selects rather than branches: which side wins is a coin toss.
                for j in 0..3 {
                    let v = if coupled[j] {
                        (across[j] >> 2) as usize
                    } else {
                        proposer
                    };
                    let better = coupled[j] & (keys[j] > offer[v]) & (keys[j] > best_key);
                    best_key = if better { keys[j] } else { best_key };
                    best = if better { v } else { best };
                }
            }
            if across.contains(&SHARED_BY_MORE) {
                let from = couples
                    .extra
                    .partition_point(|e| (e.triangle as usize) < proposer);
                for e in couples.extra[from..]
                    .iter()
                    .take_while(|e| e.triangle as usize == proposer)
                {
                    let v = e.neighbour as usize;
                    if e.key > best_key && e.key > offer[v] {
                        (best_key, best) = (e.key, v);
                    }
                }
            }
            if best == usize::MAX {
                break;
            }
            let displaced = std::mem::replace(&mut suitor[best], proposer as u32 + 1);
            offer[best] = best_key;
            if displaced == 0 {
                break;
            }
            proposer = (displaced - 1) as usize;
        }
    }
    Pairing::from_partner_fn(n, |t| {
        let s = suitor[t];
        let mutual = s != 0 && suitor[(s - 1) as usize] as usize == t + 1;
        if mutual {
            s - 1
        } else {
            UNPAIRED
        }
    })
}

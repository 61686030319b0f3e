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

#[cfg(target_arch = "x86_64")]
pub(super) mod avx512;

use super::{Pairing, UNPAIRED};
use crate::mesh::{part_cursors, triangle_part_len, SharedSlice};
use crate::pages::{filled_on_huge_pages, vec_on_huge_pages};
#[cfg(target_arch = "x86_64")]
use avx512::{couple_block, settle_mutual_best_avx512, suitor_pairs_avx512};
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
    /// about each half-edge: [`avx512::window_matches_avx512`]): the links of the couples it
    /// finds written, as [`couple_pairs`] writes them, and the half-edges whose runs
    /// it leaves to [`couple_run`] listed in `declined` (by place in `sorted`), those
    /// with an edge of three or more half-edges among them. `words` is scratch space.
    ///
    /// # Safety
    /// The CPU has AVX-512 F and POPCNT ([`crate::simd::has_avx512`]); the block's slots in `links`
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
    /// The CPU has AVX-512 F, POPCNT and BMI2 ([`crate::simd::has_avx512`]); the cursors give every
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
    /// pool's threads. When `avx512` (which the CPU must have: [`crate::simd::has_avx512`]), the passes
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
/// (neighbouring half-edges often share a run) interleave. While it sorts, the next
/// block's half-edges, `next`, are fetched from the shared cache, a line in step with
/// each line read. As it places a half-edge, the line of its triangle's slots in
/// `links` is fetched, where the block kernel's scatter of links missed (fetched as it
/// counts, or with write intent, it gained nothing).
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

/// The most vertices [`avx512::load_triangles_avx512`] takes: gathers take i32 offsets, and
/// `3v + axis` must fit.
pub(super) const MAX_GATHER_VERTICES: usize = (i32::MAX / 3) as usize;

/// The longest run whose twins [`EdgeKeys::couple_block_avx512`] is sure to find: the
/// window of [`avx512::window_matches_avx512`] reaches the rest of the run from any of its
/// half-edges.
pub(super) const BLOCK_WINDOW: usize = 16;

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

/// Suitor when every couple is across a side ([`Couples::extra`] is empty): each of
/// `proposers` proposes in turn, then each triangle it displaces. Its sides' links
/// are in the order of its keys, so it proposes across the first one whose triangle
/// takes it: one whose suitor's couple has a larger rank there, or that has no
/// suitor. A triangle's offer is the rank in it of its suitor's couple, or
/// [`NO_SUITOR`]: the rank names the side, and so the suitor, which is the triangle
/// across it. All the state is one byte a triangle, and a proposal reads one link and
/// one byte when its best couple is accepted (half the time that comparing the ranks
/// of twins' sides took).
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

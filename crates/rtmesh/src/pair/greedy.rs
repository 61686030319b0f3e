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
//! The fast route, [`pair_sah`], gives the same pairing (asserted by tests): it finds
//! twins first with the counting sort of [`HalfEdgeRuns`] (edges come out in ascending
//! `(first, second)` order, so an edge's rank encodes that part of the key), drops
//! boundary edges, and radix-sorts only the shared edges on a 64-bit key
//! `BBSA bits << 32 | edge rank` (positive floats sort as their bits): three passes of
//! 8-bit digits over the BBSA's significant bits, no per-edge allocation. Cost:
//! O(T + V) time; about 24 bytes per half-edge of scratch memory. The half-edge table,
//! the couples and the sort split their work over the rayon pool's threads; the scan,
//! whose every step depends on the ones before, stays on one.

use super::{edge_bbsa, ActiveTriangles, Pairing, UNPAIRED};
use crate::mesh::{HalfEdgeRuns, TriMesh};
use crate::pages::vec_on_huge_pages;
use crate::radix::sort_u64_by_bits;
use rayon::prelude::*;

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

/// The same pairing as [`pair_sah_reference`], fast: twins first, then a radix sort of
/// the shared edges only.
///
/// Each shared edge yields its candidate couples (neighbouring active triangles in
/// table order that traverse it in opposite directions) while the edges are walked in
/// vertex order, where the mesh's own locality keeps the reads in cache. Records
/// `BBSA bits << 32 | couple index` go through the sort (8 bytes each: the sort is
/// bound by memory traffic), and the scan prefetches the couples it will read.
pub fn pair_sah(mesh: &TriMesh) -> Pairing {
    let runs = HalfEdgeRuns::build(mesh);
    let active = ActiveTriangles::new(mesh);
    let is_active: Vec<bool> = (0..mesh.triangle_count())
        .into_par_iter()
        .map(|t| active.get(t))
        .collect();
    // Blocks of vertices in parallel, each with its records (couple indices local to
    // the block) and couples, concatenated in vertex order below.
    let mut blocks: Vec<(Vec<u64>, Vec<[u32; 2]>)> =
        HalfEdgeRuns::vertex_blocks(runs.vertex_count())
            .into_par_iter()
            .map(|vertices| shared_edge_couples(mesh, &runs, &is_active, vertices))
            .collect();
    let (mut records, mut all_couples) = blocks.remove(0);
    for (block_records, block_couples) in &blocks {
        let base = all_couples.len() as u64;
        records.extend(block_records.iter().map(|&r| r + base));
        all_couples.extend_from_slice(block_couples);
    }
    drop(blocks);
    // Stable ascending by BBSA keeps ascending (first, second) among equal areas;
    // walked backwards this is the table's descending [BBSA, first, second] order.
    sort_u64_by_bits(&mut records, 32, 64);
    // The scan's random reads go to a bitset of taken triangles (it stays in cache,
    // where a partner array would not) and to couples prefetched ahead.
    let mut taken = vec![0u64; mesh.triangle_count().div_ceil(64)];
    let is_taken = |taken: &[u64], t: u32| taken[(t / 64) as usize] >> (t % 64) & 1 != 0;
    let mut partner = vec![UNPAIRED; mesh.triangle_count()];
    const PREFETCH_DISTANCE: usize = 16;
    for (i, &record) in records.iter().enumerate().rev() {
        if let Some(j) = i.checked_sub(PREFETCH_DISTANCE) {
            crate::prefetch(&all_couples[records[j] as u32 as usize]);
        }
        let [a, b] = all_couples[record as u32 as usize];
        if !is_taken(&taken, a) && !is_taken(&taken, b) {
            taken[(a / 64) as usize] |= 1 << (a % 64);
            taken[(b / 64) as usize] |= 1 << (b % 64);
            partner[a as usize] = b;
            partner[b as usize] = a;
        }
    }
    Pairing::from_partners(&partner)
}

/// The couples of the shared edges whose smaller vertex is in `vertices` (neighbouring
/// active half-edges in table order that traverse the edge in opposite directions),
/// and one record `BBSA bits << 32 | couple index` per couple. An edge's couples are
/// listed last-first, as the scan walks the sorted records backwards.
fn shared_edge_couples(
    mesh: &TriMesh,
    runs: &HalfEdgeRuns,
    is_active: &[bool],
    vertices: std::ops::Range<usize>,
) -> (Vec<u64>, Vec<[u32; 2]>) {
    // About half the half-edges are edges, and on a closed mesh every edge is shared.
    let capacity = runs.half_edge_count_of(&vertices) / 2;
    let mut records: Vec<u64> = vec_on_huge_pages(capacity);
    let mut all_couples: Vec<[u32; 2]> = vec_on_huge_pages(capacity);
    let mut couples: Vec<[u32; 2]> = Vec::with_capacity(4);
    runs.for_each_edge_of(vertices, |first, second, half_edges| {
        if half_edges.len() < 2 {
            return;
        }
        couples.clear();
        let mut previous: Option<u32> = None;
        for &(_, h) in half_edges.iter().filter(|s| is_active[(s.1 / 3) as usize]) {
            if let Some(g) = previous {
                let (a, b) = (g / 3, h / 3);
                let starts_at_first =
                    |h: u32, t: u32| mesh.triangles[t as usize][(h % 3) as usize] == first;
                if starts_at_first(g, a) != starts_at_first(h, b) {
                    couples.push([a, b]);
                }
            }
            previous = Some(h);
        }
        if couples.is_empty() {
            return;
        }
        let bbsa = edge_bbsa(
            mesh.positions[first as usize],
            mesh.positions[second as usize],
        );
        for &couple in couples.iter().rev() {
            records.push((bbsa.to_bits() as u64) << 32 | all_couples.len() as u64);
            all_couples.push(couple);
        }
    });
    (records, all_couples)
}

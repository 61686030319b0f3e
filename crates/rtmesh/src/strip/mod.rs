//! Triangle strips for ray tracing: rtmesh's compact strip format ([`Strips`]), its
//! decoder, and the stripifiers that fill it: Strip-RT ([`sah::stripify`], SAH-aware,
//! after Lauterbach's ReduceM) and meshoptimizer's rasterization stripifier as the
//! baseline ([`meshopt::stripify`]).
//!
//! **The format, bit by bit.** A strip is a sequence of triangles in which each
//! triangle after the first shares an edge with the one before, oriented the other way
//! (so that winding is kept). Triangle k is held as its corners `(p, q, r)` in winding
//! order, where `(p, q)` is the edge it was entered by and `r` its newest vertex. The
//! next triangle leaves by one of the other two edges and adds one vertex `n`:
//!
//! ```text
//! turn bit 0 (LEFT):  across (q, r): the next triangle is (r, q, n)
//! turn bit 1 (RIGHT): across (r, p): the next triangle is (p, r, n)
//! ```
//!
//! The first triangle is stored as its three corners rotated so that its exit is
//! `(q, r)`. A strip of L triangles therefore costs L + 2 u32 vertex indices and L − 1
//! turn bits. Strips are stored back to back:
//!
//! - `indices`: per strip, 3 + (L − 1) vertex indices (u32);
//! - `turns`: one bit per triangle, LSB first in u32 words, at the triangle's position
//!   in strip order (the first triangle's bit is unused, so that bit k is triangle k's);
//! - `strip_start`: S + 1 u32 triangle offsets; strip s holds triangles
//!   `strip_start[s]..strip_start[s + 1]` and its indices start at
//!   `strip_start[s] + 2·s`.
//! - `triangle_source`: the input triangle id of each triangle in strip order (the map
//!   back; not topology, every leaf kind keeps one).
//!
//! Indices per triangle are `1 + 2·S / T` (1 + 2 × the restart share). Why this and
//! not AMD DGF's 2 control bits per triangle (RESTART, EDGE1, EDGE2, BACKTRACK): a
//! restart here is a table entry rather than a control code, which gives every strip
//! O(1) random access (a BVH leaf points at a strip), and with the turn bit a strip can
//! turn either way at no index cost, so the one bit DGF spends on BACKTRACK buys
//! nothing the ordering needs. Rasterization strips (`TRIANGLE_STRIP`, PLY
//! `tristrips`) cannot turn: writing ours as those repeats a vertex at each swap
//! ([`Strips::to_standard`]).
//!
//! Cost of decoding: one index and one bit per triangle, sequentially within a strip.

pub mod meshopt;
pub mod packed;
pub mod sah;
#[cfg(test)]
mod tests;
pub mod tunnel;

use crate::mesh::{names_a_vertex_twice, HalfEdgeRuns, TriMesh};
use serde::Serialize;

/// No neighbour across a side (boundary, non-manifold, or opposite winding).
pub(crate) const NONE: u32 = u32::MAX;

/// Triangle strips in rtmesh's compact format (see the module header).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Strips {
    /// Per strip, 3 + (L − 1) vertex indices.
    pub indices: Vec<u32>,
    /// One turn bit per triangle in strip order (0: across (q, r), 1: across (r, p)).
    pub turns: Vec<u32>,
    /// Triangle offset of each strip, and the total at the end.
    pub strip_start: Vec<u32>,
    /// Input triangle id of each triangle in strip order.
    pub triangle_source: Vec<u32>,
}

impl Strips {
    /// Number of strips.
    pub fn len(&self) -> usize {
        self.strip_start.len().saturating_sub(1)
    }

    /// Whether there is no strip.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Triangles in all strips.
    pub fn triangle_count(&self) -> usize {
        self.triangle_source.len()
    }

    /// The strip-order triangle range of strip `s`.
    pub fn triangles_of(&self, s: usize) -> std::ops::Range<usize> {
        self.strip_start[s] as usize..self.strip_start[s + 1] as usize
    }

    /// Turn bit of triangle `k` (strip order).
    #[inline(always)]
    pub fn turn(&self, k: usize) -> bool {
        self.turns[k / 32] >> (k % 32) & 1 != 0
    }

    /// Set the turn bit of triangle `k` (strip order).
    fn set_turn(&mut self, k: usize) {
        self.turns[k / 32] |= 1 << (k % 32);
    }

    /// Call `f(k, [p, q, r])` for each triangle of strip `s` in order, `k` its
    /// strip-order position; the corners are the input triangle's, rotated.
    #[inline(always)]
    pub fn for_each_triangle(&self, s: usize, mut f: impl FnMut(usize, [u32; 3])) {
        let range = self.triangles_of(s);
        let base = range.start + 2 * s;
        let mut t = [
            self.indices[base],
            self.indices[base + 1],
            self.indices[base + 2],
        ];
        f(range.start, t);
        for k in range.start + 1..range.end {
            let n = self.indices[k + 2 * s + 2];
            t = if self.turn(k) {
                [t[0], t[2], n]
            } else {
                [t[2], t[1], n]
            };
            f(k, t);
        }
    }

    /// Every triangle in strip order, decoded.
    pub fn decode(&self) -> Vec<[u32; 3]> {
        let mut out = Vec::with_capacity(self.triangle_count());
        for s in 0..self.len() {
            self.for_each_triangle(s, |_, t| out.push(t));
        }
        out
    }

    /// The same strips in the order `order` (a permutation of strip ids).
    pub fn reordered(&self, order: &[u32]) -> Strips {
        let mut out = Strips {
            indices: Vec::with_capacity(self.indices.len()),
            turns: vec![0; self.turns.len()],
            strip_start: Vec::with_capacity(self.strip_start.len()),
            triangle_source: Vec::with_capacity(self.triangle_source.len()),
        };
        out.strip_start.push(0);
        for &s in order {
            let s = s as usize;
            let range = self.triangles_of(s);
            let base = range.start + 2 * s;
            out.indices
                .extend_from_slice(&self.indices[base..base + range.len() + 2]);
            for k in range.clone() {
                if self.turn(k) {
                    out.set_turn(out.triangle_source.len());
                }
                out.triangle_source.push(self.triangle_source[k]);
            }
            out.strip_start.push(out.triangle_source.len() as u32);
        }
        out
    }

    /// Renumber the vertices (of a mesh with `vertex_count`) in the order the strips
    /// first use them; returns the old vertex id of each new one (unused vertices are
    /// dropped). [`packed::PackedStrips`] needs this numbering.
    pub fn renumber_by_first_use(&mut self, vertex_count: usize) -> Vec<u32> {
        let mut new_index = vec![u32::MAX; vertex_count];
        let mut old_of_new = Vec::new();
        for v in &mut self.indices {
            let slot = &mut new_index[*v as usize];
            if *slot == u32::MAX {
                *slot = old_of_new.len() as u32;
                old_of_new.push(*v);
            }
            *v = *slot;
        }
        old_of_new
    }

    /// Bytes of topology: indices, turn bits and the strip table (the map back to input
    /// ids not counted, as for every leaf kind).
    pub fn bytes(&self) -> usize {
        4 * (self.indices.len() + self.turns.len() + self.strip_start.len())
    }

    /// Vertex indices per triangle.
    pub fn indices_per_triangle(&self) -> f64 {
        self.indices.len() as f64 / self.triangle_count().max(1) as f64
    }

    /// The strips as rasterization strips (`TRIANGLE_STRIP`: triangle i is
    /// `(s_i, s_i+1, s_i+2)`, every odd one flipped), one index list per strip. A turn
    /// that the alternation does not make is a swap: the vertex before the previous
    /// triangle's last two is repeated before its newest (`a b c` becomes `a b a c`, one
    /// degenerate triangle), so that the shared edge ends the list. Decoding a list
    /// gives the strip's triangles with their winding, degenerate ones between.
    pub fn to_standard(&self) -> Vec<Vec<u32>> {
        (0..self.len())
            .map(|s| {
                let mut list: Vec<u32> = Vec::new();
                self.for_each_triangle(s, |_, t| {
                    let m = list.len();
                    if m >= 3 {
                        let (a, b) = (list[m - 2], list[m - 1]);
                        let ends_on_shared = (a == t[0] && b == t[1]) || (a == t[1] && b == t[0]);
                        if !ends_on_shared {
                            list.insert(m - 1, list[m - 3]);
                        }
                        list.push(t[2]);
                    } else {
                        list.extend_from_slice(&t);
                    }
                });
                list
            })
            .collect()
    }
}

/// Rasterization strips joined into one by degenerate triangles, for formats with no
/// restart index (glTF): `… a b` + `b c` + `c d e …`, with one more `c` when the next
/// strip would start at an odd triangle (which would flip its winding).
pub fn join_standard(lists: &[Vec<u32>]) -> Vec<u32> {
    let mut out: Vec<u32> = Vec::with_capacity(lists.iter().map(|l| l.len() + 3).sum());
    for list in lists.iter().filter(|l| l.len() >= 3) {
        if let Some(&last) = out.last() {
            out.push(last);
            out.push(list[0]);
            if out.len() % 2 == 1 {
                out.push(list[0]);
            }
        }
        out.extend_from_slice(list);
    }
    out
}

/// Whether `a` is a rotation of `b` (the same triangle with the same winding).
pub fn same_winding(a: [u32; 3], b: [u32; 3]) -> bool {
    a == b || a == [b[1], b[2], b[0]] || a == [b[2], b[0], b[1]]
}

/// Append the triangles of the rasterization strip `strip` to `out`: triangle `i` is
/// `(s[i], s[i+1], s[i+2])` for even `i` and `(s[i+1], s[i], s[i+2])` for odd `i`, so
/// all keep one winding. Triangles that name a vertex twice (joins and swaps) are left
/// out; returns how many. The PLY and glTF readers decode strips with it.
pub fn standard_triangles(strip: &[u32], out: &mut Vec<[u32; 3]>) -> usize {
    let mut dropped = 0;
    for (i, w) in strip.windows(3).enumerate() {
        let t = if i % 2 == 0 {
            [w[0], w[1], w[2]]
        } else {
            [w[1], w[0], w[2]]
        };
        if names_a_vertex_twice(t) {
            dropped += 1;
        } else {
            out.push(t);
        }
    }
    dropped
}

/// Figures of a stripification, with the keys of `rtmesh strip --json`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct StripReport {
    /// Triangles stripped.
    pub triangles: usize,
    /// Strips made.
    pub strips: usize,
    /// Vertex indices in rtmesh's format.
    pub indices: usize,
    /// Indices per triangle (1 + 2 × the restart share).
    pub indices_per_triangle: f64,
    /// Mean triangles per strip.
    pub mean_length: f64,
    /// Restarts (strips after the first).
    pub restarts: usize,
    /// Topology bytes (indices, turn bits, strip table) per triangle.
    pub bytes_per_triangle: f64,
    /// Seconds the stripification took.
    pub seconds: f64,
}

impl StripReport {
    /// The figures of several meshes' strips together, made in `seconds`.
    pub fn of_all(all: &[Strips], seconds: f64) -> Self {
        let mut total = Self::default();
        let mut bytes = 0;
        for strips in all {
            total.triangles += strips.triangle_count();
            total.strips += strips.len();
            total.indices += strips.indices.len();
            bytes += strips.bytes();
        }
        let triangles = total.triangles.max(1) as f64;
        Self {
            indices_per_triangle: total.indices as f64 / triangles,
            mean_length: total.triangles as f64 / total.strips.max(1) as f64,
            restarts: total.strips.saturating_sub(1),
            // No triangles: no bytes per triangle, though the strip table's end remains.
            bytes_per_triangle: if total.triangles == 0 {
                0.0
            } else {
                bytes as f64 / triangles
            },
            seconds,
            ..total
        }
    }

    /// The figures of `strips`, made in `seconds`.
    pub fn of(strips: &Strips, seconds: f64) -> Self {
        Self::of_all(std::slice::from_ref(strips), seconds)
    }
}

/// Each triangle's strip neighbour across each side: the other triangle of a
/// two-triangle edge of the mesh's index topology (split across groups and
/// materials), with that edge the other way round in it, and the side it is on there;
/// [`NONE`] elsewhere.
pub(crate) fn strip_neighbours(mesh: &TriMesh) -> Vec<[(u32, u8); 3]> {
    let topology = mesh.indices_within_groups();
    let triangles = &topology.triangles;
    let mut neighbours = vec![[(NONE, 0u8); 3]; triangles.len()];
    HalfEdgeRuns::build(&topology).for_each_edge(|_, _, half_edges| {
        let &[(_, h), (_, g)] = half_edges else {
            return;
        };
        let (t, side) = (h as usize / 3, h as usize % 3);
        let (u, other_side) = (g as usize / 3, g as usize % 3);
        if t != u && triangles[t][side] == triangles[u][(other_side + 1) % 3] {
            neighbours[t][side] = (u as u32, other_side as u8);
            neighbours[u][other_side] = (t as u32, side as u8);
        }
    });
    neighbours
}

/// Builds [`Strips`] from triangle sequences of a mesh.
pub(crate) struct Encoder<'a> {
    triangles: &'a [[u32; 3]],
    strips: Strips,
}

impl<'a> Encoder<'a> {
    pub(crate) fn new(triangles: &'a [[u32; 3]]) -> Self {
        let mut strips = Strips::default();
        strips.strip_start.push(0);
        strips.turns.resize(triangles.len().div_ceil(32), 0);
        strips.indices.reserve(triangles.len() * 5 / 4);
        strips.triangle_source.reserve(triangles.len());
        Self { triangles, strips }
    }

    /// Append the strip `sequence` of input triangle ids, each after the first sharing
    /// `exits[i]`, the side of `sequence[i]` it leaves by, with `sequence[i + 1]`.
    pub(crate) fn push(&mut self, sequence: &[u32], exits: &[u8]) {
        let Some(&first) = sequence.first() else {
            return;
        };
        let v = self.triangles[first as usize];
        let mut t = match exits.first() {
            // Rotate so that the exit side (v[s], v[s+1]) is (q, r).
            Some(&s) => {
                let s = s as usize;
                [v[(s + 2) % 3], v[s], v[(s + 1) % 3]]
            }
            None => v,
        };
        self.strips.indices.extend_from_slice(&t);
        self.strips.triangle_source.push(first);
        for (i, &next) in sequence.iter().enumerate().skip(1) {
            let k = self.strips.triangle_source.len();
            let w = self.triangles[next as usize];
            let s = exits[i - 1] as usize;
            let prev = self.triangles[sequence[i - 1] as usize];
            let shared = [prev[s], prev[(s + 1) % 3]];
            let n = *w.iter().find(|x| !shared.contains(x)).unwrap_or(&w[0]);
            let right = shared.contains(&t[0]);
            if right {
                self.strips.set_turn(k);
                t = [t[0], t[2], n];
            } else {
                t = [t[2], t[1], n];
            }
            debug_assert!(same_winding(t, w), "strip triangle {t:?} is not {w:?}");
            self.strips.indices.push(n);
            self.strips.triangle_source.push(next);
        }
        self.strips
            .strip_start
            .push(self.strips.triangle_source.len() as u32);
    }

    pub(crate) fn finish(self) -> Strips {
        self.strips
    }
}

/// The first bytes of an `.rts` file.
pub const RTS_MAGIC: &[u8; 4] = b"RTS1";

impl Strips {
    /// The strips and their vertex positions as an `.rts` file, all little-endian:
    /// `RTS1`; u32 vertex, strip, triangle and index counts; the positions (3 × f32 per
    /// vertex); `strip_start` (strips + 1 u32); `indices`; `turns` (⌈triangles / 32⌉
    /// u32); `triangle_source` (u32 per triangle).
    pub fn to_rts(&self, positions: &[glam::Vec3]) -> Vec<u8> {
        let words = [
            positions.len(),
            self.len(),
            self.triangle_count(),
            self.indices.len(),
        ];
        let mut out = Vec::with_capacity(
            16 + 12 * positions.len() + self.bytes() + 4 * self.triangle_count(),
        );
        out.extend_from_slice(RTS_MAGIC);
        for w in words {
            out.extend_from_slice(&(w as u32).to_le_bytes());
        }
        for p in positions {
            for c in p.to_array() {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        for list in [
            &self.strip_start,
            &self.indices,
            &self.turns,
            &self.triangle_source,
        ] {
            for w in list {
                out.extend_from_slice(&w.to_le_bytes());
            }
        }
        out
    }

    /// Read an `.rts` file back ([`Self::to_rts`]): the positions and the strips, or
    /// what is wrong with it.
    pub fn from_rts(bytes: &[u8]) -> Result<(Vec<glam::Vec3>, Strips), String> {
        let mut words = bytes
            .get(4..)
            .filter(|_| bytes.starts_with(RTS_MAGIC))
            .ok_or("not an .rts file (no RTS1 magic)")?
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]));
        let mut take = |n: usize, what: &str| -> Result<Vec<u32>, String> {
            let v: Vec<u32> = words.by_ref().take(n).collect();
            if v.len() == n {
                Ok(v)
            } else {
                Err(format!("the file ends inside its {what}"))
            }
        };
        let counts = take(4, "header")?;
        let [vertices, strips, triangles, indices] = [0, 1, 2, 3].map(|i| counts[i] as usize);
        if indices != triangles + 2 * strips
            || vertices.checked_mul(12).is_none_or(|b| b > bytes.len())
        {
            return Err(format!("inconsistent header: {indices} indices for {triangles} triangles in {strips} strips"));
        }
        let positions = take(3 * vertices, "positions")?
            .chunks_exact(3)
            .map(|c| {
                glam::Vec3::new(
                    f32::from_bits(c[0]),
                    f32::from_bits(c[1]),
                    f32::from_bits(c[2]),
                )
            })
            .collect();
        let out = Strips {
            strip_start: take(strips + 1, "strip table")?,
            indices: take(indices, "indices")?,
            turns: take(triangles.div_ceil(32), "turn bits")?,
            triangle_source: take(triangles, "triangle ids")?,
        };
        let starts_ok = out.strip_start.first() == Some(&0)
            && out.strip_start.last() == Some(&(triangles as u32))
            && out.strip_start.windows(2).all(|w| w[0] < w[1]);
        if !starts_ok {
            return Err("the strip table is not increasing from 0 to the triangle count".into());
        }
        if let Some(bad) = out.indices.iter().find(|&&i| i as usize >= vertices) {
            return Err(format!("index {bad} is past the {vertices} vertices"));
        }
        Ok((positions, out))
    }
}

//! Packed strips: the form the tracer keeps [`Strips`] in, about a byte a triangle of
//! topology instead of five.
//!
//! It rests on one property of the tracer's vertex buffer: its vertices are numbered in
//! the order the strips first use them (`trace::strip` reorders them so). Then a vertex
//! index in the strip stream is either *fresh*, exactly one more than the highest seen
//! so far, or a *reuse*, some distance back from that running count `next_fresh`. A
//! fresh index costs one bit and nothing else; a reuse stores its distance back, which
//! is small because strips stored near each other in the tree touch each other:
//!
//! - `fresh`: one bit per index slot (a strip of L triangles has L + 2 slots, slot
//!   `k + 2·s` for its triangle k, as in [`Strips`]), LSB first in u32 words: 1 fresh,
//!   0 reuse;
//! - `back`: for each reuse in stream order, its distance `d = next_fresh − v` (≥ 1) as
//!   one byte when d ≤ 255, else a 0 byte and d as four bytes little-endian; then one
//!   spare 0 byte;
//! - `turns`: [`Strips`]' turn bits, unchanged;
//! - `lengths`: each strip's triangle count, one byte (the tracer takes strips of at
//!   most 64 triangles).
//!
//! The stream is sequential: a strip is decoded from a [`Cursor`] at its start, which
//! the tracer keeps in its BVH leaves (12 bytes a strip, counted with the hierarchy; the
//! strip's index is its leaf's place, as the strips are stored in leaf order).
//! Why a byte and an escape rather than a fixed width: most reuses are a few dozen
//! vertices back and a few are hundreds of thousands (docs/measurements/strips.md has
//! the distribution on the scans).
//!
//! Cost of decoding: per index one bit test and, for a reuse, one or five byte loads;
//! per triangle one turn bit, as in [`Strips::for_each_triangle`].

use super::Strips;

/// Where a strip's decoding starts in a [`PackedStrips`] stream.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Cursor {
    /// Its first triangle in strip order.
    pub triangle: u32,
    /// Its first byte in `back`.
    pub back: u32,
    /// The vertex a fresh index names next.
    pub next_fresh: u32,
}

/// [`Strips`] packed for tracing (see the module header).
#[derive(Clone, Debug, Default)]
pub struct PackedStrips {
    fresh: Vec<u32>,
    back: Vec<u8>,
    turns: Vec<u32>,
    lengths: Vec<u8>,
}

/// Why strips cannot be packed.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum PackError {
    /// An index is neither fresh nor a reuse: the vertices are not numbered by first use.
    #[error("vertex {vertex} at index slot {slot} is beyond the next fresh vertex {next_fresh}: vertices are not numbered by first use")]
    NotFirstUse {
        /// The index slot.
        slot: usize,
        /// The vertex named there.
        vertex: u32,
        /// The next fresh vertex at that point.
        next_fresh: u32,
    },
    /// A strip is longer than a length byte holds.
    #[error("strip {strip} has {length} triangles; packed strips hold at most 255")]
    TooLong {
        /// The strip.
        strip: usize,
        /// Its length.
        length: usize,
    },
}

impl PackedStrips {
    /// Pack `strips`, whose vertices must be numbered in the order the strips first
    /// use them. Returns the stream and each strip's starting cursor.
    pub fn pack(strips: &Strips) -> Result<(Self, Vec<Cursor>), PackError> {
        let slots = strips.indices.len();
        let mut out = Self {
            fresh: vec![0; slots.div_ceil(32)],
            back: Vec::with_capacity(slots),
            turns: strips.turns.clone(),
            lengths: Vec::with_capacity(strips.len()),
        };
        let mut starts = Vec::with_capacity(strips.len());
        let mut next_fresh = 0u32;
        for s in 0..strips.len() {
            let range = strips.triangles_of(s);
            let length = u8::try_from(range.len()).map_err(|_| PackError::TooLong {
                strip: s,
                length: range.len(),
            })?;
            out.lengths.push(length);
            starts.push(Cursor {
                triangle: range.start as u32,
                back: out.back.len() as u32,
                next_fresh,
            });
            let first_slot = range.start + 2 * s;
            for slot in first_slot..first_slot + range.len() + 2 {
                let vertex = strips.indices[slot];
                if vertex == next_fresh {
                    out.fresh[slot / 32] |= 1 << (slot % 32);
                    next_fresh += 1;
                } else if vertex < next_fresh {
                    let d = next_fresh - vertex;
                    match u8::try_from(d) {
                        Ok(d) => out.back.push(d),
                        Err(_) => {
                            out.back.push(0);
                            out.back.extend_from_slice(&d.to_le_bytes());
                        }
                    }
                } else {
                    return Err(PackError::NotFirstUse {
                        slot,
                        vertex,
                        next_fresh,
                    });
                }
            }
        }
        // The spare byte the decoder reads past the last distance.
        out.back.push(0);
        Ok((out, starts))
    }

    /// Triangles of strip `s`.
    #[inline(always)]
    pub fn length(&self, s: usize) -> usize {
        usize::from(self.lengths[s])
    }

    /// Bytes of topology: fresh bits, reuse distances, turn bits and lengths.
    pub fn bytes(&self) -> usize {
        4 * (self.fresh.len() + self.turns.len()) + self.back.len() + self.lengths.len()
    }

    /// Call `f(k, [p, q, r])` for each triangle of strip `s`, whose cursor is
    /// `cursor` (as [`Self::pack`] returned it), as [`Strips::for_each_triangle`] does.
    #[inline(always)]
    pub fn for_each_triangle(&self, s: usize, cursor: &Cursor, mut f: impl FnMut(usize, [u32; 3])) {
        let mut decoder = self.decoder(s, cursor);
        for _ in 0..self.length(s) {
            let (k, t) = decoder.next_triangle();
            f(k, t);
        }
    }

    /// A decoder of strip `s` from its cursor, triangle by triangle.
    #[inline(always)]
    pub fn decoder(&self, s: usize, cursor: &Cursor) -> Decoder<'_> {
        let first = cursor.triangle as usize;
        Decoder {
            packed: self,
            k: first,
            first,
            slot: first + 2 * s,
            back: cursor.back as usize,
            next_fresh: cursor.next_fresh,
            t: [0; 3],
        }
    }
}

/// Decodes one strip of a [`PackedStrips`] in order (a loop the caller writes, so that
/// the tracer's per-triangle work is inlined with it).
pub struct Decoder<'a> {
    packed: &'a PackedStrips,
    k: usize,
    first: usize,
    slot: usize,
    back: usize,
    next_fresh: u32,
    t: [u32; 3],
}

impl Decoder<'_> {
    /// The next index of the stream. Branch-free on fresh against reuse (about as often
    /// one as the other): the next distance byte is read either way (`back` ends in a
    /// spare byte for that) and counts only for a reuse. The four-byte escape is rare.
    #[inline(always)]
    fn index(&mut self) -> u32 {
        let p = self.packed;
        let fresh = p.fresh[self.slot / 32] >> (self.slot % 32) & 1;
        self.slot += 1;
        let reuse = 1 - fresh;
        debug_assert!(self.back < p.back.len());
        // SAFETY: `pack` wrote one distance per reuse of the strip stream and a spare
        // byte after the last, and a cursor starts at a strip's first distance, so the
        // byte read before each index is within `back`.
        let mut d = u32::from(unsafe { *p.back.get_unchecked(self.back) });
        self.back += reuse as usize;
        if d == 0 && reuse == 1 {
            d = u32::from_le_bytes([0, 1, 2, 3].map(|i| p.back[self.back + i]));
            self.back += 4;
        }
        let v = self.next_fresh - d * reuse;
        self.next_fresh += fresh;
        v
    }

    /// The next triangle `(k, [p, q, r])`; call it at most the strip's length times.
    #[inline(always)]
    pub fn next_triangle(&mut self) -> (usize, [u32; 3]) {
        let k = self.k;
        self.k += 1;
        self.t = if k == self.first {
            [self.index(), self.index(), self.index()]
        } else {
            let n = self.index();
            let t = self.t;
            if self.packed.turns[k / 32] >> (k % 32) & 1 != 0 {
                [t[0], t[2], n]
            } else {
                [t[2], t[1], n]
            }
        };
        (k, self.t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two hand-built strips over vertices numbered by first use: the packed stream
    /// holds exactly the expected bits and bytes, and decodes to the same triangles.
    #[test]
    fn packs_fresh_bits_and_reuse_distances() {
        // Strip 0: triangles (0 1 2), (2 1 3) [turn 0]; strip 1: (3 1 4), which reuses
        // 3 and 1.
        let mut strips = Strips {
            indices: vec![0, 1, 2, 3, 3, 1, 4],
            turns: vec![0],
            strip_start: vec![0, 2, 3],
            triangle_source: vec![10, 11, 12],
        };
        let (packed, starts) = PackedStrips::pack(&strips).unwrap();
        // Slots 0..4 fresh (0, 1, 2, 3), 4 and 5 reuses, 6 fresh (4).
        assert_eq!(packed.fresh, vec![0b100_1111]);
        assert_eq!(packed.back, vec![1, 3, 0]);
        assert_eq!(packed.lengths, vec![2, 1]);
        let mut decoded = Vec::new();
        for (s, start) in starts.iter().enumerate() {
            packed.for_each_triangle(s, start, |k, t| decoded.push((k, t)));
        }
        let mut expected = Vec::new();
        for s in 0..strips.len() {
            strips.for_each_triangle(s, |k, t| expected.push((k, t)));
        }
        assert_eq!(decoded, expected);
        // A reuse more than 255 back takes the escape: three strips over 300 fresh
        // vertices, the last one (299 298 0).
        strips.indices = (0..300).chain([299, 298, 0]).collect();
        strips.strip_start = vec![0, 148, 296, 297];
        strips.turns = vec![0; 10];
        strips.triangle_source = (0..297).collect();
        let (packed, starts) = PackedStrips::pack(&strips).unwrap();
        assert_eq!(packed.back, vec![1, 2, 0, 44, 1, 0, 0, 0]);
        let mut last = Vec::new();
        packed.for_each_triangle(2, &starts[2], |_, t| last.push(t));
        assert_eq!(last, vec![[299, 298, 0]]);
    }

    /// Vertices not numbered by first use are refused, naming the slot.
    #[test]
    fn refuses_vertices_out_of_first_use_order() {
        let strips = Strips {
            indices: vec![0, 2, 1],
            turns: vec![0],
            strip_start: vec![0, 1],
            triangle_source: vec![0],
        };
        assert_eq!(
            PackedStrips::pack(&strips).unwrap_err(),
            PackError::NotFirstUse {
                slot: 1,
                vertex: 2,
                next_fresh: 1
            }
        );
    }
}

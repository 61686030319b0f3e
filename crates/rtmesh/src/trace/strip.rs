//! Strip leaves: triangle strips traced directly, through a BVH over whole strips and
//! an implicit, balanced hierarchy inside each (ReduceM: "does not have a choice in
//! where to put the split inside the strip"; Lauterbach's thesis, ch. 3).
//!
//! The top is rtmesh's 8-wide binned-SAH BVH over the strips' boxes, up to
//! `strips_per_leaf` strips a leaf, stored with quantized nodes ([`QuantizedBvh`]: 80
//! bytes a node instead of 256, 8-bit child planes; the top tree was two thirds of the
//! strips' bytes in f32), with the strips stored in leaf order and the vertex
//! buffer renumbered in the order they first use it, so that the strips are kept
//! packed ([`PackedStrips`]: a bit per fresh index, a byte per nearby reuse). A leaf
//! holds each strip's [`Cursor`] into that stream; a visit decodes each strip's
//! triangles from the shared vertex buffer into the tracer's 4-wide blocks on the
//! stack. Inside a strip ([`Inside`]):
//!
//! - [`Inside::Quantized`]: each run of four triangles (one traced block) has a stored
//!   box, its six planes quantized to 4 bits within the strip's *frame*: the box of
//!   its leaf as the quantized parent node decodes it, which the traversal has just
//!   entered, so nothing is stored per strip but its leaf's place and its first block
//!   (4 + 4 bytes a strip, 3 a block). A leaf visit tests the boxes eight at a time
//!   with the node test, then walks the strip's index stream up to the last block a
//!   box let through, loading corners only for those blocks. The command line's
//!   default: on the tunnelled strips (19–21 triangles) it traces 1.4–1.6× flat.
//! - [`Inside::Flat`]: every block of the strip is tested; nothing is stored. At the
//!   published ordering's 11–12 triangles a strip it traced 22–30% faster than the
//!   implicit split, whose boxes read every corner anyway;
//! - [`Inside::Implicit`]: a range longer than 8 triangles is split at its middle
//!   triangle, the two halves' boxes are computed from the decoded corners on the fly
//!   and tested, nearest first. Nothing is stored for it.
//!
//! docs/measurements/strips.md has the trade-offs measured.
//!
//! Hits carry the input triangle id; their `(u, v)` are relative to the strip's
//! rotation of the corners (it starts at another corner when the strip entered the
//! triangle by another edge), not necessarily the input's.
//!
//! Cost per leaf visit: ⌈L/32⌉ 8-wide box tests, the decode of the strip's indices up to
//! the last block entered and a block test per block entered (quantized); O(L) to
//! decode a strip of L triangles, then ⌈L/4⌉ block tests (flat); or about 2·log₂(L/8) box computations of O(L) and a few blocks (implicit).

use super::triangle::Triangle4;
use super::{traverse, Counters, Hit, LeafBlock, RayQuery, Tracer, Triangle};
use crate::bvh::{BuildSettings, Bvh, BvhStats, Child, Primitive, QuantizedBvh, WIDTH};
use crate::geom::{Aabb, Ray};
use crate::simd::{dispatch, Isa, Kernel};
use crate::strip::packed::{Cursor, PackedStrips};
use crate::strip::Strips;
use glam::Vec3;

/// Longest strip the tracer takes (a strip is decoded on the stack).
pub const MAX_TRACED_LENGTH: usize = 64;

/// What a strip's triangles are tested through.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Inside {
    /// Every triangle, four at a time.
    Flat,
    /// A balanced binary split at the middle triangle, boxes computed on the fly.
    Implicit,
    /// A stored 4-bit box per block of four triangles, within the box of its leaf.
    Quantized,
}

/// `leaf_of` of a strip in a tree that is one leaf.
const ROOT_LEAF: u32 = u32::MAX;

/// The stored boxes of [`Inside::Quantized`].
struct BlockBoxes {
    /// Each strip's leaf in the top tree, as `node << 3 | lane` ([`ROOT_LEAF`] when the
    /// tree is one leaf): its blocks' planes are within that lane's decoded box, the
    /// *frame*, which the traversal has just entered, so no box is stored per strip.
    leaf_of: Vec<u32>,
    /// The frame of a tree that is one leaf: the union of the blocks.
    root_frame: Aabb,
    /// Strip `s`'s blocks are `planes[block_start[s]..block_start[s + 1]]`.
    block_start: Vec<u32>,
    /// min x, y, z, max x, y, z of each block, in [`LEVELS`]ths of its frame's
    /// extent, four bits each ([`pack`]).
    planes: Vec<[u8; 3]>,
}

impl BlockBoxes {
    /// The boxes of every block of `strips` over `positions`, each quantized outward
    /// within its strip's leaf box in `bvh` (the strips are its primitives, in order).
    fn build(strips: &Strips, positions: &[Vec3], bvh: &QuantizedBvh<Cursor>) -> Self {
        let mut leaf_of = vec![ROOT_LEAF; strips.len()];
        for (i, node) in bvh.nodes.iter().enumerate() {
            for lane in 0..crate::bvh::WIDTH {
                if let Child::Leaf { first, count } = Child::decode(node.child(lane)) {
                    for s in first..first + count {
                        leaf_of[s as usize] = (i as u32) << 3 | lane as u32;
                    }
                }
            }
        }
        let mut out = Self {
            leaf_of,
            root_frame: Aabb::EMPTY,
            block_start: vec![0],
            planes: Vec::new(),
        };
        let mut boxes: Vec<Vec<Aabb>> = Vec::with_capacity(strips.len());
        for s in 0..strips.len() {
            let mut blocks = Vec::with_capacity(strips.triangles_of(s).len().div_ceil(4));
            let first = strips.triangles_of(s).start;
            strips.for_each_triangle(s, |k, t| {
                let block = (k - first) / 4;
                if block == blocks.len() {
                    blocks.push(Aabb::EMPTY);
                }
                for v in t {
                    blocks[block] = blocks[block].grown_by_point(positions[v as usize]);
                }
            });
            out.root_frame = blocks.iter().fold(out.root_frame, |a, &b| a.union(b));
            boxes.push(blocks);
        }
        for (s, blocks) in boxes.iter().enumerate() {
            let frame = out.frame(s, bvh);
            for b in blocks {
                out.planes.push(pack(quantize(&frame, b)));
            }
            out.block_start.push(out.planes.len() as u32);
        }
        out
    }

    /// The box strip `s`'s planes are within.
    #[inline(always)]
    fn frame(&self, s: usize, bvh: &QuantizedBvh<Cursor>) -> Aabb {
        match self.leaf_of[s] {
            ROOT_LEAF => self.root_frame,
            leaf => bvh.nodes[(leaf >> 3) as usize].child_bounds((leaf & 7) as usize),
        }
    }

    /// Bytes stored.
    fn bytes(&self) -> usize {
        4 * (self.leaf_of.len() + self.block_start.len()) + 3 * self.planes.len()
    }
}

/// Steps of a block plane across its frame: four bits a plane. Against 8 bits (255
/// steps) this halves the planes' bytes (6 → 3 a block, 0.8 byte a triangle on the
/// scans, which brings hierarchy and topology under 5 bytes a triangle) for 5–7% of
/// the speed: 3.8 triangle tests a primary ray instead of 2.9
/// (docs/measurements/strips.md).
const LEVELS: u8 = 15;

/// One [`LEVELS`]th of `frame`'s extent, the unit of its blocks' planes.
#[inline(always)]
fn plane_step(frame: &Aabb) -> Vec3 {
    frame.extent() / f32::from(LEVELS)
}

/// Six 4-bit planes in three bytes: (min x, min y), (min z, max x), (max y, max z), the
/// first of each pair in the low nibble.
fn pack(q: [u8; 6]) -> [u8; 3] {
    [q[0] | q[1] << 4, q[2] | q[3] << 4, q[4] | q[5] << 4]
}

/// The planes [`pack`] packed.
#[inline(always)]
fn unpack(p: [u8; 3]) -> [u8; 6] {
    [
        p[0] & 15,
        p[0] >> 4,
        p[1] & 15,
        p[1] >> 4,
        p[2] & 15,
        p[2] >> 4,
    ]
}

/// The box of `planes` within `frame` (`step` its [`plane_step`]): mins counted up from
/// its min, maxes down from its max, so that 0 and [`LEVELS`] give its planes exactly.
#[inline(always)]
fn dequantize(frame: &Aabb, step: Vec3, planes: [u8; 6]) -> Aabb {
    let q = planes.map(f32::from);
    let top = f32::from(LEVELS);
    Aabb {
        min: frame.min + Vec3::new(q[0], q[1], q[2]) * step,
        max: frame.max - Vec3::new(top - q[3], top - q[4], top - q[5]) * step,
    }
}

/// `b`'s planes within `frame`, rounded outward so that the dequantized box holds `b`
/// (checked against [`dequantize`] itself, so float rounding cannot shrink it).
fn quantize(frame: &Aabb, b: &Aabb) -> [u8; 6] {
    let extent = frame.extent();
    let step = plane_step(frame);
    let mut q = [0u8; 6];
    for axis in 0..3 {
        let scale = if extent[axis] > 0.0 {
            f32::from(LEVELS) / extent[axis]
        } else {
            0.0
        };
        q[axis] = ((b.min[axis] - frame.min[axis]) * scale)
            .floor()
            .clamp(0.0, f32::from(LEVELS)) as u8;
        q[axis + 3] = ((b.max[axis] - frame.min[axis]) * scale)
            .ceil()
            .clamp(0.0, f32::from(LEVELS)) as u8;
    }
    for axis in 0..3 {
        while q[axis] > 0 && dequantize(frame, step, q).min[axis] > b.min[axis] {
            q[axis] -= 1;
        }
        while q[axis + 3] < LEVELS && dequantize(frame, step, q).max[axis] < b.max[axis] {
            q[axis + 3] += 1;
        }
    }
    q
}

/// Room for one decoded strip.
struct Decoded([std::mem::MaybeUninit<Triangle>; MAX_TRACED_LENGTH]);

impl Decoded {
    #[inline(always)]
    fn new() -> Self {
        Self([const { std::mem::MaybeUninit::uninit() }; MAX_TRACED_LENGTH])
    }
}

/// A strip's box, for the build.
#[derive(Clone)]
struct StripBox {
    strip: u32,
    bounds: Aabb,
}

impl Primitive for StripBox {
    fn bounds(&self) -> Aabb {
        self.bounds
    }
}

/// A strip in a BVH leaf is its cursor into the packed stream (its box is the node's).
impl Primitive for Cursor {
    fn bounds(&self) -> Aabb {
        Aabb::EMPTY
    }
}

/// Strips traced directly.
pub struct StripAccel {
    bvh: QuantizedBvh<Cursor>,
    /// The top tree's figures, from its f32 build (node bytes those of `bvh`).
    stats: BvhStats,
    strips: PackedStrips,
    /// The input triangle id of each triangle in strip order.
    triangle_source: Vec<u32>,
    positions: Vec<Vec3>,
    inside: Inside,
    /// The stored boxes, for [`Inside::Quantized`].
    blocks: Option<BlockBoxes>,
}

/// Why strips cannot be traced.
#[derive(Debug, thiserror::Error)]
pub enum StripAccelError {
    /// A strip is longer than [`MAX_TRACED_LENGTH`].
    #[error("strip {strip} has {length} triangles; the tracer takes at most {MAX_TRACED_LENGTH}")]
    TooLong {
        /// The strip.
        strip: usize,
        /// Its length.
        length: usize,
    },
}

impl StripAccel {
    /// Build over `strips` of a mesh with `positions`, up to `strips_per_leaf` strips
    /// in a leaf (1..=15).
    pub fn build(
        positions: &[Vec3],
        strips: &Strips,
        strips_per_leaf: usize,
        inside: Inside,
    ) -> Result<Self, StripAccelError> {
        let start = std::time::Instant::now();
        let mut boxes = Vec::with_capacity(strips.len());
        for s in 0..strips.len() {
            let length = strips.triangles_of(s).len();
            if length > MAX_TRACED_LENGTH {
                return Err(StripAccelError::TooLong { strip: s, length });
            }
            let mut bounds = Aabb::EMPTY;
            strips.for_each_triangle(s, |_, t| {
                for v in t {
                    bounds = bounds.grown_by_point(positions[v as usize]);
                }
            });
            boxes.push(StripBox {
                strip: s as u32,
                bounds,
            });
        }
        let settings = BuildSettings {
            max_leaf_size: strips_per_leaf.clamp(1, 15),
            ..BuildSettings::quality()
        };
        let tree = Bvh::build(boxes, &settings);
        let quantized = QuantizedBvh::from_bvh(&tree);
        // Strips in the quantized tree's leaf order.
        let order: Vec<u32> = quantized.primitives.iter().map(|b| b.strip).collect();
        let mut strips = strips.reordered(&order);
        // The vertex buffer in the order the strips first use it, so that a leaf's
        // corners are near each other in memory and the strips pack.
        let reordered: Vec<Vec3> = strips
            .renumber_by_first_use(positions.len())
            .iter()
            .map(|&v| positions[v as usize])
            .collect();
        let (packed, starts) =
            PackedStrips::pack(&strips).expect("vertices numbered by first use, strips of ≤ 64");
        let bvh = QuantizedBvh {
            primitives: starts,
            nodes: quantized.nodes,
            root: quantized.root,
        };
        let blocks =
            (inside == Inside::Quantized).then(|| BlockBoxes::build(&strips, &reordered, &bvh));
        let stats = BvhStats {
            node_bytes: bvh.node_bytes(),
            build_seconds: start.elapsed().as_secs_f64(),
            ..tree.stats()
        };
        Ok(Self {
            bvh,
            stats,
            strips: packed,
            triangle_source: strips.triangle_source,
            positions: reordered,
            inside,
            blocks,
        })
    }

    /// Figures of the top BVH.
    pub fn stats(&self) -> BvhStats {
        self.stats.clone()
    }

    /// Bytes of the hierarchy: the top BVH's nodes and its leaves' strip cursors.
    pub fn hierarchy_bytes(&self) -> usize {
        self.stats.node_bytes
            + std::mem::size_of_val(self.bvh.primitives.as_slice())
            + self.blocks.as_ref().map_or(0, BlockBoxes::bytes)
    }

    /// Bytes of the strips' topology ([`PackedStrips::bytes`]).
    pub fn topology_bytes(&self) -> usize {
        self.strips.bytes()
    }

    /// Bytes of the shared vertex buffer (f32 positions).
    pub fn position_bytes(&self) -> usize {
        12 * self.positions.len()
    }

    /// Seconds the build took.
    pub fn build_seconds(&self) -> f64 {
        self.stats.build_seconds
    }

    /// The strip at `cursor`: the strips are stored in leaf order, so its index is the
    /// cursor's place among the leaves' cursors.
    #[inline(always)]
    fn strip_of(&self, cursor: &Cursor) -> usize {
        let base = self.bvh.primitives.as_ptr() as usize;
        (cursor as *const Cursor as usize - base) / std::mem::size_of::<Cursor>()
    }

    /// Decode the strip at `cursor` into `buffer`; returns its triangles. The buffer is
    /// not zero-filled per ray (that costs as much as a traversal), so only the decoded
    /// prefix is read.
    #[inline(always)]
    fn decode<'b>(&self, cursor: &Cursor, buffer: &'b mut Decoded) -> &'b [Triangle] {
        let first = cursor.triangle as usize;
        let mut n = 0;
        self.strips
            .for_each_triangle(self.strip_of(cursor), cursor, |k, t| {
                buffer.0[k - first].write(Triangle::new(
                    t.map(|v| self.positions[v as usize]),
                    self.triangle_source[k],
                ));
                n += 1;
            });
        // SAFETY: `for_each_triangle` visits the strip's `n` ≤ MAX_TRACED_LENGTH
        // triangles at positions 0..n (checked in `build`), each written above.
        unsafe { std::slice::from_raw_parts(buffer.0.as_ptr().cast::<Triangle>(), n) }
    }

    /// Test the triangles of the strip at `cursor` (decoded into `buffer` as needed);
    /// `f` tests one block and returns whether to stop.
    #[inline(always)]
    fn visit_strip<S: Isa, C: Counters>(
        &self,
        cursor: &Cursor,
        buffer: &mut Decoded,
        query: &RayQuery,
        t_max: &mut f32,
        counters: &mut C,
        f: impl FnMut(&Triangle4, &mut f32) -> bool,
    ) -> bool {
        let s = self.strip_of(cursor);
        match &self.blocks {
            Some(blocks) => {
                let entered = self.entered_blocks::<S, C>(s, blocks, query, *t_max, counters);
                self.test_blocks(s, cursor, entered, t_max, counters, f)
            }
            None if self.inside == Inside::Flat => {
                self.test_blocks(s, cursor, u32::MAX, t_max, counters, f)
            }
            None => {
                let triangles = self.decode(cursor, buffer);
                self.visit(triangles, query, t_max, counters, f)
            }
        }
    }

    /// [`Inside::Quantized`]: the blocks of strip `s` whose stored boxes the ray
    /// enters, as a mask, eight boxes at a time through the node test.
    #[inline(always)]
    fn entered_blocks<S: Isa, C: Counters>(
        &self,
        s: usize,
        blocks: &BlockBoxes,
        query: &RayQuery,
        t_max: f32,
        counters: &mut C,
    ) -> u32 {
        let planes =
            &blocks.planes[blocks.block_start[s] as usize..blocks.block_start[s + 1] as usize];
        counters.box_tests(planes.len() as u32);
        let frame = blocks.frame(s, &self.bvh);
        let step = plane_step(&frame);
        let mut entered = 0u32;
        for (i, eight) in planes.chunks(WIDTH).enumerate() {
            // Lanes past the strip's blocks hold the frame; the mask drops them.
            let mut lanes = [[0.0f32; WIDTH]; 6];
            for (lane, &q) in eight.iter().enumerate() {
                let b = dequantize(&frame, step, unpack(q));
                for axis in 0..3 {
                    lanes[axis][lane] = b.min[axis];
                    lanes[axis + 3][lane] = b.max[axis];
                }
            }
            let (_, mask) = traverse::children::<S>(&lanes, query, t_max);
            entered |= (mask & ((1 << eight.len()) - 1)) << (WIDTH * i);
        }
        entered
    }

    /// Strip `s` (at `cursor`) decoded straight into blocks of four (no buffer of the
    /// strip's triangles), the blocks in `wanted` (bit i for block i) each tested as it
    /// fills; the decoding stops after the last wanted block, and loads no corners for
    /// the others. Flat inside wants every block.
    #[inline(always)]
    fn test_blocks<C: Counters>(
        &self,
        s: usize,
        cursor: &Cursor,
        wanted: u32,
        t_max: &mut f32,
        counters: &mut C,
        mut f: impl FnMut(&Triangle4, &mut f32) -> bool,
    ) -> bool {
        let length = self.strips.length(s);
        let blocks = length.div_ceil(4);
        let wanted = if blocks < 32 {
            wanted & ((1 << blocks) - 1)
        } else {
            wanted
        };
        if wanted == 0 {
            return false;
        }
        let decoded = (4 * (32 - wanted.leading_zeros() as usize)).min(length);
        // Replaced at each block's first triangle.
        let mut block = Triangle4::of_one(&Triangle::new([Vec3::ZERO; 3], u32::MAX));
        let mut decoder = self.strips.decoder(s, cursor);
        for i in 0..decoded {
            let (k, t) = decoder.next_triangle();
            if wanted & (1 << (i / 4)) == 0 {
                continue;
            }
            let triangle = Triangle::new(
                t.map(|v| self.positions[v as usize]),
                self.triangle_source[k],
            );
            let lane = i % 4;
            if lane == 0 {
                block = Triangle4::of_one(&triangle);
            } else {
                block.set(lane, &triangle);
            }
            if lane == 3 || i + 1 == decoded {
                block.count_tests(counters);
                if f(&block, t_max) {
                    return true;
                }
            }
        }
        false
    }

    /// [`Inside::Implicit`]: test the triangles of a decoded strip through the implicit
    /// split; `f` tests one block and returns whether to stop.
    #[inline(always)]
    fn visit<C: Counters>(
        &self,
        triangles: &[Triangle],
        query: &RayQuery,
        t_max: &mut f32,
        counters: &mut C,
        mut f: impl FnMut(&Triangle4, &mut f32) -> bool,
    ) -> bool {
        // The implicit balanced hierarchy, nearest half first, down to 8 triangles.
        debug_assert_eq!(self.inside, Inside::Implicit);
        let split_above = 8;
        let mut stack = [(0usize, 0usize, 0.0f32); 16];
        let mut len = 1;
        stack[0] = (0, triangles.len(), 0.0);
        while len > 0 {
            len -= 1;
            let (lo, hi, entry) = stack[len];
            if entry > *t_max {
                continue;
            }
            if hi - lo <= split_above {
                for chunk in triangles[lo..hi].chunks(4) {
                    let block = Triangle4::new(chunk);
                    block.count_tests(counters);
                    if f(&block, t_max) {
                        return true;
                    }
                }
                continue;
            }
            let mid = (lo + hi) / 2;
            counters.box_tests(2);
            let near = |r: &[Triangle]| box_entry(&corners_box(r), query, *t_max);
            let (a, b) = (near(&triangles[lo..mid]), near(&triangles[mid..hi]));
            let mut push = |lo, hi, e: Option<f32>| {
                if let Some(e) = e {
                    stack[len] = (lo, hi, e);
                    len += 1;
                }
            };
            // Farther first, so that the nearer pops next.
            if a.unwrap_or(f32::INFINITY) <= b.unwrap_or(f32::INFINITY) {
                push(mid, hi, b);
                push(lo, mid, a);
            } else {
                push(lo, mid, a);
                push(mid, hi, b);
            }
        }
        false
    }

    #[inline(always)]
    fn intersect_with<S: Isa, C: Counters>(&self, ray: &Ray, counters: &mut C) -> Hit {
        let query = RayQuery::new(ray);
        let mut hit = Hit::MISS;
        hit.t = ray.t_max;
        let mut buffer = Decoded::new();
        let mut t_max = ray.t_max;
        let mut found = false;
        traverse::closest_hit::<S, _, _, C>(
            &self.bvh,
            &query,
            &mut t_max,
            counters,
            |leaf, t_max, counters| {
                let before = found;
                for cursor in leaf {
                    let (b, q) = (&mut buffer, &query);
                    self.visit_strip::<S, C>(cursor, b, q, t_max, counters, |block, t_max| {
                        if block.intersect_into(&query, &mut hit) {
                            *t_max = hit.t;
                            found = true;
                        }
                        false
                    });
                }
                found != before
            },
        );
        if found {
            hit.instance = 0;
            hit.geometry = 0;
            hit
        } else {
            Hit::MISS
        }
    }

    #[inline(always)]
    fn occluded_with<S: Isa, C: Counters>(&self, ray: &Ray, counters: &mut C) -> bool {
        let query = RayQuery::new(ray);
        let mut buffer = Decoded::new();
        traverse::any_hit::<S, _, _, C>(
            &self.bvh,
            &query,
            ray.t_max,
            counters,
            |leaf, t_max, counters| {
                let mut t = t_max;
                leaf.iter().any(|cursor| {
                    let (b, q) = (&mut buffer, &query);
                    self.visit_strip::<S, C>(cursor, b, q, &mut t, counters, |block, t_max| {
                        block.occludes(&query, *t_max)
                    })
                })
            },
        )
    }
}

/// The box of decoded triangles.
#[inline(always)]
fn corners_box(triangles: &[Triangle]) -> Aabb {
    let mut b = Aabb::EMPTY;
    for t in triangles {
        b = b
            .grown_by_point(t.v0)
            .grown_by_point(t.v0 + t.e1)
            .grown_by_point(t.v0 + t.e2);
    }
    b
}

/// Where the ray enters `b` within `(t_min, t_max)`: the slab test, its exit distance
/// scaled by 1 + 2γ₃ as the traversal's is, so that rounding never culls a touched box.
#[inline(always)]
fn box_entry(b: &Aabb, query: &RayQuery, t_max: f32) -> Option<f32> {
    let t0 = (b.min - query.origin) * query.inverse_direction;
    let t1 = (b.max - query.origin) * query.inverse_direction;
    let enter = t0.min(t1).max_element().max(query.t_min);
    let leave = (t0.max(t1).min_element() * super::ROBUST_FAR_SCALE).min(t_max);
    (enter <= leave).then_some(enter)
}

struct Closest<'a, C> {
    accel: &'a StripAccel,
    ray: &'a Ray,
    counters: &'a mut C,
}

impl<C: Counters> Kernel for Closest<'_, C> {
    type Output = Hit;
    #[inline(always)]
    fn run<S: Isa>(self) -> Hit {
        self.accel.intersect_with::<S, C>(self.ray, self.counters)
    }
}

struct Occluded<'a, C> {
    accel: &'a StripAccel,
    ray: &'a Ray,
    counters: &'a mut C,
}

impl<C: Counters> Kernel for Occluded<'_, C> {
    type Output = bool;
    #[inline(always)]
    fn run<S: Isa>(self) -> bool {
        self.accel.occluded_with::<S, C>(self.ray, self.counters)
    }
}

impl Tracer for StripAccel {
    fn intersect<C: Counters>(&self, ray: &Ray, counters: &mut C) -> Hit {
        dispatch(Closest {
            accel: self,
            ray,
            counters,
        })
    }

    fn occluded<C: Counters>(&self, ray: &Ray, counters: &mut C) -> bool {
        dispatch(Occluded {
            accel: self,
            ray,
            counters,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// A quantized block box holds the block, stays within its frame, and packs losslessly.
        #[test]
        fn quantized_boxes_hold_their_blocks(
            corners in proptest::collection::vec((-1e3f32..1e3, -1e3f32..1e3, -1e3f32..1e3), 2..8),
            flat_axis in 0usize..4,
        ) {
            let mut points: Vec<Vec3> = corners.iter().map(|&(x, y, z)| Vec3::new(x, y, z)).collect();
            if flat_axis < 3 {
                for p in &mut points {
                    p[flat_axis] = 1.5;
                }
            }
            let strip_box = Aabb::from_points(&points);
            let block = Aabb::from_points(&points[1..]);
            let q = quantize(&strip_box, &block);
            prop_assert_eq!(unpack(pack(q)), q);
            let back = dequantize(&strip_box, plane_step(&strip_box), q);
            for axis in 0..3 {
                prop_assert!(back.min[axis] <= block.min[axis] && back.max[axis] >= block.max[axis]);
                prop_assert!(back.min[axis] >= strip_box.min[axis]);
            }
        }
    }
}

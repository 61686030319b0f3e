//! Quantized 8-wide BVH nodes: a [`Bvh`]'s child boxes stored as 8-bit planes on a
//! power-of-two grid over the node's box, as in the compressed wide BVH of Ylitie,
//! Karras and Laine ("Efficient Incoherent Ray Traversal on GPUs Through Compressed
//! Wide BVHs", HPG 2017) and Embree's quantized BVH8 nodes. A node is 80 bytes against
//! [`BvhNode`]'s 256; it costs a decode of the planes per visit.
//!
//! [`QuantizedNode`], field by field:
//! - `origin`: the node box's min corner, 3 × f32;
//! - `exponent`: per axis, the grid step 2^e, 3 × i8;
//! - `leaf_total`: primitives in the node's leaf children, u8 (8 × 15 at most);
//! - `inner_base`: index of the node's first inner child; its inner children are stored
//!   consecutively, u32;
//! - `leaf_base`: first primitive of its leaf children, whose primitives are stored
//!   consecutively in lane order, u32;
//! - `meta`: per lane, [`EMPTY_LANE`]; `INNER_LANE | rank` for inner child
//!   `inner_base + rank`; or a leaf's first primitive as an offset from `leaf_base`.
//!   Lanes hold the leaves first, then the inner children, then the empty ones, so a
//!   leaf ends where the next lane's leaf begins, or at `leaf_total`;
//! - `planes`: `[min x, min y, min z, max x, max y, max z]` × 8 lanes, u8.
//!
//! A plane decodes as `origin + q · 2^e` in f32: the product is exact and the sum
//! rounds once, the same in the builder as in the traversal. The builder rounds each
//! min down and each max up and then checks the decoded plane, moving q until the
//! decoded box contains the child's, so a ray that touches a child's true box always
//! enters its decoded box and the traversal's robust slab test applies unchanged.
//! Empty lanes store min 255 and max 0, an inverted box no ray enters.
//!
//! Nodes are stored depth first with each node's inner children consecutive (the
//! leaf children's primitives are emitted as their node is), so a subtree stays
//! together in memory as in [`Bvh`].

use super::{Bvh, BvhNode, Child, EMPTY_CHILD, WIDTH};
use crate::geom::Aabb;
use glam::Vec3;

/// `meta` of a lane that holds nothing.
pub const EMPTY_LANE: u8 = 0xFF;
/// `meta` bit of a lane that holds an inner child (its rank in the low bits).
pub const INNER_LANE: u8 = 0x80;

/// One quantized node (see the module header).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct QuantizedNode {
    /// Min corner of the node's box.
    pub origin: [f32; 3],
    /// Per axis, the grid step is 2^exponent.
    pub exponent: [i8; 3],
    /// Primitives in the leaf children.
    pub leaf_total: u8,
    /// First inner child.
    pub inner_base: u32,
    /// First primitive of the leaf children.
    pub leaf_base: u32,
    /// Per lane: empty, inner child rank, or leaf offset.
    pub meta: [u8; WIDTH],
    /// `planes[k][lane]` in grid steps: k = 0..3 min x, y, z; k = 3..6 max x, y, z.
    pub planes: [[u8; WIDTH]; 6],
}

/// 2^e as f32, for e in -126..=127.
#[inline(always)]
fn step(exponent: i8) -> f32 {
    f32::from_bits(((exponent as i32 + 127) as u32) << 23)
}

/// The plane `q` steps of `s` above `origin`, exactly as the traversal decodes it (the
/// builder checks its rounding against this very function).
#[inline(always)]
fn dequantize(origin: f32, q: u8, s: f32) -> f32 {
    origin + q as f32 * s
}

impl QuantizedNode {
    /// The planes in f32, laid out as [`BvhNode::planes`].
    #[inline(always)]
    pub fn decoded_planes(&self) -> [[f32; WIDTH]; 6] {
        let mut planes = [[0.0; WIDTH]; 6];
        for (k, out) in planes.iter_mut().enumerate() {
            let (origin, s) = (self.origin[k % 3], step(self.exponent[k % 3]));
            for (plane, &q) in out.iter_mut().zip(&self.planes[k]) {
                *plane = dequantize(origin, q, s);
            }
        }
        planes
    }

    /// The encoded [`Child`] reference of `lane`.
    #[inline(always)]
    pub fn child(&self, lane: usize) -> u32 {
        let meta = self.meta[lane];
        if meta == EMPTY_LANE {
            EMPTY_CHILD
        } else if meta & INNER_LANE != 0 {
            Child::Inner(self.inner_base + (meta & !INNER_LANE) as u32).encode()
        } else {
            let end = match self.meta.get(lane + 1) {
                Some(&next) if next & INNER_LANE == 0 => next,
                _ => self.leaf_total,
            };
            Child::Leaf {
                first: self.leaf_base + meta as u32,
                count: (end - meta) as u32,
            }
            .encode()
        }
    }

    /// Lanes that hold a child.
    #[inline(always)]
    pub fn occupied(&self) -> u32 {
        self.meta.iter().filter(|&&m| m != EMPTY_LANE).count() as u32
    }

    /// The decoded box of `lane`, the same planes as [`Self::decoded_planes`] gives.
    #[inline(always)]
    pub fn child_bounds(&self, lane: usize) -> Aabb {
        let plane = |k: usize| {
            dequantize(
                self.origin[k % 3],
                self.planes[k][lane],
                step(self.exponent[k % 3]),
            )
        };
        Aabb {
            min: Vec3::new(plane(0), plane(1), plane(2)),
            max: Vec3::new(plane(3), plane(4), plane(5)),
        }
    }
}

/// Grid exponent of one axis: the smallest whose 255 steps from `origin` reach `max`.
fn grid_exponent(origin: f32, max: f32) -> i8 {
    let extent = max - origin;
    let mut e = if extent > 0.0 {
        ((extent / 255.0).log2().ceil() as i32).clamp(-126, 120)
    } else {
        -126
    };
    while e < 120 && dequantize(origin, 255, step(e as i8)) < max {
        e += 1;
    }
    e as i8
}

/// Quantize `[lo, hi]` outward on the grid `origin + q · s`.
fn quantize(lo: f32, hi: f32, origin: f32, s: f32) -> (u8, u8) {
    let decode = |q: i32| dequantize(origin, q as u8, s);
    let mut q_lo = (((lo - origin) / s).floor() as i32).clamp(0, 255);
    while q_lo > 0 && decode(q_lo) > lo {
        q_lo -= 1;
    }
    let mut q_hi = (((hi - origin) / s).ceil() as i32).clamp(q_lo, 255);
    while q_hi < 255 && decode(q_hi) < hi {
        q_hi += 1;
    }
    (q_lo as u8, q_hi as u8)
}

/// A [`Bvh`] with quantized nodes, over primitives stored in its own leaf order.
#[derive(Clone, Debug)]
pub struct QuantizedBvh<P> {
    /// Nodes, depth first; node 0 is the root when `root` is inner.
    pub nodes: Vec<QuantizedNode>,
    /// The root reference (inner node 0, a single leaf, or empty).
    pub root: u32,
    /// Primitives in leaf order.
    pub primitives: Vec<P>,
}

impl<P: Clone> QuantizedBvh<P> {
    /// Quantize `bvh`: the same tree, the same leaves, boxes rounded outward.
    pub fn from_bvh(bvh: &Bvh<P>) -> Self {
        let mut out = QuantizedBvh {
            nodes: Vec::with_capacity(bvh.nodes.len()),
            root: EMPTY_CHILD,
            primitives: Vec::with_capacity(bvh.primitives.len()),
        };
        match Child::decode(bvh.root) {
            Child::Inner(i) => {
                out.nodes.push(UNFILLED);
                out.root = Child::Inner(0).encode();
                out.fill(bvh, i as usize, 0);
            }
            Child::Leaf { first, count } => {
                out.primitives
                    .extend_from_slice(&bvh.primitives[first as usize..(first + count) as usize]);
                out.root = Child::Leaf { first: 0, count }.encode();
            }
            Child::Empty => {}
        }
        out
    }

    /// Write old node `old` as new node `new`, then its subtrees.
    fn fill(&mut self, bvh: &Bvh<P>, old: usize, new: usize) {
        let node: &BvhNode = &bvh.nodes[old];
        let mut lanes: Vec<(usize, Child)> = (0..WIDTH)
            .map(|lane| (lane, Child::decode(node.children[lane])))
            .filter(|(_, c)| *c != Child::Empty)
            .collect();
        lanes.sort_by_key(|(_, c)| matches!(c, Child::Inner(_)));
        let bounds = node.bounds();
        let origin = bounds.min.to_array();
        let max = bounds.max.to_array();
        let exponent: [i8; 3] = std::array::from_fn(|a| grid_exponent(origin[a], max[a]));
        let mut q = QuantizedNode {
            origin,
            exponent,
            leaf_total: 0,
            inner_base: self.nodes.len() as u32,
            leaf_base: self.primitives.len() as u32,
            meta: [EMPTY_LANE; WIDTH],
            planes: [
                [255; WIDTH],
                [255; WIDTH],
                [255; WIDTH],
                [0; WIDTH],
                [0; WIDTH],
                [0; WIDTH],
            ],
        };
        let mut inner = Vec::new();
        for (slot, &(lane, child)) in lanes.iter().enumerate() {
            match child {
                Child::Inner(i) => {
                    q.meta[slot] = INNER_LANE | inner.len() as u8;
                    inner.push(i as usize);
                    self.nodes.push(UNFILLED);
                }
                Child::Leaf { first, count } => {
                    q.meta[slot] = q.leaf_total;
                    q.leaf_total += count as u8;
                    self.primitives.extend_from_slice(
                        &bvh.primitives[first as usize..(first + count) as usize],
                    );
                }
                Child::Empty => unreachable!("filtered out"),
            }
            let b = node.child_bounds(lane);
            for axis in 0..3 {
                let (lo, hi) =
                    quantize(b.min[axis], b.max[axis], origin[axis], step(exponent[axis]));
                q.planes[axis][slot] = lo;
                q.planes[axis + 3][slot] = hi;
            }
        }
        self.nodes[new] = q;
        let inner_base = q.inner_base as usize;
        for (rank, child) in inner.into_iter().enumerate() {
            self.fill(bvh, child, inner_base + rank);
        }
    }
}

impl<P> QuantizedBvh<P> {
    /// Bytes of the nodes.
    pub fn node_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
    }
}

/// A slot reserved for a node written later.
const UNFILLED: QuantizedNode = QuantizedNode {
    origin: [0.0; 3],
    exponent: [0; 3],
    leaf_total: 0,
    inner_base: 0,
    leaf_base: 0,
    meta: [EMPTY_LANE; WIDTH],
    planes: [[0; WIDTH]; 6],
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{BuildSettings, Primitive};
    use proptest::prelude::*;

    #[derive(Clone, Debug)]
    struct Boxed(Aabb, u32);

    impl Primitive for Boxed {
        fn bounds(&self) -> Aabb {
            self.0
        }
    }

    #[test]
    fn a_node_is_80_bytes() {
        assert_eq!(std::mem::size_of::<QuantizedNode>(), 80);
    }

    #[test]
    fn planes_round_outward_and_stay_within_a_step() {
        let s = step(grid_exponent(1.0, 2.0));
        assert_eq!(s, 1.0 / 128.0);
        assert_eq!(quantize(1.25, 1.5, 1.0, s), (32, 64));
        assert_eq!(quantize(1.2501, 1.4999, 1.0, s), (32, 64));
        assert_eq!(quantize(1.0, 2.0, 1.0, s), (0, 128));
    }

    /// Walk the quantized tree: every decoded child box holds its subtree's
    /// primitives, and each primitive is reached exactly once. Returns the box of the
    /// primitives under `reference`.
    fn check(q: &QuantizedBvh<Boxed>, reference: u32, seen: &mut [u32]) -> Aabb {
        match Child::decode(reference) {
            Child::Empty => Aabb::EMPTY,
            Child::Leaf { first, count } => q.primitives[first as usize..(first + count) as usize]
                .iter()
                .fold(Aabb::EMPTY, |b, p| {
                    seen[p.1 as usize] += 1;
                    b.union(p.0)
                }),
            Child::Inner(i) => {
                let node = &q.nodes[i as usize];
                (0..WIDTH).fold(Aabb::EMPTY, |b, lane| {
                    let subtree = check(q, node.child(lane), seen);
                    if node.child(lane) != EMPTY_CHILD {
                        let decoded = node.child_bounds(lane);
                        assert_eq!(
                            decoded.union(subtree),
                            decoded,
                            "decoded box misses its subtree"
                        );
                    }
                    b.union(subtree)
                })
            }
        }
    }

    proptest! {
        #[test]
        fn quantized_trees_hold_every_primitive_once_within_their_boxes(
            corners in prop::collection::vec(
                (-1e4f32..1e4, -1e4f32..1e4, -1e4f32..1e4, 0f32..50.0, 0f32..50.0, 0f32..5.0),
                1..400,
            ),
            leaf in 1usize..8,
        ) {
            let boxes: Vec<Boxed> = corners
                .iter()
                .enumerate()
                .map(|(i, &(x, y, z, dx, dy, dz))| {
                    let min = Vec3::new(x, y, z);
                    Boxed(Aabb { min, max: min + Vec3::new(dx, dy, dz) }, i as u32)
                })
                .collect();
            let settings = BuildSettings { max_leaf_size: leaf, ..BuildSettings::quality() };
            let bvh = Bvh::build(boxes, &settings);
            let q = QuantizedBvh::from_bvh(&bvh);
            prop_assert_eq!(q.nodes.len(), bvh.nodes.len());
            let mut seen = vec![0u32; corners.len()];
            check(&q, q.root, &mut seen);
            prop_assert!(seen.iter().all(|&n| n == 1), "primitives reached {:?}", seen);
        }
    }
}

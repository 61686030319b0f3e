//! Bounding volume hierarchies: an 8-wide BVH ([`Bvh`], like Embree's BVH8) built by
//! binned SAH and shared by every leaf primitive (triangles now; pairs, strips, clusters
//! and instances plug in through [`Primitive`]).
//!
//! Node layout ([`BvhNode`], 256 bytes, four 64-byte cache lines): the six planes of the
//! eight child boxes stored structure-of-arrays (`[min x, min y, min z, max x, max y,
//! max z]` × 8 lanes), so one node visit tests all eight boxes with 8-wide SIMD (two
//! independent 4-wide halves on SSE2, one AVX register where available), and eight
//! child references. Eight children rather than four halve the depth: the traversal's
//! cost is the latency of each node test, and two halves in parallel cost about what
//! one does. A child reference is an inner node index, a leaf
//! (bit 31 set, 4-bit primitive count and 27-bit first primitive), or [`EMPTY_CHILD`]
//! whose box is inverted so that no ray ever enters it. The builder stores nodes parent
//! before children (depth first), which keeps a subtree together in memory; nothing
//! else relies on the order (refit walks from the root), so a per-frame cluster scene
//! can keep its clusters' nodes in place ahead of the top tree's.

mod build;
mod quantized;

pub use build::BuildSettings;
pub use quantized::{QuantizedBvh, QuantizedNode};

use crate::geom::Aabb;
use crate::pages::{copy_to_huge_pages, vec_on_huge_pages};
use glam::Vec3;
use serde::Serialize;

/// A child slot holding nothing (its box is inverted).
pub const EMPTY_CHILD: u32 = u32::MAX;
const LEAF_BIT: u32 = 1 << 31;
const LEAF_COUNT_SHIFT: u32 = 27;
/// Most primitives one leaf can hold.
pub const MAX_LEAF_SIZE: usize = 15;
/// Most primitives a BVH can hold (27-bit first index).
pub const MAX_PRIMITIVES: usize = 1 << LEAF_COUNT_SHIFT;

/// What a BVH leaf can hold: anything with a box. Its centroid places it in the build.
pub trait Primitive: Send + Sync {
    /// Bounding box.
    fn bounds(&self) -> Aabb;
}

/// A reference to a child: inner node, leaf range, or empty.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Child {
    /// Index of an inner node.
    Inner(u32),
    /// Primitives `first .. first + count`.
    Leaf {
        /// First primitive.
        first: u32,
        /// Number of primitives (1..=15).
        count: u32,
    },
    /// No child.
    Empty,
}

impl Child {
    /// Pack into the 32-bit reference stored in nodes.
    #[inline]
    pub fn encode(self) -> u32 {
        match self {
            Child::Inner(i) => i,
            Child::Leaf { first, count } => LEAF_BIT | (count << LEAF_COUNT_SHIFT) | first,
            Child::Empty => EMPTY_CHILD,
        }
    }

    /// Unpack a stored reference.
    #[inline(always)]
    pub fn decode(reference: u32) -> Self {
        if reference == EMPTY_CHILD {
            Child::Empty
        } else if reference & LEAF_BIT != 0 {
            Child::Leaf {
                first: reference & ((1 << LEAF_COUNT_SHIFT) - 1),
                count: (reference >> LEAF_COUNT_SHIFT) & 0xF,
            }
        } else {
            Child::Inner(reference)
        }
    }
}

/// Children per node.
pub const WIDTH: usize = 8;

/// One node: eight child boxes, structure of arrays, and eight child references.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct BvhNode {
    /// `planes[k][lane]`: k = 0..3 min x, y, z; k = 3..6 max x, y, z of child `lane`.
    pub planes: [[f32; WIDTH]; 6],
    /// Encoded child references (see [`Child`]).
    pub children: [u32; WIDTH],
}

impl BvhNode {
    /// A node with eight empty (inverted) children.
    pub const EMPTY: BvhNode = BvhNode {
        planes: [
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        children: [EMPTY_CHILD; WIDTH],
    };

    /// Box of child `lane`.
    pub fn child_bounds(&self, lane: usize) -> Aabb {
        let p = &self.planes;
        Aabb {
            min: Vec3::new(p[0][lane], p[1][lane], p[2][lane]),
            max: Vec3::new(p[3][lane], p[4][lane], p[5][lane]),
        }
    }

    /// Set the box of child `lane`.
    pub fn set_child_bounds(&mut self, lane: usize, b: Aabb) {
        for axis in 0..3 {
            self.planes[axis][lane] = b.min[axis];
            self.planes[axis + 3][lane] = b.max[axis];
        }
    }

    /// Union of the children's boxes.
    pub fn bounds(&self) -> Aabb {
        (0..WIDTH).fold(Aabb::EMPTY, |b, lane| b.union(self.child_bounds(lane)))
    }
}

/// Figures of a built BVH.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BvhStats {
    /// Inner nodes (8-wide).
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Primitives referenced by leaves.
    pub primitives: usize,
    /// SAH cost: Σ over inner nodes of A(node)/A(root)·C_node + Σ over leaves of
    /// A(leaf)/A(root)·count·C_primitive, with C_node = C_primitive = 1.
    pub sah_cost: f32,
    /// Bytes of nodes.
    pub node_bytes: usize,
    /// Deepest leaf (root = depth 1).
    pub depth: usize,
    /// Seconds the build took (wall clock).
    pub build_seconds: f64,
}

/// An 8-wide BVH over primitives stored in leaf order.
#[derive(Clone, Debug)]
pub struct Bvh<P> {
    /// Nodes, each reached from one parent (the builder's are parent before children,
    /// the root at 0).
    pub nodes: Vec<BvhNode>,
    /// The root reference (an inner node, a single leaf, or empty).
    pub root: u32,
    /// Primitives in leaf order.
    pub primitives: Vec<P>,
    /// Seconds the build took.
    pub build_seconds: f64,
}

impl<P: Primitive> Bvh<P> {
    /// Build with binned SAH (see [`BuildSettings`]). Primitives with an empty or
    /// non-finite box (NaN triangles: DXR's inactive ones) are left out.
    pub fn build(primitives: Vec<P>, settings: &BuildSettings) -> Self {
        let start = std::time::Instant::now();
        let (nodes, root, order) = build::build(&primitives, settings);
        let mut slots: Vec<Option<P>> = primitives.into_iter().map(Some).collect();
        let primitives = order
            .iter()
            .map(|&i| slots[i as usize].take().expect("each primitive once"))
            .collect();
        Self {
            nodes,
            root,
            primitives,
            build_seconds: start.elapsed().as_secs_f64(),
        }
    }

    /// The same tree with each leaf's primitives turned into one primitive of another
    /// kind by `combine` (e.g. up to four triangles into one SIMD block). Leaves of the
    /// result hold exactly one primitive each, numbered in node order.
    pub fn map_leaves<Q>(&self, combine: impl Fn(&[P]) -> Q) -> Bvh<Q> {
        let mut primitives = vec_on_huge_pages(self.primitives.len());
        let mut remap = |reference: u32| match Child::decode(reference) {
            Child::Leaf { first, count } => {
                primitives.push(combine(
                    &self.primitives[first as usize..(first + count) as usize],
                ));
                Child::Leaf {
                    first: primitives.len() as u32 - 1,
                    count: 1,
                }
                .encode()
            }
            _ => reference,
        };
        let root = remap(self.root);
        let mut nodes = copy_to_huge_pages(&self.nodes);
        for node in &mut nodes {
            for child in &mut node.children {
                *child = remap(*child);
            }
        }
        Bvh {
            nodes,
            root,
            primitives,
            build_seconds: self.build_seconds,
        }
    }

    /// Box of the whole tree.
    pub fn bounds(&self) -> Aabb {
        match Child::decode(self.root) {
            Child::Inner(i) => self.nodes[i as usize].bounds(),
            Child::Leaf { first, count } => self.leaf_bounds(first, count),
            Child::Empty => Aabb::EMPTY,
        }
    }

    fn leaf_bounds(&self, first: u32, count: u32) -> Aabb {
        self.primitives[first as usize..(first + count) as usize]
            .iter()
            .fold(Aabb::EMPTY, |b, p| b.union(p.bounds()))
    }

    /// Recompute every box from the primitives (after they moved), keeping the topology:
    /// one pass from the root, children before their parent, O(nodes + primitives).
    /// Nodes may be stored in any order (a per-frame cluster scene keeps its clusters'
    /// nodes ahead of the top tree's).
    pub fn refit(&mut self) {
        self.refit_subtree(self.root);
    }

    /// Refit the subtree of `reference` and return its box.
    fn refit_subtree(&mut self, reference: u32) -> Aabb {
        match Child::decode(reference) {
            Child::Inner(n) => {
                let mut bounds = Aabb::EMPTY;
                for lane in 0..WIDTH {
                    let child = self.nodes[n as usize].children[lane];
                    if Child::decode(child) == Child::Empty {
                        continue;
                    }
                    let b = self.refit_subtree(child);
                    self.nodes[n as usize].set_child_bounds(lane, b);
                    bounds = bounds.union(b);
                }
                bounds
            }
            Child::Leaf { first, count } => self.leaf_bounds(first, count),
            Child::Empty => Aabb::EMPTY,
        }
    }

    /// Node count, leaves, SAH cost, bytes and depth.
    pub fn stats(&self) -> BvhStats {
        let mut stats = BvhStats {
            nodes: self.nodes.len(),
            node_bytes: self.nodes.len() * std::mem::size_of::<BvhNode>(),
            primitives: self.primitives.len(),
            build_seconds: self.build_seconds,
            sah_cost: self.sah_cost_by(|leaf| leaf.len() as f64) as f32,
            ..BvhStats::default()
        };
        let mut stack = vec![(self.root, 1usize)];
        while let Some((reference, depth)) = stack.pop() {
            stats.depth = stats.depth.max(depth);
            match Child::decode(reference) {
                Child::Inner(i) => {
                    let node = &self.nodes[i as usize];
                    stack.extend(node.children.iter().map(|&c| (c, depth + 1)));
                }
                Child::Leaf { .. } => stats.leaves += 1,
                Child::Empty => {}
            }
        }
        stats
    }

    /// SAH cost with the leaf costs given by `leaf_cost` (of a leaf's primitives):
    /// Σ over inner nodes of A(node)/A(root) + Σ over leaves of
    /// A(leaf)/A(root)·`leaf_cost`, A the box surface area. [`BvhStats::sah_cost`]
    /// counts one per primitive; a two-level estimate charges each instance its BLAS's
    /// cost ([`crate::trace::SceneAccel::two_level_sah_cost`]).
    pub fn sah_cost_by(&self, leaf_cost: impl Fn(&[P]) -> f64) -> f64 {
        let root_area = self.bounds().half_area().max(f32::MIN_POSITIVE) as f64;
        let mut sah = 0.0f64;
        let mut stack = vec![(self.root, self.bounds())];
        while let Some((reference, bounds)) = stack.pop() {
            let relative = bounds.half_area() as f64 / root_area;
            match Child::decode(reference) {
                Child::Inner(i) => {
                    sah += relative;
                    let node = &self.nodes[i as usize];
                    for lane in 0..WIDTH {
                        stack.push((node.children[lane], node.child_bounds(lane)));
                    }
                }
                Child::Leaf { first, count } => {
                    let leaf = &self.primitives[first as usize..(first + count) as usize];
                    sah += relative * leaf_cost(leaf);
                }
                Child::Empty => {}
            }
        }
        sah
    }

    /// Check every invariant: child boxes contain their subtrees' primitives, every node
    /// is reached from exactly one parent (so there is no cycle), every primitive is in
    /// exactly one leaf, leaves are 1..=15.
    /// Returns the first violation.
    pub fn validate(&self) -> Result<(), InvalidBvh> {
        let mut seen = vec![false; self.primitives.len()];
        let mut node_seen = vec![false; self.nodes.len()];
        let mut stack = vec![(self.root, None::<Aabb>)];
        while let Some((reference, bounds)) = stack.pop() {
            let subtree = match Child::decode(reference) {
                Child::Empty => continue,
                Child::Inner(i) => {
                    if i as usize >= self.nodes.len() || node_seen[i as usize] {
                        return Err(InvalidBvh::NodeReachedTwice(i));
                    }
                    node_seen[i as usize] = true;
                    let node = &self.nodes[i as usize];
                    for lane in 0..WIDTH {
                        stack.push((node.children[lane], Some(node.child_bounds(lane))));
                    }
                    node.bounds()
                }
                Child::Leaf { first, count } => {
                    if count == 0 || (first + count) as usize > self.primitives.len() {
                        return Err(InvalidBvh::BadLeaf { first, count });
                    }
                    for p in first..first + count {
                        if std::mem::replace(&mut seen[p as usize], true) {
                            return Err(InvalidBvh::PrimitiveInTwoLeaves(p));
                        }
                    }
                    self.leaf_bounds(first, count)
                }
            };
            if let Some(b) = bounds {
                if b.union(subtree) != b {
                    return Err(InvalidBvh::LooseBox { child: b, subtree });
                }
            }
        }
        if let Some(p) = seen.iter().position(|&s| !s) {
            return Err(InvalidBvh::PrimitiveInNoLeaf(p));
        }
        if let Some(n) = node_seen.iter().position(|&s| !s) {
            return Err(InvalidBvh::Unreachable(n));
        }
        Ok(())
    }
}

/// A broken invariant of a [`Bvh`], as [`Bvh::validate`] finds it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InvalidBvh {
    /// An inner node index past the nodes, or reached from two parents.
    #[error("node {0} out of range or reached twice")]
    NodeReachedTwice(u32),
    /// A leaf with no primitive, or past the primitives.
    #[error("leaf {first}+{count} is empty or out of range")]
    BadLeaf {
        /// The leaf's first primitive.
        first: u32,
        /// Its primitive count.
        count: u32,
    },
    /// A primitive in two leaves.
    #[error("primitive {0} in two leaves")]
    PrimitiveInTwoLeaves(u32),
    /// A child box that does not contain its subtree.
    #[error("child box {child:?} does not contain its subtree {subtree:?}")]
    LooseBox {
        /// The box stored for the child.
        child: Aabb,
        /// The box of the child's subtree.
        subtree: Aabb,
    },
    /// A primitive in no leaf.
    #[error("primitive {0} in no leaf")]
    PrimitiveInNoLeaf(usize),
    /// An inner node no path from the root reaches.
    #[error("node {0} unreachable")]
    Unreachable(usize),
}

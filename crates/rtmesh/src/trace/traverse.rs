//! Single-ray traversal of a [`Bvh`]: closest hit (ordered, nearest child first, and
//! subtrees farther than the closest hit so far are skipped when popped) and any hit
//! (stops at the first hit).
//!
//! Each node visit tests its eight child boxes at once with 8-wide SIMD (the `wide`
//! crate: AVX where compiled in, else two SSE or NEON halves, scalar elsewhere) using
//! the slab test with the precomputed safe reciprocal direction and per-axis near planes
//! (Williams et al., "An efficient and robust ray-box intersection algorithm", JGT 2005).
//! Far distances use the reciprocal scaled by 1 + 2γ₃ (Ize, "Robust BVH ray traversal",
//! JCGT 2013) so that rounding never culls a box the ray touches, including flat boxes
//! and rays that run along a box face. The min/max reductions are balanced trees to
//! shorten the latency chain that every step of a traversal waits on. Cost per visit:
//! 6 subtractions, 6 multiplications, 8 min/max, and a sort of the (usually 1–3) hits.

#[cfg(target_arch = "x86_64")]
mod avx;

use super::{Counters, RayQuery};
use crate::bvh::WIDTH;
use crate::bvh::{Bvh, BvhNode, Child, QuantizedBvh, QuantizedNode, EMPTY_CHILD};
use crate::simd::Isa;
use wide::f32x8;

/// Deepest stack any tree of ours needs: the builder bounds the binary depth at 64 SAH
/// levels plus 27 median-split levels (2^27 primitives at most), a collapsed tree is no
/// deeper, and each level pushes at most 7 children.
pub(crate) const STACK_SIZE: usize = (WIDTH - 1) * (64 + 27) + 1;

/// A traversal stack that is not zero-filled per ray (that memset would cost more than
/// a typical traversal). Only slots below `len` are ever read, and all were written.
pub(crate) struct Stack<T: Copy> {
    slots: [std::mem::MaybeUninit<T>; STACK_SIZE],
    len: usize,
}

impl<T: Copy> Stack<T> {
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Self {
            slots: [const { std::mem::MaybeUninit::uninit() }; STACK_SIZE],
            len: 0,
        }
    }

    #[inline(always)]
    pub(crate) fn push(&mut self, value: T) {
        self.slots[self.len].write(value);
        self.len += 1;
    }

    #[inline(always)]
    pub(crate) fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: every slot below the old `len` was written by `push`.
        Some(unsafe { self.slots[self.len].assume_init() })
    }
}

/// Near distances and hit mask of the eight child boxes `planes` (laid out as
/// [`BvhNode::planes`]), with the node test of `S`: AVX's 256-bit registers, or `wide`'s
/// portable 8 lanes (the reference: the same operations, so the same results).
#[inline(always)]
pub(crate) fn children<S: Isa>(
    planes: &[[f32; WIDTH]; 6],
    ray: &RayQuery,
    t_max: f32,
) -> ([f32; WIDTH], u32) {
    #[cfg(target_arch = "x86_64")]
    if S::AVX {
        // SAFETY: code with an AVX `Isa` runs only on CPUs with AVX, compiled with it.
        return unsafe { avx::avx_children(planes, ray, t_max) };
    }
    portable_children(planes, ray, t_max)
}

/// The node test on any CPU: `wide`'s 8-lane floats (two SSE/NEON halves, or AVX when
/// the whole program is compiled for it).
#[inline(always)]
fn portable_children(p: &[[f32; WIDTH]; 6], ray: &RayQuery, t_max: f32) -> ([f32; WIDTH], u32) {
    let ([nx, ny, nz], [fx, fy, fz]) = (ray.near_plane, ray.far_plane);
    let o = ray.origin;
    let (i, f) = (ray.inverse_direction, ray.inverse_direction_far);
    let slab = |plane: usize, origin: f32, inverse: f32| {
        (f32x8::new(p[plane]) - f32x8::splat(origin)) * f32x8::splat(inverse)
    };
    let near = slab(nx, o.x, i.x)
        .fast_max(slab(ny, o.y, i.y))
        .fast_max(slab(nz, o.z, i.z).fast_max(f32x8::splat(ray.t_min)));
    let far = slab(fx, o.x, f.x)
        .fast_min(slab(fy, o.y, f.y))
        .fast_min(slab(fz, o.z, f.z).fast_min(f32x8::splat(t_max)));
    (near.to_array(), near.simd_le(far).to_bitmask())
}

/// A tree the single-ray traversal walks: 8-wide nodes of child references
/// ([`Child`]'s encoding) over primitives in leaf order. [`Bvh`]'s nodes hold f32
/// planes; [`QuantizedBvh`]'s decode theirs first.
pub(crate) trait WideTree<P> {
    /// Its node.
    type Node;
    /// The root reference.
    fn root(&self) -> u32;
    /// Inner node `index`.
    fn node(&self, index: u32) -> &Self::Node;
    /// The primitives in leaf order.
    fn primitives(&self) -> &[P];
    /// Near distances and hit mask of the node's children.
    fn test<S: Isa>(node: &Self::Node, ray: &RayQuery, t_max: f32) -> ([f32; WIDTH], u32);
    /// The reference of child `lane`.
    fn child(node: &Self::Node, lane: usize) -> u32;
    /// Children the node holds (its box tests).
    fn occupied(node: &Self::Node) -> u32;
    /// Ask the memory system for what the node's test reads.
    fn prefetch_node(node: &Self::Node);
}

impl<P> WideTree<P> for Bvh<P> {
    type Node = BvhNode;
    #[inline(always)]
    fn root(&self) -> u32 {
        self.root
    }
    #[inline(always)]
    fn node(&self, index: u32) -> &BvhNode {
        &self.nodes[index as usize]
    }
    #[inline(always)]
    fn primitives(&self) -> &[P] {
        &self.primitives
    }
    #[inline(always)]
    fn test<S: Isa>(node: &BvhNode, ray: &RayQuery, t_max: f32) -> ([f32; WIDTH], u32) {
        children::<S>(&node.planes, ray, t_max)
    }
    #[inline(always)]
    fn child(node: &BvhNode, lane: usize) -> u32 {
        node.children[lane]
    }
    #[inline(always)]
    fn occupied(node: &BvhNode) -> u32 {
        node.children.iter().filter(|&&c| c != EMPTY_CHILD).count() as u32
    }
    #[inline(always)]
    fn prefetch_node(node: &BvhNode) {
        crate::prefetch(&node.planes)
    }
}

impl<P> WideTree<P> for QuantizedBvh<P> {
    type Node = QuantizedNode;
    #[inline(always)]
    fn root(&self) -> u32 {
        self.root
    }
    #[inline(always)]
    fn node(&self, index: u32) -> &QuantizedNode {
        &self.nodes[index as usize]
    }
    #[inline(always)]
    fn primitives(&self) -> &[P] {
        &self.primitives
    }
    #[inline(always)]
    fn test<S: Isa>(node: &QuantizedNode, ray: &RayQuery, t_max: f32) -> ([f32; WIDTH], u32) {
        children::<S>(&node.decoded_planes(), ray, t_max)
    }
    #[inline(always)]
    fn child(node: &QuantizedNode, lane: usize) -> u32 {
        node.child(lane)
    }
    #[inline(always)]
    fn occupied(node: &QuantizedNode) -> u32 {
        node.occupied()
    }
    #[inline(always)]
    fn prefetch_node(node: &QuantizedNode) {
        crate::prefetch(node)
    }
}

/// Insert `entry` among the first `n` entries of `sorted`, kept in decreasing order of
/// `distance` (the nearest last, to be visited first), and count it in `n`.
#[inline(always)]
pub(crate) fn insert_nearest_last<T: Copy>(
    sorted: &mut [T; WIDTH],
    n: &mut usize,
    entry: T,
    distance: impl Fn(&T) -> f32,
) {
    let mut j = *n;
    while j > 0 && distance(&sorted[j - 1]) < distance(&entry) {
        sorted[j] = sorted[j - 1];
        j -= 1;
    }
    sorted[j] = entry;
    *n += 1;
}

/// Ask the memory system for a child the traversal will probably visit after the one
/// it goes to now (a pushed sibling), so that its cache misses overlap the current
/// subtree's instead of following them: a single ray's traversal is otherwise a chain
/// of dependent loads. Only a hint: it changes speed, never results.
#[inline(always)]
fn prefetch_child<P, T: WideTree<P>>(tree: &T, reference: u32) {
    match Child::decode(reference) {
        Child::Inner(i) => T::prefetch_node(tree.node(i)),
        Child::Leaf { first, count } => {
            crate::prefetch(&tree.primitives()[first as usize..(first + count) as usize])
        }
        Child::Empty => {}
    }
}

#[inline(always)]
fn count_boxes<P, T: WideTree<P>, C: Counters>(node: &T::Node, counters: &mut C) {
    if C::ENABLED {
        counters.node_visited();
        counters.box_tests(T::occupied(node));
    }
}

/// Closest-hit traversal. `leaf(primitives, t_max, counters)` tests a leaf's primitives,
/// lowers `t_max` when it finds a closer hit, and returns whether it did. Returns
/// whether anything was hit.
#[inline(always)]
pub(crate) fn closest_hit<S: Isa, P, T: WideTree<P>, C: Counters>(
    bvh: &T,
    ray: &RayQuery,
    t_max: &mut f32,
    counters: &mut C,
    mut leaf: impl FnMut(&[P], &mut f32, &mut C) -> bool,
) -> bool {
    let mut stack = Stack::<(u32, f32)>::new();
    let mut current = bvh.root();
    let mut found = false;
    loop {
        match Child::decode(current) {
            Child::Inner(index) => {
                let node = bvh.node(index);
                count_boxes::<P, T, C>(node, counters);
                let (near, mut mask) = T::test::<S>(node, ray, *t_max);
                if mask != 0 {
                    // One child hit (the common case for incoherent rays): go on.
                    let lane = mask.trailing_zeros() as usize;
                    if mask & (mask - 1) == 0 {
                        current = T::child(node, lane);
                        continue;
                    }
                    // Hit children sorted by entry distance, nearest last.
                    let mut hits = [(T::child(node, lane), near[lane]); WIDTH];
                    let mut n = 1;
                    mask &= mask - 1;
                    while mask != 0 {
                        let lane = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        insert_nearest_last(
                            &mut hits,
                            &mut n,
                            (T::child(node, lane), near[lane]),
                            |e| e.1,
                        );
                    }
                    for &entry in &hits[..n - 1] {
                        prefetch_child(bvh, entry.0);
                        stack.push(entry);
                    }
                    current = hits[n - 1].0;
                    continue;
                }
            }
            Child::Leaf { first, count } => {
                let primitives = &bvh.primitives()[first as usize..(first + count) as usize];
                found |= leaf(primitives, t_max, counters);
            }
            Child::Empty => {}
        }
        // Pop the next subtree that may still hold a closer hit.
        loop {
            let Some((reference, entry)) = stack.pop() else {
                return found;
            };
            if entry <= *t_max {
                current = reference;
                break;
            }
        }
    }
}

/// Any-hit traversal: stops at the first leaf hit. `leaf(primitives, t_max, counters)`
/// returns whether a primitive blocks the ray.
#[inline(always)]
pub(crate) fn any_hit<S: Isa, P, T: WideTree<P>, C: Counters>(
    bvh: &T,
    ray: &RayQuery,
    t_max: f32,
    counters: &mut C,
    mut leaf: impl FnMut(&[P], f32, &mut C) -> bool,
) -> bool {
    let mut stack = Stack::<u32>::new();
    let mut current = bvh.root();
    loop {
        match Child::decode(current) {
            Child::Inner(index) => {
                let node = bvh.node(index);
                count_boxes::<P, T, C>(node, counters);
                let (_, mut mask) = T::test::<S>(node, ray, t_max);
                if mask != 0 {
                    current = T::child(node, mask.trailing_zeros() as usize);
                    mask &= mask - 1;
                    while mask != 0 {
                        stack.push(T::child(node, mask.trailing_zeros() as usize));
                        mask &= mask - 1;
                    }
                    continue;
                }
            }
            Child::Leaf { first, count } => {
                let primitives = &bvh.primitives()[first as usize..(first + count) as usize];
                if leaf(primitives, t_max, counters) {
                    return true;
                }
            }
            Child::Empty => {}
        }
        match stack.pop() {
            Some(next) => current = next,
            None => return false,
        }
    }
}

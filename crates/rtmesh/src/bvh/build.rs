//! Binned SAH build (Wald, "On fast construction of SAH-based bounding volume
//! hierarchies", 2007), then collapse of the binary tree into 8-wide nodes by pulling up
//! the grandchildren of the largest children (as Embree's BVH4/BVH8 builders do).
//!
//! Each node bins primitive centroids into `bins` (32) buckets on all three axes in one
//! pass, sweeps the buckets for the cheapest split under the surface area heuristic
//! `C_node + (A_L·N_L + A_R·N_R) / A · C_primitive`, and stops at a leaf when that is no
//! cheaper than `N · C_primitive` and N ≤ `max_leaf_size`. When every centroid coincides
//! (no bin split exists), or past depth 64, it splits at the object median instead, so
//! the tree stays shallow on any input. Subtrees over `parallel_threshold` primitives
//! are built in parallel with rayon. Cost: O(N log N) time, O(N) extra memory.

use super::{BvhNode, Child, Primitive, MAX_LEAF_SIZE, MAX_PRIMITIVES, WIDTH};
use crate::geom::Aabb;
use glam::{Vec3, Vec4};

/// Build settings, with named presets.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildSettings {
    /// Centroid bins per axis.
    pub bins: usize,
    /// Most primitives in a leaf (at most 15).
    pub max_leaf_size: usize,
    /// SAH cost of visiting a node, relative to one primitive test.
    pub node_cost: f32,
    /// SAH cost of one primitive test.
    pub primitive_cost: f32,
    /// Subtrees with more primitives than this are built in parallel.
    pub parallel_threshold: usize,
    /// Primitives a leaf tests at once (SIMD width of the leaf test): the SAH charges
    /// `ceil(n / leaf_block)` primitive tests for `n` primitives, as Embree does for its
    /// 4-triangle leaves.
    pub leaf_block: usize,
}

impl Default for BuildSettings {
    fn default() -> Self {
        Self::quality()
    }
}

impl BuildSettings {
    /// 32 bins, leaves of up to 4 triangles: the tracer's default.
    pub fn quality() -> Self {
        Self {
            bins: 32,
            max_leaf_size: 4,
            node_cost: 1.0,
            primitive_cost: 1.0,
            parallel_threshold: 4096,
            leaf_block: 1,
        }
    }

    /// 8 bins: faster builds for per-frame rebuilds, slightly worse trees.
    pub fn fast() -> Self {
        Self {
            bins: 8,
            ..Self::quality()
        }
    }
}

/// The binary tree before collapsing.
enum Tree {
    Leaf {
        bounds: Aabb,
        first: u32,
        count: u32,
    },
    Inner {
        bounds: Aabb,
        children: Box<[Tree; 2]>,
    },
}

impl Tree {
    fn bounds(&self) -> Aabb {
        match self {
            Tree::Leaf { bounds, .. } | Tree::Inner { bounds, .. } => *bounds,
        }
    }
}

/// A box in SIMD registers (glam's `Vec4` is SSE/NEON-backed): one union is two
/// instructions. The w lanes carry no geometry.
#[derive(Clone, Copy)]
struct Box4 {
    min: Vec4,
    max: Vec4,
}

impl Box4 {
    const EMPTY: Box4 = Box4 {
        min: Vec4::splat(f32::INFINITY),
        max: Vec4::splat(f32::NEG_INFINITY),
    };

    #[inline(always)]
    fn union(self, other: Box4) -> Box4 {
        Box4 {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    #[inline(always)]
    fn grown_by_point(self, p: Vec4) -> Box4 {
        Box4 {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    #[inline(always)]
    fn half_area(&self) -> f32 {
        let d = (self.max - self.min).truncate().max(Vec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }

    fn to_aabb(self) -> Aabb {
        Aabb {
            min: self.min.truncate(),
            max: self.max.truncate(),
        }
    }
}

/// A primitive reference as the builder moves it: its box, with the primitive's index
/// in the w lane of `min` (bit pattern of a tiny positive float, never NaN for indices
/// below 2^27), so one reference is 32 bytes. Partitioning these in place keeps every
/// pass sequential in memory.
#[derive(Clone, Copy)]
struct PrimRef(Box4);

impl PrimRef {
    fn new(bounds: Aabb, index: u32) -> Self {
        Self(Box4 {
            min: bounds.min.extend(f32::from_bits(index)),
            max: bounds.max.extend(0.0),
        })
    }

    #[inline(always)]
    fn index(&self) -> u32 {
        self.0.min.w.to_bits()
    }

    /// Twice the centroid (min + max): binning only needs it up to scale.
    #[inline(always)]
    fn centroid2(&self) -> Vec4 {
        self.0.min + self.0.max
    }
}

/// Most bins per axis.
const MAX_BINS: usize = 32;

/// Build nodes over `primitives`. Returns the nodes, the root reference and the leaf
/// order (indices into `primitives`; primitives with bad boxes are left out).
pub(super) fn build<P: Primitive>(
    primitives: &[P],
    settings: &BuildSettings,
) -> (Vec<BvhNode>, u32, Vec<u32>) {
    assert!(
        primitives.len() < MAX_PRIMITIVES,
        "a BVH holds fewer than 2^27 primitives"
    );
    let settings = BuildSettings {
        max_leaf_size: settings.max_leaf_size.clamp(1, MAX_LEAF_SIZE),
        bins: settings.bins.clamp(2, MAX_BINS),
        leaf_block: settings.leaf_block.max(1),
        ..settings.clone()
    };
    let mut refs: Vec<PrimRef> = primitives
        .iter()
        .enumerate()
        .map(|(i, p)| (i, p.bounds()))
        .filter(|(_, b)| b.is_finite())
        .map(|(i, b)| PrimRef::new(b, i as u32))
        .collect();
    if refs.is_empty() {
        return (Vec::new(), Child::Empty.encode(), Vec::new());
    }
    let tree = build_node(&settings, &mut refs, 0, 0);
    let mut nodes = Vec::with_capacity(primitives.len() / 2);
    let root = collapse(&tree, &mut nodes);
    (nodes, root, refs.iter().map(PrimRef::index).collect())
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Box4,
    count: u32,
}

const EMPTY_BIN: Bin = Bin {
    bounds: Box4::EMPTY,
    count: 0,
};

/// Maps twice-centroids to bins along each axis.
struct Binning {
    low: Vec4,
    scale: Vec4,
    bins: usize,
}

impl Binning {
    fn new(centroid2_bounds: &Box4, bins: usize) -> Self {
        let extent = (centroid2_bounds.max - centroid2_bounds.min).truncate();
        let scale = Vec3::select(
            extent.cmpgt(Vec3::ZERO),
            Vec3::splat(bins as f32 * (1.0 - 1e-6)) / extent,
            Vec3::ZERO,
        );
        Self {
            low: centroid2_bounds.min,
            scale: scale.extend(0.0),
            bins,
        }
    }

    /// Bins of all three axes at once.
    #[inline(always)]
    fn bins_of(&self, centroid2: Vec4) -> [usize; 3] {
        let b = ((centroid2 - self.low) * self.scale).as_uvec4();
        let last = self.bins as u32 - 1;
        [
            b.x.min(last) as usize,
            b.y.min(last) as usize,
            b.z.min(last) as usize,
        ]
    }

    #[inline(always)]
    fn bin(&self, centroid2: Vec4, axis: usize) -> usize {
        (((centroid2[axis] - self.low[axis]) * self.scale[axis]) as usize).min(self.bins - 1)
    }
}

fn build_node(settings: &BuildSettings, refs: &mut [PrimRef], offset: usize, depth: usize) -> Tree {
    let (bounds, centroid2_bounds) = refs.iter().fold((Box4::EMPTY, Box4::EMPTY), |(b, c), r| {
        (b.union(r.0), c.grown_by_point(r.centroid2()))
    });
    let n = refs.len();
    let leaf = || Tree::Leaf {
        bounds: bounds.to_aabb(),
        first: offset as u32,
        count: n as u32,
    };
    if n == 1 {
        return leaf();
    }
    let leaf_cost = blocks(n as u32, settings) * settings.primitive_cost;
    let binning = Binning::new(
        &centroid2_bounds,
        settings.bins.min(n.next_power_of_two().max(4)),
    );
    let split = if depth < 64 {
        best_split(settings, &binning, refs, &bounds)
    } else {
        None
    };
    let mid = match split {
        Some((cost, axis, bin)) if cost < leaf_cost || n > settings.max_leaf_size => {
            let mid = partition(refs, |r| binning.bin(r.centroid2(), axis) < bin);
            if mid == 0 || mid == n {
                median_split(refs, &centroid2_bounds)
            } else {
                mid
            }
        }
        _ if n <= settings.max_leaf_size => return leaf(),
        _ => median_split(refs, &centroid2_bounds),
    };
    let (left, right) = refs.split_at_mut(mid);
    let (l, r) = if n > settings.parallel_threshold {
        rayon::join(
            || build_node(settings, left, offset, depth + 1),
            || build_node(settings, right, offset + mid, depth + 1),
        )
    } else {
        (
            build_node(settings, left, offset, depth + 1),
            build_node(settings, right, offset + mid, depth + 1),
        )
    };
    Tree::Inner {
        bounds: bounds.to_aabb(),
        children: Box::new([l, r]),
    }
}

/// The cheapest binned split: (SAH cost, axis, first bin of the right side), with bin
/// arrays sized to the node (small nodes use few
/// bins, and zero-filling 96 large bins per node would cost more than the binning).
fn best_split(
    settings: &BuildSettings,
    binning: &Binning,
    refs: &[PrimRef],
    bounds: &Box4,
) -> Option<(f32, usize, usize)> {
    match binning.bins {
        0..=4 => best_split_in::<4>(settings, binning, refs, bounds),
        5..=8 => best_split_in::<8>(settings, binning, refs, bounds),
        9..=16 => best_split_in::<16>(settings, binning, refs, bounds),
        _ => best_split_in::<MAX_BINS>(settings, binning, refs, bounds),
    }
}

fn best_split_in<const BINS: usize>(
    settings: &BuildSettings,
    binning: &Binning,
    refs: &[PrimRef],
    bounds: &Box4,
) -> Option<(f32, usize, usize)> {
    let bins = binning.bins;
    let mut binned = [[EMPTY_BIN; BINS]; 3];
    for r in refs {
        let slots = binning.bins_of(r.centroid2());
        for (axis_bins, slot) in binned.iter_mut().zip(slots) {
            let bin = &mut axis_bins[slot];
            bin.bounds = bin.bounds.union(r.0);
            bin.count += 1;
        }
    }
    let inverse_area = 1.0 / bounds.half_area().max(f32::MIN_POSITIVE);
    let mut best: Option<(f32, usize, usize)> = None;
    let mut right_cost = [0.0f32; BINS];
    for (axis, axis_bins) in binned.iter().enumerate() {
        if binning.scale[axis] == 0.0 {
            continue;
        }
        let (mut area_box, mut count) = (Box4::EMPTY, 0u32);
        for b in (1..bins).rev() {
            area_box = area_box.union(axis_bins[b].bounds);
            count += axis_bins[b].count;
            right_cost[b] = area_box.half_area() * blocks(count, settings);
        }
        let (mut area_box, mut count) = (Box4::EMPTY, 0u32);
        for b in 1..bins {
            area_box = area_box.union(axis_bins[b - 1].bounds);
            count += axis_bins[b - 1].count;
            let cost = settings.node_cost
                + (area_box.half_area() * blocks(count, settings) + right_cost[b])
                    * inverse_area
                    * settings.primitive_cost;
            if count > 0 && (count as usize) < refs.len() && best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    best
}

/// Leaf tests needed for `count` primitives.
#[inline(always)]
fn blocks(count: u32, settings: &BuildSettings) -> f32 {
    count.div_ceil(settings.leaf_block as u32) as f32
}

/// Split at the object median along the centroid box's longest axis.
fn median_split(refs: &mut [PrimRef], centroid2_bounds: &Box4) -> usize {
    let extent = (centroid2_bounds.max - centroid2_bounds.min).truncate();
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = refs.len() / 2;
    refs.select_nth_unstable_by(mid, |a, b| {
        a.centroid2()[axis].total_cmp(&b.centroid2()[axis])
    });
    mid
}

/// Move the items where `goes_left` holds to the front (Hoare-style, each item moved
/// at most once); returns how many there are.
fn partition(items: &mut [PrimRef], goes_left: impl Fn(&PrimRef) -> bool) -> usize {
    let (mut left, mut right) = (0, items.len());
    loop {
        while left < right && goes_left(&items[left]) {
            left += 1;
        }
        while left < right && !goes_left(&items[right - 1]) {
            right -= 1;
        }
        if left >= right {
            return left;
        }
        items.swap(left, right - 1);
        left += 1;
        right -= 1;
    }
}

/// Emit 8-wide nodes for `tree`, parent first; returns its reference.
fn collapse(tree: &Tree, nodes: &mut Vec<BvhNode>) -> u32 {
    let children = match tree {
        Tree::Leaf { first, count, .. } => {
            return Child::Leaf {
                first: *first,
                count: *count,
            }
            .encode()
        }
        Tree::Inner { children, .. } => children,
    };
    let index = nodes.len();
    nodes.push(BvhNode::EMPTY);
    let mut kids: [&Tree; WIDTH] = [&children[1]; WIDTH];
    kids[0] = &children[0];
    let mut count = 2;
    while count < WIDTH {
        // Open the inner child with the largest surface area, keeping spatial order.
        let mut open = None;
        let mut largest = f32::NEG_INFINITY;
        for (i, kid) in kids[..count].iter().enumerate() {
            if let Tree::Inner { bounds, children } = kid {
                if bounds.half_area() > largest {
                    largest = bounds.half_area();
                    open = Some((i, children));
                }
            }
        }
        let Some((i, grand)) = open else { break };
        kids.copy_within(i + 1..count, i + 2);
        kids[i] = &grand[0];
        kids[i + 1] = &grand[1];
        count += 1;
    }
    let mut node = BvhNode::EMPTY;
    for (lane, kid) in kids[..count].iter().enumerate() {
        node.set_child_bounds(lane, kid.bounds());
        node.children[lane] = collapse(kid, nodes);
    }
    nodes[index] = node;
    index as u32
}

//! Packet traversal of the 8-wide BVH for rays that share an origin (camera rays of
//! 2×2, 4×4 or 8×8 neighbouring pixels, or shadow rays from one hit point): the classic
//! any-ray-active descent (Wald, Slusallek, Benthin & Wagner, "Interactive rendering
//! with coherent ray tracing", 2001) with a per-packet ray mask of up to 64 rays, and an
//! interval-arithmetic frustum test that culls children for the whole packet at once
//! (Wald, Boulos & Shirley, "Ray tracing deformable scenes using dynamic bounding volume
//! hierarchies", TOG 2007).
//!
//! Per visited node: one frustum test of all eight children (8-wide SIMD: the packet's
//! per-axis range of reciprocal directions against each slab, 12 multiplications), then
//! for each child the frustum keeps, the exact single-ray slab test for the active rays,
//! eight rays per SIMD test. A child is entered with the mask of rays that hit it,
//! nearest (by the frustum's entry distance) first. At a leaf each 4-triangle block
//! computes the intersector's shared terms once ([`Intersector::share`]) and tests each
//! active ray ([`Intersector::test`]), which is where `moller-packet` pays.
//!
//! Exactness: a ray's box tests use the very operations of single-ray traversal, so a
//! ray enters every box it would enter alone, and its leaf tests are the single-ray
//! tests; the closest hit is the same, up to the order in which exact ties in `t` are
//! met. Rays need not share an origin or direction signs: such packets (diffuse
//! bounces of neighbouring pixels) take a general form that reads each ray's origin,
//! tests both planes per axis, and computes the intersector's shared terms per ray.
//! Scenes with a top level are traced ray by ray.

use super::intersect::{BasicRay, Intersector, MAX_PACKET_RAYS};
use super::traverse::{insert_nearest_last, Stack};
use super::triangle::Triangle4;
use super::{safe_reciprocal, Counters, Hit, RayQuery, ROBUST_FAR_SCALE};
use crate::bvh::{Bvh, BvhNode, Child, EMPTY_CHILD, WIDTH};
use crate::geom::Ray;
use crate::simd::{dispatch, Isa, Kernel, Lanes};
use glam::Vec3;
use wide::f32x4;

/// Rays of one packet, structure of arrays, room for 64 rays.
struct Packet {
    /// The first ray's origin (all rays' when `shared_origin`).
    origin: Vec3,
    len: usize,
    shared_origin: bool,
    /// Some axis has directions of both signs: no common near plane.
    mixed_signs: bool,
    origins: [[f32; MAX_PACKET_RAYS]; 3],
    directions: [[f32; MAX_PACKET_RAYS]; 3],
    /// Per axis, the smallest and largest origin coordinate.
    origin_range: [(f32, f32); 3],
    rays: [BasicRay; MAX_PACKET_RAYS],
    inverse: [[f32; MAX_PACKET_RAYS]; 3],
    inverse_far: [[f32; MAX_PACKET_RAYS]; 3],
    t_min: [f32; MAX_PACKET_RAYS],
    t_max: [f32; MAX_PACKET_RAYS],
    near_plane: [usize; 3],
    far_plane: [usize; 3],
    /// Per axis, the smallest and largest reciprocal direction (near planes).
    inverse_range: [(f32, f32); 3],
    /// Per axis, the same for the far-plane reciprocals.
    inverse_far_range: [(f32, f32); 3],
    lowest_t_min: f32,
}

/// Storage for tracing packets, about 10 KB: make one per thread or work item and
/// reuse it for many packets.
pub struct PacketBuffer(Box<Packet>);

impl Default for PacketBuffer {
    fn default() -> Self {
        let ray = BasicRay::from(&Ray::new(Vec3::ZERO, Vec3::ONE));
        Self(Box::new(Packet {
            origin: Vec3::ZERO,
            len: 0,
            shared_origin: true,
            mixed_signs: false,
            origins: [[0.0; MAX_PACKET_RAYS]; 3],
            directions: [[0.0; MAX_PACKET_RAYS]; 3],
            origin_range: [(0.0, 0.0); 3],
            rays: [ray; MAX_PACKET_RAYS],
            inverse: [[0.0; MAX_PACKET_RAYS]; 3],
            inverse_far: [[0.0; MAX_PACKET_RAYS]; 3],
            t_min: [0.0; MAX_PACKET_RAYS],
            t_max: [0.0; MAX_PACKET_RAYS],
            near_plane: [0, 1, 2],
            far_plane: [3, 4, 5],
            inverse_range: [(0.0, 0.0); 3],
            inverse_far_range: [(0.0, 0.0); 3],
            lowest_t_min: 0.0,
        }))
    }
}

impl Packet {
    /// Prepare `rays` (1 to 64): copy them structure-of-arrays, then compute the
    /// reciprocal directions (the single-ray [`RayQuery`] values, bit for bit) and
    /// the packet's ranges eight rays at a time. Slots past `rays.len()` keep stale
    /// values, which the ray masks never read.
    #[inline(always)]
    fn fill<L: Lanes>(&mut self, rays: &[Ray]) {
        debug_assert!(L::WIDTH == 8 && !rays.is_empty() && rays.len() <= MAX_PACKET_RAYS);
        let first = rays[0].origin;
        self.origin = first;
        self.len = rays.len();
        self.shared_origin = true;
        self.lowest_t_min = f32::INFINITY;
        for (r, ray) in rays.iter().enumerate() {
            self.rays[r] = BasicRay::from(ray);
            for axis in 0..3 {
                self.origins[axis][r] = ray.origin[axis];
                self.directions[axis][r] = ray.direction[axis];
            }
            self.t_min[r] = ray.t_min;
            self.t_max[r] = ray.t_max;
            self.shared_origin &= ray.origin == first;
            self.lowest_t_min = self.lowest_t_min.min(ray.t_min);
        }
        // Pad the last group of eight with the first ray: no effect on the ranges.
        let padded = rays.len().div_ceil(8) * 8;
        for axis in 0..3 {
            for r in rays.len()..padded {
                self.origins[axis][r] = self.origins[axis][0];
                self.directions[axis][r] = self.directions[axis][0];
            }
        }
        // Padding never enters a box and never raises the farthest bound.
        self.t_max[rays.len()..padded].fill(f32::NEG_INFINITY);
        self.mixed_signs = false;
        for axis in 0..3 {
            let (mut low, mut high) = (L::splat(f32::INFINITY), L::splat(f32::NEG_INFINITY));
            let (mut far_low, mut far_high) = (low, high);
            let (mut o_low, mut o_high) = (low, high);
            for base in (0..padded).step_by(8) {
                let d = L::load(&self.directions[axis][base..]);
                self.inverse[axis][base..base + 8].copy_from_slice(&(L::splat(1.0) / d).to_array());
                let mut tiny = L::bitmask(L::lt(d.abs(), L::splat(1e-18)));
                while tiny != 0 {
                    let r = base + tiny.trailing_zeros() as usize;
                    self.inverse[axis][r] = safe_reciprocal(self.directions[axis][r]);
                    tiny &= tiny - 1;
                }
                let inverse = L::load(&self.inverse[axis][base..]);
                let inverse_far = inverse * L::splat(ROBUST_FAR_SCALE);
                self.inverse_far[axis][base..base + 8].copy_from_slice(&inverse_far.to_array());
                low = low.min(inverse);
                high = high.max(inverse);
                far_low = far_low.min(inverse_far);
                far_high = far_high.max(inverse_far);
                let o = L::load(&self.origins[axis][base..]);
                o_low = o_low.min(o);
                o_high = o_high.max(o);
            }
            let reduce = |lanes: L, f: fn(f32, f32) -> f32| {
                lanes.to_array().into_iter().reduce(f).unwrap_or(0.0)
            };
            self.inverse_range[axis] = (reduce(low, f32::min), reduce(high, f32::max));
            self.inverse_far_range[axis] = (reduce(far_low, f32::min), reduce(far_high, f32::max));
            self.origin_range[axis] = (reduce(o_low, f32::min), reduce(o_high, f32::max));
            let (lowest, highest) = self.inverse_range[axis];
            self.mixed_signs |= lowest < 0.0 && highest >= 0.0;
            // As `RayQuery::new` picks: the low plane when the reciprocal is ≥ 0.
            self.near_plane[axis] = if lowest >= 0.0 { axis } else { axis + 3 };
            self.far_plane[axis] = (self.near_plane[axis] + 3) % 6;
        }
    }

    /// The largest current `t_max` of the packet's rays: nothing farther matters.
    #[inline(always)]
    fn farthest<L: Lanes>(&self) -> f32 {
        let mut farthest = L::splat(f32::NEG_INFINITY);
        for base in (0..self.len).step_by(8) {
            farthest = farthest.max(L::load(&self.t_max[base..]));
        }
        farthest
            .to_array()
            .into_iter()
            .fold(f32::NEG_INFINITY, f32::max)
    }

    /// The mask of all rays.
    fn all(&self) -> u64 {
        if self.len == 64 {
            u64::MAX
        } else {
            (1u64 << self.len) - 1
        }
    }

    /// Frustum test of `node`'s eight children: entry distances and the mask of those
    /// some ray of the packet may enter. With one origin and one direction sign per
    /// axis, each slab's distances over the packet lie between the products with the
    /// smallest and largest reciprocal; in the `GENERAL` case (origins spread, or
    /// signs mixed) both planes and the origin range enter the interval product.
    /// Rounding is monotone, so the bounds hold for every ray's own float test.
    #[inline(always)]
    fn frustum<L: Lanes, const GENERAL: bool>(
        &self,
        node: &BvhNode,
        farthest: f32,
    ) -> ([f32; 8], u32) {
        let mut near = L::splat(self.lowest_t_min);
        let mut far = L::splat(farthest);
        for axis in 0..3 {
            let (low, high) = self.inverse_range[axis];
            let (far_low, far_high) = self.inverse_far_range[axis];
            if GENERAL {
                let (o_low, o_high) = self.origin_range[axis];
                let (mut lower, mut upper) = (L::splat(f32::INFINITY), L::splat(f32::NEG_INFINITY));
                for plane in [axis, axis + 3] {
                    let p = L::load(&node.planes[plane]);
                    for d in [p - L::splat(o_low), p - L::splat(o_high)] {
                        lower = lower.min((d * L::splat(low)).min(d * L::splat(high)));
                        upper = upper.max((d * L::splat(far_low)).max(d * L::splat(far_high)));
                    }
                }
                near = near.max(lower);
                far = far.min(upper);
            } else {
                let o = L::splat(self.origin[axis]);
                let to_near = L::load(&node.planes[self.near_plane[axis]]) - o;
                near = near.max((to_near * L::splat(low)).min(to_near * L::splat(high)));
                let to_far = L::load(&node.planes[self.far_plane[axis]]) - o;
                far = far.min((to_far * L::splat(far_low)).max(to_far * L::splat(far_high)));
            }
        }
        let mut mask = L::bitmask(L::le(near, far));
        if GENERAL {
            // Inverted (empty) boxes pass the two-plane test; drop them here.
            for (lane, &child) in node.children.iter().enumerate() {
                if child == EMPTY_CHILD {
                    mask &= !(1 << lane);
                }
            }
        }
        (near.to_array(), mask)
    }

    /// The rays of `active` whose single-ray slab test enters child `lane` of `node`
    /// before their current closest hit, eight rays per SIMD test. The `GENERAL` form
    /// reads each ray's origin and takes the nearer and farther of both planes per
    /// axis, which for a non-empty box are exactly the planes a single ray picks by
    /// its direction's sign (the caller never asks about empty children).
    #[inline(always)]
    fn rays_entering<L: Lanes, const GENERAL: bool>(
        &self,
        node: &BvhNode,
        lane: usize,
        active: u64,
    ) -> u64 {
        let mut entering = 0u64;
        let mut groups = active;
        while groups != 0 {
            let base = (groups.trailing_zeros() as usize) & !7;
            let mut near = L::load(&self.t_min[base..]);
            let mut far = L::load(&self.t_max[base..]);
            for axis in 0..3 {
                let inverse = L::load(&self.inverse[axis][base..]);
                let inverse_far = L::load(&self.inverse_far[axis][base..]);
                if GENERAL {
                    let o = L::load(&self.origins[axis][base..]);
                    let to_low = L::splat(node.planes[axis][lane]) - o;
                    let to_high = L::splat(node.planes[axis + 3][lane]) - o;
                    near = near.max((to_low * inverse).min(to_high * inverse));
                    far = far.min((to_low * inverse_far).max(to_high * inverse_far));
                } else {
                    let o = self.origin[axis];
                    let to_near = node.planes[self.near_plane[axis]][lane] - o;
                    let to_far = node.planes[self.far_plane[axis]][lane] - o;
                    near = near.max(L::splat(to_near) * inverse);
                    far = far.min(L::splat(to_far) * inverse_far);
                }
            }
            entering |= (L::bitmask(L::le(near, far)) as u64) << base;
            groups &= !(0xFFu64 << base);
        }
        entering & active
    }
}

/// Bits of `mask`, lowest first.
#[inline(always)]
fn bits(mut mask: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let bit = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            bit
        })
    })
}

/// Count a node visit: the frustum test of its non-empty children, charged to the
/// packet's first active ray, and one node visit.
#[inline(always)]
fn count_frustum<C: Counters>(node: &BvhNode, active: u64, counters: &mut [C]) {
    if C::ENABLED {
        let first = active.trailing_zeros() as usize;
        counters[first].node_visited();
        counters[first]
            .box_tests(node.children.iter().filter(|&&c| c != EMPTY_CHILD).count() as u32);
    }
}

/// Closest hits of a packet in one BVH (`hits[r].t` is ray `r`'s bound on entry).
#[inline(always)]
fn closest_in_bvh<L: Lanes, I: Intersector, C: Counters, const GENERAL: bool>(
    bvh: &Bvh<Triangle4>,
    packet: &mut Packet,
    hits: &mut [Hit],
    counters: &mut [C],
) {
    let per_ray: [I::PerRay; MAX_PACKET_RAYS] =
        std::array::from_fn(|r| I::prepare(&packet.rays[r]));
    let mut stack = Stack::<(u32, u64, f32)>::new();
    let mut current = (bvh.root, packet.all());
    let mut farthest = packet.farthest::<L>();
    loop {
        let (reference, active) = current;
        match Child::decode(reference) {
            Child::Inner(index) => {
                let node = &bvh.nodes[index as usize];
                count_frustum(node, active, counters);
                let (near, mut candidates) = packet.frustum::<L, GENERAL>(node, farthest);
                // Entered children sorted by frustum entry distance, nearest last.
                let mut entered = [(0u32, 0u64, 0.0f32); WIDTH];
                let mut n = 0;
                while candidates != 0 {
                    let lane = candidates.trailing_zeros() as usize;
                    candidates &= candidates - 1;
                    let rays = packet.rays_entering::<L, GENERAL>(node, lane, active);
                    if C::ENABLED {
                        for r in bits(active) {
                            counters[r].box_tests(1);
                        }
                    }
                    if rays == 0 {
                        continue;
                    }
                    let entry = (node.children[lane], rays, near[lane]);
                    insert_nearest_last(&mut entered, &mut n, entry, |e| e.2);
                }
                if n > 0 {
                    for &entry in &entered[..n - 1] {
                        stack.push(entry);
                    }
                    current = (entered[n - 1].0, entered[n - 1].1);
                    continue;
                }
            }
            Child::Leaf { first, count } => {
                let mut found_any = false;
                for block in &bvh.primitives[first as usize..(first + count) as usize] {
                    let mut shared = I::share::<f32x4>(block, packet.origin);
                    for r in bits(active) {
                        if C::ENABLED {
                            counters[r].triangle_tests(block.count());
                        }
                        let ray = &packet.rays[r];
                        if GENERAL && !packet.shared_origin {
                            shared = I::share::<f32x4>(block, ray.origin);
                        }
                        let found = I::test::<f32x4>(block, &shared, ray, &per_ray[r], hits[r].t);
                        if let Some((lane, t, u, v)) = found.and_then(|f| f.nearest()) {
                            hits[r] = Hit {
                                t,
                                u,
                                v,
                                triangle: block.ids[lane],
                                instance: 0,
                                geometry: 0,
                            };
                            packet.t_max[r] = t;
                            found_any = true;
                        }
                    }
                }
                if found_any {
                    farthest = packet.farthest::<L>();
                }
            }
            Child::Empty => {}
        }
        // Pop the next subtree some ray may still find a closer hit in.
        loop {
            let Some((reference, rays, near)) = stack.pop() else {
                return;
            };
            if near <= farthest {
                current = (reference, rays);
                break;
            }
        }
    }
}

/// Occlusion of a packet in one BVH: sets `occluded[r]` for every blocked ray.
#[inline(always)]
fn occluded_in_bvh<L: Lanes, I: Intersector, C: Counters, const GENERAL: bool>(
    bvh: &Bvh<Triangle4>,
    packet: &mut Packet,
    occluded: &mut [bool],
    counters: &mut [C],
) {
    let per_ray: [I::PerRay; MAX_PACKET_RAYS] =
        std::array::from_fn(|r| I::prepare(&packet.rays[r]));
    let mut stack = Stack::<(u32, u64)>::new();
    let mut blocked = 0u64;
    let mut current = (bvh.root, packet.all());
    loop {
        let (reference, active) = (current.0, current.1 & !blocked);
        match Child::decode(reference) {
            _ if active == 0 => {}
            Child::Inner(index) => {
                let node = &bvh.nodes[index as usize];
                count_frustum(node, active, counters);
                let (_, mut candidates) = packet.frustum::<L, GENERAL>(node, f32::INFINITY);
                let mut next = None;
                while candidates != 0 {
                    let lane = candidates.trailing_zeros() as usize;
                    candidates &= candidates - 1;
                    let rays = packet.rays_entering::<L, GENERAL>(node, lane, active);
                    if C::ENABLED {
                        for r in bits(active) {
                            counters[r].box_tests(1);
                        }
                    }
                    if rays != 0 {
                        if let Some(entry) = next.replace((node.children[lane], rays)) {
                            stack.push(entry);
                        }
                    }
                }
                if let Some(entry) = next {
                    current = entry;
                    continue;
                }
            }
            Child::Leaf { first, count } => {
                for block in &bvh.primitives[first as usize..(first + count) as usize] {
                    let mut shared = I::share::<f32x4>(block, packet.origin);
                    for r in bits(active & !blocked) {
                        if C::ENABLED {
                            counters[r].triangle_tests(block.count());
                        }
                        let ray = &packet.rays[r];
                        if GENERAL && !packet.shared_origin {
                            shared = I::share::<f32x4>(block, ray.origin);
                        }
                        let t_max = packet.t_max[r];
                        if I::test::<f32x4>(block, &shared, ray, &per_ray[r], t_max).is_some() {
                            blocked |= 1 << r;
                            occluded[r] = true;
                        }
                    }
                }
                if blocked == packet.all() {
                    return;
                }
            }
            Child::Empty => {}
        }
        match stack.pop() {
            Some(next) => current = next,
            None => return,
        }
    }
}

/// Test one leaf block for one ray with intersector `I`; record a closer hit.
#[inline(always)]
pub(crate) fn block_closest<I: Intersector>(
    block: &Triangle4,
    query: &RayQuery,
    hit: &mut Hit,
) -> bool {
    let ray = basic(query);
    let shared = I::share::<f32x4>(block, ray.origin);
    let found = I::test::<f32x4>(block, &shared, &ray, &I::prepare(&ray), hit.t);
    match found.and_then(|f| f.nearest()) {
        Some((lane, t, u, v)) => {
            hit.t = t;
            hit.u = u;
            hit.v = v;
            hit.triangle = block.ids[lane];
            true
        }
        None => false,
    }
}

/// Whether one leaf block blocks one ray before `t_max`, with intersector `I`.
#[inline(always)]
pub(crate) fn block_occludes<I: Intersector>(
    block: &Triangle4,
    query: &RayQuery,
    t_max: f32,
) -> bool {
    let ray = basic(query);
    let shared = I::share::<f32x4>(block, ray.origin);
    I::test::<f32x4>(block, &shared, &ray, &I::prepare(&ray), t_max).is_some()
}

/// What the intersectors read of a prepared single ray. (Their per-ray terms are
/// recomputed per leaf block on this path, which costs only the watertight test.)
#[inline(always)]
fn basic(query: &RayQuery) -> BasicRay {
    BasicRay {
        origin: query.origin,
        direction: query.direction,
        t_min: query.t_min,
    }
}

/// Closest hits of up to 64 rays through `bvh` (a scene of one untransformed mesh),
/// traced as a packet with intersector `I`: the traversal of this file on the lanes of
/// the CPU's instruction set.
pub(crate) fn closest<I: Intersector, C: Counters>(
    bvh: &Bvh<Triangle4>,
    buffer: &mut PacketBuffer,
    rays: &[Ray],
    hits: &mut [Hit],
    counters: &mut [C],
) {
    for (hit, ray) in hits.iter_mut().zip(rays) {
        *hit = Hit::MISS;
        hit.t = ray.t_max;
    }
    dispatch(ClosestPacket::<I, C> {
        bvh,
        packet: &mut buffer.0,
        rays,
        hits,
        counters,
        intersector: std::marker::PhantomData,
    });
    for hit in hits.iter_mut() {
        if !hit.is_hit() {
            hit.t = f32::INFINITY;
        }
    }
}

/// Occlusion of up to 64 rays through `bvh`, as [`closest`].
pub(crate) fn occluded<I: Intersector, C: Counters>(
    bvh: &Bvh<Triangle4>,
    buffer: &mut PacketBuffer,
    rays: &[Ray],
    occluded: &mut [bool],
    counters: &mut [C],
) {
    occluded.fill(false);
    dispatch(OccludedPacket::<I, C> {
        bvh,
        packet: &mut buffer.0,
        rays,
        occluded,
        counters,
        intersector: std::marker::PhantomData,
    });
}

/// [`closest_with`] as a [`Kernel`].
struct ClosestPacket<'a, I, C> {
    bvh: &'a Bvh<Triangle4>,
    packet: &'a mut Packet,
    rays: &'a [Ray],
    hits: &'a mut [Hit],
    counters: &'a mut [C],
    intersector: std::marker::PhantomData<I>,
}

impl<I: Intersector, C: Counters> Kernel for ClosestPacket<'_, I, C> {
    type Output = ();
    #[inline(always)]
    fn run<S: Isa>(self) {
        closest_with::<S::Lanes8, I, C>(self.bvh, self.packet, self.rays, self.hits, self.counters)
    }
}

/// [`occluded_with`] as a [`Kernel`].
struct OccludedPacket<'a, I, C> {
    bvh: &'a Bvh<Triangle4>,
    packet: &'a mut Packet,
    rays: &'a [Ray],
    occluded: &'a mut [bool],
    counters: &'a mut [C],
    intersector: std::marker::PhantomData<I>,
}

impl<I: Intersector, C: Counters> Kernel for OccludedPacket<'_, I, C> {
    type Output = ();
    #[inline(always)]
    fn run<S: Isa>(self) {
        occluded_with::<S::Lanes8, I, C>(
            self.bvh,
            self.packet,
            self.rays,
            self.occluded,
            self.counters,
        )
    }
}

/// Fill `packet` with `rays` and trace closest hits with 8 lanes `L`, in the general
/// form when origins differ or direction signs are mixed.
#[inline(always)]
fn closest_with<L: Lanes, I: Intersector, C: Counters>(
    bvh: &Bvh<Triangle4>,
    packet: &mut Packet,
    rays: &[Ray],
    hits: &mut [Hit],
    counters: &mut [C],
) {
    packet.fill::<L>(rays);
    if packet.mixed_signs || !packet.shared_origin {
        closest_in_bvh::<L, I, C, true>(bvh, packet, hits, counters)
    } else {
        closest_in_bvh::<L, I, C, false>(bvh, packet, hits, counters)
    }
}

/// Fill `packet` with `rays` and trace occlusion with 8 lanes `L`.
#[inline(always)]
fn occluded_with<L: Lanes, I: Intersector, C: Counters>(
    bvh: &Bvh<Triangle4>,
    packet: &mut Packet,
    rays: &[Ray],
    occluded: &mut [bool],
    counters: &mut [C],
) {
    packet.fill::<L>(rays);
    if packet.mixed_signs || !packet.shared_origin {
        occluded_in_bvh::<L, I, C, true>(bvh, packet, occluded, counters)
    } else {
        occluded_in_bvh::<L, I, C, false>(bvh, packet, occluded, counters)
    }
}

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
//! met. Packets whose rays do not share an origin, or whose directions differ in sign
//! on some axis (the frustum needs one near plane per axis), and scenes with a top
//! level, are traced ray by ray.

use super::intersect::{Intersector, MAX_PACKET_RAYS};
use super::lanes::Lanes;
use super::traverse::Stack;
use super::triangle::Triangle4;
use super::{Counters, Hit, RayQuery, SceneAccel};
use crate::bvh::{Bvh, BvhNode, Child, EMPTY_CHILD, WIDTH};
use crate::geom::Ray;
use glam::Vec3;
use wide::f32x4;

/// Rays of one packet, structure of arrays, room for 64 rays.
struct Packet {
    origin: Vec3,
    len: usize,
    queries: [RayQuery; MAX_PACKET_RAYS],
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
        let query = RayQuery::new(&Ray::new(Vec3::ZERO, Vec3::ONE));
        Self(Box::new(Packet {
            origin: Vec3::ZERO,
            len: 0,
            queries: [query; MAX_PACKET_RAYS],
            inverse: [[0.0; MAX_PACKET_RAYS]; 3],
            inverse_far: [[0.0; MAX_PACKET_RAYS]; 3],
            t_min: [0.0; MAX_PACKET_RAYS],
            t_max: [0.0; MAX_PACKET_RAYS],
            near_plane: query.near_plane,
            far_plane: query.far_plane,
            inverse_range: [(0.0, 0.0); 3],
            inverse_far_range: [(0.0, 0.0); 3],
            lowest_t_min: 0.0,
        }))
    }
}

impl Packet {
    /// Prepare `rays` (1 to 64); false when they do not share an origin or their
    /// direction signs differ on some axis. Slots past `rays.len()` keep stale values,
    /// which the ray masks never read.
    #[inline(always)]
    fn fill(&mut self, rays: &[Ray]) -> bool {
        let Some(first) = rays.first() else {
            return false;
        };
        if rays.len() > MAX_PACKET_RAYS || rays.iter().any(|r| r.origin != first.origin) {
            return false;
        }
        self.origin = first.origin;
        self.len = rays.len();
        self.inverse_range = [(f32::INFINITY, f32::NEG_INFINITY); 3];
        self.inverse_far_range = [(f32::INFINITY, f32::NEG_INFINITY); 3];
        self.lowest_t_min = f32::INFINITY;
        for (r, ray) in rays.iter().enumerate() {
            self.queries[r] = RayQuery::new(ray);
            let query = &self.queries[r];
            if r == 0 {
                self.near_plane = query.near_plane;
                self.far_plane = query.far_plane;
            } else if query.near_plane != self.near_plane {
                return false;
            }
            for axis in 0..3 {
                let (i, f) = (
                    query.inverse_direction[axis],
                    query.inverse_direction_far[axis],
                );
                self.inverse[axis][r] = i;
                self.inverse_far[axis][r] = f;
                let range = &mut self.inverse_range[axis];
                *range = (range.0.min(i), range.1.max(i));
                let range = &mut self.inverse_far_range[axis];
                *range = (range.0.min(f), range.1.max(f));
            }
            self.t_min[r] = ray.t_min;
            self.t_max[r] = ray.t_max;
            self.lowest_t_min = self.lowest_t_min.min(ray.t_min);
        }
        true
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
    /// some ray of the packet may enter.
    #[inline(always)]
    fn frustum<L: Lanes>(&self, node: &BvhNode) -> ([f32; 8], u32) {
        let mut near = L::splat(self.lowest_t_min);
        let mut far = L::splat(f32::INFINITY);
        for axis in 0..3 {
            let o = L::splat(self.origin[axis]);
            let to_near = L::load(&node.planes[self.near_plane[axis]]) - o;
            let (low, high) = self.inverse_range[axis];
            near = near.max((to_near * L::splat(low)).min(to_near * L::splat(high)));
            let to_far = L::load(&node.planes[self.far_plane[axis]]) - o;
            let (low, high) = self.inverse_far_range[axis];
            far = far.min((to_far * L::splat(low)).max(to_far * L::splat(high)));
        }
        (near.to_array(), L::bitmask(L::le(near, far)))
    }

    /// The rays of `active` whose single-ray slab test enters child `lane` of `node`
    /// before their current closest hit, eight rays per SIMD test.
    #[inline(always)]
    fn rays_entering<L: Lanes>(&self, node: &BvhNode, lane: usize, active: u64) -> u64 {
        let to_near = [0, 1, 2].map(|a| node.planes[self.near_plane[a]][lane] - self.origin[a]);
        let to_far = [0, 1, 2].map(|a| node.planes[self.far_plane[a]][lane] - self.origin[a]);
        let mut entering = 0u64;
        let mut groups = active;
        while groups != 0 {
            let base = (groups.trailing_zeros() as usize) & !7;
            let mut near = L::load(&self.t_min[base..]);
            let mut far = L::load(&self.t_max[base..]);
            for axis in 0..3 {
                near = near.max(L::splat(to_near[axis]) * L::load(&self.inverse[axis][base..]));
                far = far.min(L::splat(to_far[axis]) * L::load(&self.inverse_far[axis][base..]));
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
fn closest_in_bvh<L: Lanes, I: Intersector, C: Counters>(
    bvh: &Bvh<Triangle4>,
    packet: &mut Packet,
    hits: &mut [Hit],
    counters: &mut [C],
) {
    let mut stack = Stack::<(u32, u64)>::new();
    let mut current = (bvh.root, packet.all());
    loop {
        let (reference, active) = current;
        match Child::decode(reference) {
            Child::Inner(index) => {
                let node = &bvh.nodes[index as usize];
                count_frustum(node, active, counters);
                let (near, mut candidates) = packet.frustum::<L>(node);
                // Entered children sorted by frustum entry distance, nearest last.
                let mut entered = [(0u32, 0u64, 0.0f32); WIDTH];
                let mut n = 0;
                while candidates != 0 {
                    let lane = candidates.trailing_zeros() as usize;
                    candidates &= candidates - 1;
                    let rays = packet.rays_entering::<L>(node, lane, active);
                    if C::ENABLED {
                        for r in bits(active) {
                            counters[r].box_tests(1);
                        }
                    }
                    if rays == 0 {
                        continue;
                    }
                    let entry = (node.children[lane], rays, near[lane]);
                    let mut j = n;
                    while j > 0 && entered[j - 1].2 < entry.2 {
                        entered[j] = entered[j - 1];
                        j -= 1;
                    }
                    entered[j] = entry;
                    n += 1;
                }
                if n > 0 {
                    for &(child, rays, _) in &entered[..n - 1] {
                        stack.push((child, rays));
                    }
                    current = (entered[n - 1].0, entered[n - 1].1);
                    continue;
                }
            }
            Child::Leaf { first, count } => {
                for block in &bvh.primitives[first as usize..(first + count) as usize] {
                    let shared = I::share::<f32x4>(block, packet.origin);
                    for r in bits(active) {
                        if C::ENABLED {
                            counters[r].triangle_tests(block.count);
                        }
                        let found = I::test::<f32x4>(block, &shared, &packet.queries[r], hits[r].t);
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
                        }
                    }
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

/// Occlusion of a packet in one BVH: sets `occluded[r]` for every blocked ray.
#[inline(always)]
fn occluded_in_bvh<L: Lanes, I: Intersector, C: Counters>(
    bvh: &Bvh<Triangle4>,
    packet: &mut Packet,
    occluded: &mut [bool],
    counters: &mut [C],
) {
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
                let (_, mut candidates) = packet.frustum::<L>(node);
                let mut next = None;
                while candidates != 0 {
                    let lane = candidates.trailing_zeros() as usize;
                    candidates &= candidates - 1;
                    let rays = packet.rays_entering::<L>(node, lane, active);
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
                    let shared = I::share::<f32x4>(block, packet.origin);
                    for r in bits(active & !blocked) {
                        if C::ENABLED {
                            counters[r].triangle_tests(block.count);
                        }
                        let query = &packet.queries[r];
                        if I::test::<f32x4>(block, &shared, query, packet.t_max[r]).is_some() {
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
fn block_closest<I: Intersector>(block: &Triangle4, query: &RayQuery, hit: &mut Hit) -> bool {
    let shared = I::share::<f32x4>(block, query.origin);
    match I::test::<f32x4>(block, &shared, query, hit.t).and_then(|f| f.nearest()) {
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
fn block_occludes<I: Intersector>(block: &Triangle4, query: &RayQuery, t_max: f32) -> bool {
    let shared = I::share::<f32x4>(block, query.origin);
    I::test::<f32x4>(block, &shared, query, t_max).is_some()
}

impl SceneAccel<Triangle4> {
    /// Closest hit of one ray with intersector `I` in the leaves (single-ray
    /// traversal: the reference for [`Self::intersect_packet`]).
    pub fn intersect_by<I: Intersector, C: Counters>(&self, ray: &Ray, counters: &mut C) -> Hit {
        self.intersect_dispatched(ray, counters, block_closest::<I>)
    }

    /// Whether anything blocks one ray, with intersector `I` in the leaves.
    pub fn occluded_by<I: Intersector, C: Counters>(&self, ray: &Ray, counters: &mut C) -> bool {
        self.occluded_dispatched(ray, counters, block_occludes::<I>)
    }

    /// Closest hits of up to 64 rays with one origin, traced as a packet with
    /// intersector `I` (ray by ray where a packet cannot be formed; see the module
    /// notes). `hits` and `counters` have one entry per ray.
    pub fn intersect_packet<I: Intersector, C: Counters>(
        &self,
        buffer: &mut PacketBuffer,
        rays: &[Ray],
        hits: &mut [Hit],
        counters: &mut [C],
    ) {
        assert!(hits.len() == rays.len() && counters.len() == rays.len());
        let packet = &mut *buffer.0;
        let (None, Some(bvh), true) = (&self.tlas, self.blas.first(), packet.fill(rays)) else {
            for ((ray, hit), counter) in rays.iter().zip(hits.iter_mut()).zip(counters) {
                *hit = self.intersect_by::<I, C>(ray, counter);
            }
            return;
        };
        for (hit, ray) in hits.iter_mut().zip(rays) {
            *hit = Hit::MISS;
            hit.t = ray.t_max;
        }
        #[cfg(target_arch = "x86_64")]
        if super::lanes::has_avx() {
            // SAFETY: the CPU has AVX.
            unsafe { closest_avx::<I, C>(bvh, packet, hits, counters) };
        } else {
            closest_in_bvh::<wide::f32x8, I, C>(bvh, packet, hits, counters);
        }
        #[cfg(not(target_arch = "x86_64"))]
        closest_in_bvh::<wide::f32x8, I, C>(bvh, packet, hits, counters);
        for hit in hits.iter_mut() {
            if !hit.is_hit() {
                hit.t = f32::INFINITY;
            }
        }
    }

    /// Occlusion of up to 64 rays with one origin (shadow rays from one hit point),
    /// traced as a packet with intersector `I`.
    pub fn occluded_packet<I: Intersector, C: Counters>(
        &self,
        buffer: &mut PacketBuffer,
        rays: &[Ray],
        occluded: &mut [bool],
        counters: &mut [C],
    ) {
        assert!(occluded.len() == rays.len() && counters.len() == rays.len());
        let packet = &mut *buffer.0;
        let (None, Some(bvh), true) = (&self.tlas, self.blas.first(), packet.fill(rays)) else {
            for ((ray, blocked), counter) in rays.iter().zip(occluded.iter_mut()).zip(counters) {
                *blocked = self.occluded_by::<I, C>(ray, counter);
            }
            return;
        };
        occluded.fill(false);
        #[cfg(target_arch = "x86_64")]
        if super::lanes::has_avx() {
            // SAFETY: the CPU has AVX.
            unsafe { occluded_avx::<I, C>(bvh, packet, occluded, counters) };
            return;
        }
        occluded_in_bvh::<wide::f32x8, I, C>(bvh, packet, occluded, counters);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn closest_avx<I: Intersector, C: Counters>(
    bvh: &Bvh<Triangle4>,
    packet: &mut Packet,
    hits: &mut [Hit],
    counters: &mut [C],
) {
    closest_in_bvh::<super::lanes::Avx8, I, C>(bvh, packet, hits, counters)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn occluded_avx<I: Intersector, C: Counters>(
    bvh: &Bvh<Triangle4>,
    packet: &mut Packet,
    occluded: &mut [bool],
    counters: &mut [C],
) {
    occluded_in_bvh::<super::lanes::Avx8, I, C>(bvh, packet, occluded, counters)
}

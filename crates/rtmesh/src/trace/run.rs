//! Runners: trace a list of rays, one at a time or in packets, on every thread of the
//! current rayon pool, with per-ray counters.

use super::intersect::Intersector;
use super::packet::PacketBuffer;
use super::{Counters, Hit, SceneAccel, Tracer, TILE};
use crate::geom::Ray;
use rayon::prelude::*;

/// Rays per parallel work item (one tile).
const CHUNK: usize = TILE * TILE;

/// Run `trace` on every ray on the current rayon pool, a tile (64 rays) per work item;
/// returns the outcomes and per-ray counters (zero-sized and free for [`NoCounters`](super::NoCounters)).
pub(crate) fn trace_each<C: Counters + Copy, R: Copy + Send>(
    rays: &[Ray],
    nothing: R,
    trace: impl Fn(&Ray, &mut C) -> R + Sync,
) -> (Vec<R>, Vec<C>) {
    let mut outcomes = vec![nothing; rays.len()];
    let mut counters = vec![C::default(); rays.len()];
    rays.par_chunks(CHUNK)
        .zip(outcomes.par_chunks_mut(CHUNK))
        .zip(counters.par_chunks_mut(CHUNK))
        .for_each(|((rays, outcomes), counters)| {
            for ((ray, outcome), counter) in rays.iter().zip(outcomes).zip(counters) {
                *outcome = trace(ray, counter);
            }
        });
    (outcomes, counters)
}

/// Closest hits of `rays` on the current rayon pool, with per-ray counters.
pub fn trace_closest<C: Counters + Copy>(tracer: &impl Tracer, rays: &[Ray]) -> (Vec<Hit>, Vec<C>) {
    trace_each(rays, Hit::MISS, |ray, counters| {
        tracer.intersect(ray, counters)
    })
}

/// Occlusion of `rays` on the current rayon pool, with per-ray counters.
pub fn trace_occluded<C: Counters + Copy>(
    tracer: &impl Tracer,
    rays: &[Ray],
) -> (Vec<bool>, Vec<C>) {
    trace_each(rays, false, |ray, counters| tracer.occluded(ray, counters))
}

/// One parallel work item of packets: its rays, the packet sizes, and the per-ray
/// outputs and counters.
type PacketItem<'a, R, C> = (&'a [Ray], Vec<usize>, &'a mut [R], &'a mut [C]);

/// Split `rays` and per-ray outputs into work items of whole packets (`starts` as
/// from [`Workload::primary_packets`](super::Workload::primary_packets)), about 64 rays each.
fn packet_items<'a, R, C>(
    rays: &'a [Ray],
    starts: &[u32],
    mut outcomes: &'a mut [R],
    mut counters: &'a mut [C],
) -> Vec<PacketItem<'a, R, C>> {
    let mut items = Vec::new();
    let mut k = 0;
    while k + 1 < starts.len() {
        let begin = starts[k] as usize;
        let mut sizes = Vec::new();
        while k + 1 < starts.len() && (sizes.is_empty() || starts[k] as usize - begin < CHUNK) {
            sizes.push((starts[k + 1] - starts[k]) as usize);
            k += 1;
        }
        let end = starts[k] as usize;
        let (head, tail) = std::mem::take(&mut outcomes).split_at_mut(end - begin);
        outcomes = tail;
        let (counted, rest) = std::mem::take(&mut counters).split_at_mut(end - begin);
        counters = rest;
        items.push((&rays[begin..end], sizes, head, counted));
    }
    items
}

/// Run `trace(buffer, rays, outcomes, counters)` on every packet (`starts` as from
/// [`Workload::grouped`](super::Workload::grouped)) on the current rayon pool, one packet buffer per work item.
fn trace_packets<R: Copy + Send, C: Counters + Copy>(
    rays: &[Ray],
    starts: &[u32],
    nothing: R,
    trace: impl Fn(&mut PacketBuffer, &[Ray], &mut [R], &mut [C]) + Sync,
) -> (Vec<R>, Vec<C>) {
    let mut outcomes = vec![nothing; rays.len()];
    let mut counters = vec![C::default(); rays.len()];
    packet_items(rays, starts, &mut outcomes, &mut counters)
        .into_par_iter()
        .for_each_init(
            PacketBuffer::default,
            |buffer, (rays, sizes, outcomes, counters)| {
                let mut at = 0;
                for size in sizes {
                    let range = at..at + size;
                    trace(
                        buffer,
                        &rays[range.clone()],
                        &mut outcomes[range.clone()],
                        &mut counters[range],
                    );
                    at += size;
                }
            },
        );
    (outcomes, counters)
}

/// Closest hits of packets of rays (`starts` as from [`Workload::grouped`](super::Workload::grouped)) with
/// packet traversal and intersector `I`, on the current rayon pool, with per-ray
/// counters.
pub fn trace_packets_closest<I: Intersector, C: Counters + Copy>(
    accel: &SceneAccel,
    rays: &[Ray],
    starts: &[u32],
) -> (Vec<Hit>, Vec<C>) {
    trace_packets(rays, starts, Hit::MISS, |buffer, rays, hits, counters| {
        accel.intersect_packet::<I, C>(buffer, rays, hits, counters)
    })
}

/// Occlusion of packets of rays (`starts` as from [`Workload::grouped`](super::Workload::grouped)) with packet
/// traversal and intersector `I`, on the current rayon pool, with per-ray counters.
pub fn trace_packets_occluded<I: Intersector, C: Counters + Copy>(
    accel: &SceneAccel,
    rays: &[Ray],
    starts: &[u32],
) -> (Vec<bool>, Vec<C>) {
    trace_packets(rays, starts, false, |buffer, rays, occluded, counters| {
        accel.occluded_packet::<I, C>(buffer, rays, occluded, counters)
    })
}

/// Closest hits of `rays` one at a time with intersector `I`, on the current rayon
/// pool, with per-ray counters (the reference for [`trace_packets_closest`]).
pub fn trace_closest_by<I: Intersector, C: Counters + Copy>(
    accel: &SceneAccel,
    rays: &[Ray],
) -> (Vec<Hit>, Vec<C>) {
    trace_each(rays, Hit::MISS, |ray, counters| {
        accel.intersect_by::<I, C>(ray, counters)
    })
}

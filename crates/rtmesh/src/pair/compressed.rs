//! Greedy pairing on position-only input with compressed 16-byte edge keys (Aman &
//! Fenney, "Fast Triangle Pairing for Ray Tracing", Imagination, HPG 2024, §"edge key
//! compression").
//!
//! Without shared vertex indices an edge is known by where it is: its key is its box
//! surface area and its midpoint, each quantised to 24 bits, and the record adds the
//! 32-bit half-edge id: 16 bytes. The BBSA keeps its float order by taking the top 24
//! bits of its (positive) IEEE bits, a relative precision of 2⁻¹⁵; midpoints are
//! quantised linearly in the mesh's box. The table is sorted descending by
//! [BBSA, midpoint] with a radix sort (a most-significant-digit pass into buckets that
//! fit the cache, then 8-bit passes within each; see [`crate::radix`]) and scanned as
//! in [`super::greedy`].
//!
//! Quantisation can give two different edges one key. A scan that paired them would
//! pair triangles that do not touch, so a candidate pair must also share the edge's two
//! corner positions exactly, in opposite directions; the published procedure takes
//! the key on trust. Cost: O(T) time, 16 bytes per half-edge twice.

use super::{ActiveTriangles, Pairing, UNPAIRED};
use crate::mesh::TriMesh;
use crate::radix::sort_u128_by_bits;
use glam::Vec3;

/// Bits per quantised key field.
const FIELD_BITS: u32 = 24;

/// Greedy pairing keyed by position: vertex indices are used only to read corners.
pub fn pair_sah_compressed(mesh: &TriMesh) -> Pairing {
    let active = ActiveTriangles::new(mesh);
    let n = mesh.triangle_count();
    let bounds = (0..n)
        .filter(|&t| active.get(t))
        .fold(crate::geom::Aabb::EMPTY, |b, t| {
            b.union(super::triangle_box(mesh, t))
        });
    let field_max = ((1u32 << FIELD_BITS) - 1) as f32;
    let scale = Vec3::splat(field_max) / bounds.extent().max(Vec3::splat(f32::MIN_POSITIVE));
    // Nearest step, by truncating `x + 0.5` (`f32::round` is a library call on
    // baseline x86-64); NaN lands on 0.
    let quantise = |x: f32, axis: usize| {
        (((x - bounds.min[axis]) * scale[axis]).clamp(0.0, field_max) + 0.5) as u32 as u128
    };
    let mut records: Vec<u128> = Vec::with_capacity(3 * n);
    for t in 0..n {
        if !active.get(t) {
            continue;
        }
        let corners = mesh.corners(t);
        for k in 0..3 {
            let (p, q) = (corners[k], corners[(k + 1) % 3]);
            let bbsa = super::edge_bbsa(p, q); // symmetric in p and q
            let mid = (p + q) * 0.5;
            let key = (bbsa.to_bits() >> (31 - FIELD_BITS)) as u128;
            let key = (key << FIELD_BITS) | quantise(mid.x, 0);
            let key = (key << FIELD_BITS) | quantise(mid.y, 1);
            let key = (key << FIELD_BITS) | quantise(mid.z, 2);
            records.push(key << 32 | (3 * t + k) as u128);
        }
    }
    sort_u128_by_bits(&mut records, 32, 128);
    let corner = |h: u32, offset: u32| {
        let t = (h / 3) as usize;
        mesh.positions[mesh.triangles[t][((h + offset) % 3) as usize] as usize]
    };
    let mut partner = vec![UNPAIRED; n];
    // Walk runs of equal keys from the largest; within a run, in table order.
    let mut end = records.len();
    while end > 0 {
        let key = records[end - 1] >> 32;
        let mut start = end - 1;
        while start > 0 && records[start - 1] >> 32 == key {
            start -= 1;
        }
        for w in records[start..end].windows(2) {
            let (ha, hb) = (w[0] as u32, w[1] as u32);
            let (a, b) = ((ha / 3) as usize, (hb / 3) as usize);
            // Half-edge h of triangle t runs from corner h % 3 to the next.
            if a != b
                && partner[a] == UNPAIRED
                && partner[b] == UNPAIRED
                && corner(ha, 0) == corner(hb, 1)
                && corner(ha, 1) == corner(hb, 0)
            {
                partner[a] = b as u32;
                partner[b] = a as u32;
            }
        }
        end = start;
    }
    Pairing::from_partners(&partner)
}

//! Iterative growing of precomputed triangle clusters (Garanzha, EGSR 2009; the
//! acceptance heuristic Acc(k) is in the module header of `cluster`): a cluster starts
//! at the first triangle not yet taken, in Morton order over the centroids so that
//! clusters tile the surface, and takes, one at a time, the neighbour across an edge
//! whose Acc of the grown set is largest, while it is positive. The slides prefer it to
//! contraction for its memory: one growing set and its frontier at a time.
//!
//! Cost: O(T · F · |k|) for F candidates on a cluster's frontier (tens) and |k| the
//! cluster's size (Acc(k ∪ t) walks k's vertices and normals).

use super::{
    edge_neighbours, farthest, finish, morton_order, prepare, widest, AcceptanceScale,
    ClusterSettings, Clusters, Set, Summary, Union,
};
use crate::mesh::TriMesh;
use glam::Vec3;

/// Triangle `t` as a one-triangle [`Summary`], its distinct vertices and their
/// positions kept in `distinct`.
fn one_triangle<'a>(
    mesh: &TriMesh,
    t: usize,
    normal: &'a Vec3,
    area: f32,
    distinct: &'a mut ([u32; 3], [Vec3; 3]),
) -> Summary<'a> {
    let mut count = 0;
    let mut vertex_sum = Vec3::ZERO;
    for v in mesh.triangles[t] {
        if !distinct.0[..count].contains(&v) {
            let p = mesh.positions[v as usize];
            distinct.0[count] = v;
            distinct.1[count] = p;
            count += 1;
            vertex_sum += p;
        }
    }
    Summary {
        vertices: &distinct.0[..count],
        points: &distinct.1[..count],
        vertex_sum,
        normals: std::slice::from_ref(normal),
        normal_sum: *normal * area.max(f32::MIN_POSITIVE),
        area,
        triangles: 1,
    }
}

/// Adding one triangle to the growing set: the union's figures, and the triangle's
/// own share of the two reductions.
struct Growth {
    triangle: u32,
    union: Union,
    /// [`farthest`] over the triangle's corners.
    far: f32,
    /// [`widest`] over its normal.
    wide: f32,
}

impl Growth {
    /// Adding `triangle` (its one-triangle summary `t`) to `k`, or `None` past a hard
    /// limit; `in_k` tells a vertex of `k`.
    fn of(
        k: &Set,
        triangle: u32,
        t: Summary,
        scale: &AcceptanceScale,
        in_k: impl Fn(u32) -> bool,
    ) -> Option<Self> {
        let union = Union::of(k.summary(), t, scale, in_k)?;
        Some(Self {
            triangle,
            far: farthest(t.points, union.centre),
            wide: widest(t.normals, union.mean),
            union,
        })
    }
}

/// Candidates a pass over the growing set's points and normals serves at once.
const LANES: usize = 8;

/// The candidate of largest positive Acc(k ∪ t) (the smallest triangle id among
/// equals). The reductions over k's points and normals, O(|k|) a candidate and most of
/// the growing's time, run for [`LANES`] candidates in one pass, the candidates across
/// the lanes of fixed-size arrays that the compiler vectorizes; each lane computes
/// exactly what [`farthest`] and [`widest`] compute, so the result is [`acceptance`]'s.
///
/// [`acceptance`]: super::acceptance
fn best_growth(k: &Set, candidates: &[Growth], scale: &AcceptanceScale) -> Option<u32> {
    let mut best: Option<(f32, u32)> = None;
    for chunk in candidates.chunks(LANES) {
        let mut centre = [[0.0f32; LANES]; 3];
        let mut mean = [[0.0f32; LANES]; 3];
        for (lane, g) in chunk.iter().enumerate() {
            for axis in 0..3 {
                centre[axis][lane] = g.union.centre[axis];
                mean[axis][lane] = g.union.mean[axis];
            }
        }
        let mut far = [0.0f32; LANES];
        for p in &k.points {
            for lane in 0..LANES {
                let (dx, dy, dz) = (
                    p.x - centre[0][lane],
                    p.y - centre[1][lane],
                    p.z - centre[2][lane],
                );
                far[lane] = far[lane].max(dx * dx + dy * dy + dz * dz);
            }
        }
        let mut wide = [1.0f32; LANES];
        for n in &k.normals {
            for lane in 0..LANES {
                wide[lane] =
                    wide[lane].min(n.x * mean[0][lane] + n.y * mean[1][lane] + n.z * mean[2][lane]);
            }
        }
        for (lane, g) in chunk.iter().enumerate() {
            let acc = g
                .union
                .acceptance(far[lane].max(g.far), wide[lane].min(g.wide), scale);
            let better = |(b, t): (f32, u32)| acc.total_cmp(&b).then(t.cmp(&g.triangle)).is_gt();
            if acc > 0.0 && best.is_none_or(better) {
                best = Some((acc, g.triangle));
            }
        }
    }
    best.map(|(_, t)| t)
}

/// Iterative growing (module header): clusters of `mesh`'s triangles, every triangle in
/// exactly one, each connected through shared edges (by position) except that a
/// degenerate or isolated triangle may make a cluster of its own.
pub fn grow(mesh: &TriMesh, settings: &ClusterSettings) -> Clusters {
    let n = mesh.triangle_count();
    let (adjacency, shape, scale, mut marks) = prepare(mesh, settings);
    let mut taken = vec![false; n];
    let mut frontier: Vec<u32> = Vec::new();
    let mut candidates: Vec<Growth> = Vec::new();
    let mut groups: Vec<Vec<u32>> = Vec::new();
    for seed in morton_order(mesh) {
        if taken[seed as usize] {
            continue;
        }
        let mut k = Set::default();
        // The marks hold k's vertices while it grows.
        marks.mark(&[]);
        frontier.clear();
        let mut next = Some(seed);
        while let Some(t) = next {
            let tu = t as usize;
            taken[tu] = true;
            k.add(mesh, t, shape[tu]);
            marks.mark_also(&mesh.triangles[tu]);
            for u in edge_neighbours(&adjacency, tu) {
                if !taken[u as usize] && !frontier.contains(&u) {
                    frontier.push(u);
                }
            }
            frontier.retain(|&u| !taken[u as usize]);
            // The neighbour whose addition keeps Acc highest, if it stays positive.
            candidates.clear();
            for &u in &frontier {
                let (normal, area) = &shape[u as usize];
                if *area == 0.0 {
                    continue;
                }
                let mut distinct = ([0u32; 3], [Vec3::ZERO; 3]);
                let candidate = one_triangle(mesh, u as usize, normal, *area, &mut distinct);
                candidates.extend(Growth::of(&k, u, candidate, &scale, |v| marks.is_marked(v)));
            }
            next = best_growth(&k, &candidates, &scale);
        }
        groups.push(k.triangles);
    }
    finish(mesh, &adjacency, groups, settings)
}

#[cfg(test)]
mod tests {
    use super::super::{acceptance, normal_and_area, Marks};
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The lane-wise pick is the scalar Acc's pick: the same triangle, or none.
        #[test]
        fn best_growth_picks_what_scalar_acceptance_picks(
            jitter in proptest::collection::vec(-0.15f32..0.15, 3 * 121),
            in_k in 1usize..24,
            offered in 1usize..40,
            max_size in 1.0f32..8.0,
        ) {
            let mut mesh = crate::scenes::quad_grid(10);
            for (p, d) in mesh.positions.iter_mut().zip(jitter.chunks(3)) {
                *p += Vec3::new(d[0], d[1], d[2]);
            }
            let settings = ClusterSettings { max_size, ..ClusterSettings::default() };
            let shape: Vec<(Vec3, f32)> =
                (0..mesh.triangle_count()).map(|t| normal_and_area(&mesh, t)).collect();
            let scale = AcceptanceScale::new(&settings, &shape);
            let mut marks = Marks::new(mesh.positions.len());
            let mut k = Set::default();
            for t in 0..in_k as u32 {
                k.add(&mesh, t, shape[t as usize]);
            }
            marks.mark(&k.vertices);
            let offered: Vec<u32> = (in_k as u32..mesh.triangle_count() as u32).take(offered).collect();
            let mut growths = Vec::new();
            let mut scalar: Option<(f32, u32)> = None;
            for &u in offered.iter().rev() {
                let (normal, area) = &shape[u as usize];
                let mut distinct = ([0u32; 3], [Vec3::ZERO; 3]);
                let b = one_triangle(&mesh, u as usize, normal, *area, &mut distinct);
                if let Some(acc) = acceptance(k.summary(), b, &scale, |v| marks.is_marked(v)) {
                    if acc > 0.0 && scalar.is_none_or(|(s, _)| acc >= s) {
                        scalar = Some((acc, u));
                    }
                }
                growths.extend(Growth::of(&k, u, b, &scale, |v| marks.is_marked(v)));
            }
            prop_assert_eq!(best_growth(&k, &growths, &scale), scalar.map(|(_, u)| u));
        }
    }
}

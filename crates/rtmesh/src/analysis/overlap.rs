//! Instances whose world boxes overlap by half or more: candidates for merging into one
//! geometry. Sort and sweep, O(n log n + the pairs that overlap on the sweep axis).

use crate::geom::Aabb;
use crate::mesh::{Scene, TriMesh};

/// Pairs of instances `(a, b, overlap)`, `a < b`, in order, whose world boxes overlap
/// by half or more: `overlap` = half-area of the boxes' intersection over the smaller
/// box's. Sort and sweep: the boxes sorted along the axis where their centres spread
/// most, each compared with those that start before it ends on that axis. O(n log n +
/// the pairs that overlap on that axis).
pub fn overlapping_instances(scene: &Scene) -> Vec<(usize, usize, f32)> {
    let mesh_bounds: Vec<Aabb> = scene.meshes.iter().map(TriMesh::bounds).collect();
    let boxes: Vec<Aabb> = scene
        .instances
        .iter()
        .map(|i| mesh_bounds[i.mesh].transformed(&i.transform))
        .collect();
    // A mesh with no finite corner has an empty box, which overlaps nothing.
    let mut order: Vec<usize> = (0..boxes.len()).filter(|&i| !boxes[i].is_empty()).collect();
    let centres = order
        .iter()
        .fold(Aabb::EMPTY, |c, &i| c.grown_by_point(boxes[i].center()));
    let axis = centres.extent().max_position();
    order.sort_unstable_by(|&a, &b| boxes[a].min[axis].total_cmp(&boxes[b].min[axis]));
    let mut pairs = Vec::new();
    for (k, &a) in order.iter().enumerate() {
        let reach = boxes[a].max[axis];
        for &b in order[k + 1..]
            .iter()
            .take_while(|&&b| boxes[b].min[axis] <= reach)
        {
            let shared = boxes[a].intersection(boxes[b]);
            if shared.is_empty() {
                continue;
            }
            let smaller = boxes[a].half_area().min(boxes[b].half_area());
            let overlap = shared.half_area() / smaller.max(f32::MIN_POSITIVE);
            if overlap >= 0.5 {
                pairs.push((a.min(b), a.max(b), overlap));
            }
        }
    }
    pairs.sort_unstable_by_key(|&(a, b, _)| (a, b));
    pairs
}

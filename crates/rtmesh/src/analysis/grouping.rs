//! Regrouping the geometries of a scene, with the map back to the input: scattered
//! geometries split into one geometry per piece (placed by every instance of the
//! original), and overlapping geometries placed once merged into one (transforms baked
//! in). Lint estimates the proposed regrouping's two-level SAH cost; repair keeps it
//! only where probe rays measure a gain. Cost: O(T) to split or merge, plus the sweep
//! over instance boxes.

use super::overlap::overlapping_instances;
use super::pieces::Pieces;
use crate::mesh::{Scene, TriMesh};
use serde::Serialize;

/// A repaired geometry and, per output triangle, its input triangle id.
#[derive(Clone, Debug, PartialEq)]
pub struct Repaired {
    /// The repaired mesh.
    pub mesh: TriMesh,
    /// `input_triangle[t]` = the input triangle output triangle `t` came from.
    pub input_triangle: Vec<u32>,
}

/// Where every output triangle of a repaired scene came from.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RepairMap {
    /// Per output geometry, the input geometry of every output triangle (one value
    /// unless geometries were merged).
    pub input_geometry: Vec<Vec<u32>>,
    /// Per output geometry, the input triangle (within the input geometry) of every
    /// output triangle.
    pub input_triangle: Vec<Vec<u32>>,
}

/// The regrouping that lint estimates and `repair --split-scattered
/// --merge-overlapping` tries, before probe rays judge it: every scattered geometry
/// split into one geometry per piece, then the geometries placed once whose boxes
/// overlap by half or more merged into one. `pieces[g]` are the pieces of geometry
/// `g` ([`Pieces::of`]). `None` when neither applies.
pub fn proposed_grouping(scene: &Scene, pieces: &[Pieces]) -> Option<Scene> {
    let variants: Vec<(Vec<Repaired>, Option<Vec<Repaired>>)> = scene
        .meshes
        .iter()
        .zip(pieces)
        .map(|(mesh, pieces)| {
            let whole = Repaired {
                mesh: mesh.clone(),
                input_triangle: (0..mesh.triangle_count() as u32).collect(),
            };
            let split = pieces
                .scattered()
                .then(|| split_pieces(&whole, &pieces.of_triangle, pieces.boxes.len()));
            (vec![whole], split)
        })
        .collect();
    let split_any = variants.iter().any(|v| v.1.is_some());
    let (split, map) = assemble(scene, &variants, true);
    match merge_overlapping(&split, &map) {
        Some((merged, _, _)) => Some(merged),
        None => split_any.then_some(split),
    }
}

/// Merge the geometries of instances whose boxes overlap by half or more (as lint's
/// `overlapping-geometries` finds them), where each such geometry is placed once:
/// one geometry per group, transforms baked in, placed with the identity. Returns
/// the merged scene and map and the number of groups, or `None` when nothing merges.
pub(crate) fn merge_overlapping(
    scene: &Scene,
    map: &RepairMap,
) -> Option<(Scene, RepairMap, usize)> {
    let placements = scene.placements();
    let n = scene.instances.len();
    let pairs = overlapping_instances(scene);
    // Union-find over instances.
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let single = |i: usize| placements[scene.instances[i].mesh] == 1;
    for &(a, b, _) in &pairs {
        if single(a) && single(b) {
            let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
            parent[ra] = rb;
        }
    }
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); n];
    for i in 0..n {
        let r = root(&mut parent, i);
        members[r].push(i);
    }
    let groups: Vec<&Vec<usize>> = members.iter().filter(|m| m.len() > 1).collect();
    if groups.is_empty() {
        return None;
    }
    let merged_instance: Vec<bool> = (0..n)
        .map(|i| members[root(&mut parent, i)].len() > 1)
        .collect();
    let mut out = Scene {
        meshes: Vec::new(),
        instances: Vec::new(),
        ..scene.clone()
    };
    let mut out_map = RepairMap::default();
    // Geometries not merged keep their instances.
    let mut new_index = vec![usize::MAX; scene.meshes.len()];
    for (i, instance) in scene.instances.iter().enumerate() {
        if merged_instance[i] {
            continue;
        }
        if new_index[instance.mesh] == usize::MAX {
            new_index[instance.mesh] = out.meshes.len();
            out.meshes.push(scene.meshes[instance.mesh].clone());
            out_map
                .input_geometry
                .push(map.input_geometry[instance.mesh].clone());
            out_map
                .input_triangle
                .push(map.input_triangle[instance.mesh].clone());
        }
        out.instances.push(crate::mesh::Instance {
            mesh: new_index[instance.mesh],
            ..instance.clone()
        });
    }
    for group in &groups {
        let mut mesh = TriMesh::default();
        let (mut geometry, mut triangle) = (Vec::new(), Vec::new());
        for &i in group.iter() {
            let instance = &scene.instances[i];
            mesh.append(&scene.meshes[instance.mesh], &instance.transform, 0);
            geometry.extend_from_slice(&map.input_geometry[instance.mesh]);
            triangle.extend_from_slice(&map.input_triangle[instance.mesh]);
        }
        out.instances.push(crate::mesh::Instance::new(
            out.meshes.len(),
            glam::Affine3A::IDENTITY,
        ));
        out.meshes.push(mesh);
        out_map.input_geometry.push(geometry);
        out_map.input_triangle.push(triangle);
    }
    Some((out, out_map, groups.len()))
}

/// The scene of the repaired geometries (split into pieces where `split` and
/// available), every input instance placing each of its geometry's outputs.
pub(crate) fn assemble(
    scene: &Scene,
    variants: &[(Vec<Repaired>, Option<Vec<Repaired>>)],
    split: bool,
) -> (Scene, RepairMap) {
    let mut out = Scene {
        meshes: Vec::new(),
        instances: Vec::new(),
        ..scene.clone()
    };
    let mut map = RepairMap::default();
    let mut outputs: Vec<Vec<usize>> = Vec::with_capacity(variants.len());
    for (g, (whole, pieces)) in variants.iter().enumerate() {
        let parts = match pieces {
            Some(pieces) if split => pieces.as_slice(),
            _ => whole.as_slice(),
        };
        let mut ids = Vec::with_capacity(parts.len());
        for part in parts {
            ids.push(out.meshes.len());
            out.meshes.push(part.mesh.clone());
            map.input_geometry
                .push(vec![g as u32; part.input_triangle.len()]);
            map.input_triangle.push(part.input_triangle.clone());
        }
        outputs.push(ids);
    }
    for instance in &scene.instances {
        for &mesh in &outputs[instance.mesh] {
            out.instances.push(crate::mesh::Instance {
                mesh,
                ..instance.clone()
            });
        }
    }
    (out, map)
}

/// One mesh per piece (`piece[t]` of triangle `t`; triangles in no piece go with
/// piece 0), vertices compacted, attributes and input ids kept.
pub(crate) fn split_pieces(repaired: &Repaired, piece: &[u32], count: usize) -> Vec<Repaired> {
    let mesh = &repaired.mesh;
    let mut parts: Vec<Repaired> = (0..count)
        .map(|_| Repaired {
            mesh: TriMesh {
                name: mesh.name.clone(),
                ..TriMesh::default()
            },
            input_triangle: Vec::new(),
        })
        .collect();
    let mut local = vec![(u32::MAX, u32::MAX); mesh.positions.len()];
    for t in 0..mesh.triangle_count() {
        let p = piece
            .get(t)
            .copied()
            .filter(|&p| (p as usize) < count)
            .unwrap_or(0);
        let part = &mut parts[p as usize];
        let triangle = mesh.triangles[t].map(|v| {
            let Some(slot) = local.get_mut(v as usize) else {
                return v; // out of range: kept as is, still skipped by the tracer
            };
            if slot.0 != p {
                *slot = (p, part.mesh.push_vertex_like(mesh, v as usize));
            }
            slot.1
        });
        part.mesh.push_triangle_like(triangle, mesh, t);
        part.input_triangle.push(repaired.input_triangle[t]);
    }
    parts
}

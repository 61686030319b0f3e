//! Vertex welding: merge vertices with identical (or, optionally, nearby) positions so
//! that triangle soups and files with split vertices get shared edges.
//!
//! Exact welding hashes the positions' bit patterns (with -0.0 read as +0.0): O(V)
//! expected. Tolerance welding hashes points into a grid of cells of the tolerance's
//! size and compares against the 27 neighbouring cells: O(V) expected for tolerances
//! smaller than the typical edge. Each merged vertex takes the position of the first
//! vertex (in index order) of its group, so exact welding never moves any triangle.
//! Vertices merge only when every attribute agrees too (bit for bit), so seams stay;
//! [`TriMesh::topology`] welds by position alone for adjacency.

use super::TriMesh;
use glam::Vec3;
use std::collections::HashMap;

/// The result of welding: the new mesh and the map from old to new vertex ids.
#[derive(Clone, Debug)]
pub struct WeldResult {
    /// The welded mesh: same triangles in the same order, fewer vertices.
    pub mesh: TriMesh,
    /// `remap[old_vertex] = new_vertex`.
    pub remap: Vec<u32>,
    /// How many vertices were merged away (old count − new count).
    pub merged: usize,
}

/// Merge vertices with bit-identical positions (treating -0.0 as 0.0).
pub fn weld_exact(mesh: &TriMesh) -> WeldResult {
    weld(mesh, 0.0)
}

fn position_key(p: Vec3) -> [u32; 3] {
    // `+ 0.0` turns -0.0 into +0.0 and leaves every other value alone.
    [
        (p.x + 0.0).to_bits(),
        (p.y + 0.0).to_bits(),
        (p.z + 0.0).to_bits(),
    ]
}

/// Merge vertices whose positions are within `tolerance` of each other (Chebyshev
/// distance, per axis) and whose attributes are bit-identical: seams and creases stay,
/// so no output vertex stands for two inputs that differ. `tolerance == 0` merges only
/// identical positions. Non-finite positions are never merged with anything.
pub fn weld(mesh: &TriMesh, tolerance: f32) -> WeldResult {
    weld_by(mesh, tolerance, true)
}

/// Exact weld by position alone, attributes dropped: [`TriMesh::topology`].
pub(super) fn weld_positions(mesh: &TriMesh) -> TriMesh {
    weld_by(mesh, 0.0, false).mesh
}

/// The weld; with `keep_attributes`, vertices must also agree in every attribute, and
/// the output carries them.
fn weld_by(mesh: &TriMesh, tolerance: f32, keep_attributes: bool) -> WeldResult {
    let keyed = keep_attributes && !mesh.attributes.is_empty();
    let attribute_key = |v: usize| -> Vec<u8> {
        let mut key = Vec::new();
        if keyed {
            for attribute in &mesh.attributes {
                attribute.push_vertex_bytes(v, &mut key);
            }
        }
        key
    };
    let mut remap = Vec::with_capacity(mesh.positions.len());
    // The input vertex each output vertex is (the first of its group).
    let mut representative: Vec<u32> = Vec::new();
    let new_vertex = |representative: &mut Vec<u32>, v: usize| {
        representative.push(v as u32);
        representative.len() as u32 - 1
    };
    if tolerance > 0.0 && tolerance.is_finite() {
        let inverse_cell = 1.0 / tolerance;
        let cell_of = |p: Vec3| (p * inverse_cell).floor().as_ivec3();
        let mut grid: HashMap<glam::IVec3, Vec<u32>> = HashMap::new();
        for (v, &p) in mesh.positions.iter().enumerate() {
            if !p.is_finite() {
                remap.push(new_vertex(&mut representative, v));
                continue;
            }
            let cell = cell_of(p);
            let key = attribute_key(v);
            let mut found = None;
            'search: for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let near = cell + glam::IVec3::new(dx, dy, dz);
                        if let Some(list) = grid.get(&near) {
                            if let Some(&w) = list.iter().find(|&&w| {
                                let r = representative[w as usize] as usize;
                                (mesh.positions[r] - p).abs().max_element() <= tolerance
                                    && (!keyed || attribute_key(r) == key)
                            }) {
                                found = Some(w);
                                break 'search;
                            }
                        }
                    }
                }
            }
            let w = found.unwrap_or_else(|| {
                let w = new_vertex(&mut representative, v);
                grid.entry(cell).or_default().push(w);
                w
            });
            remap.push(w);
        }
    } else if keyed {
        let mut seen: HashMap<([u32; 3], Vec<u8>), u32> =
            HashMap::with_capacity(mesh.positions.len());
        for (v, &p) in mesh.positions.iter().enumerate() {
            let w = if p.is_finite() {
                *seen
                    .entry((position_key(p), attribute_key(v)))
                    .or_insert_with(|| new_vertex(&mut representative, v))
            } else {
                new_vertex(&mut representative, v)
            };
            remap.push(w);
        }
    } else {
        let mut seen: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.positions.len());
        for (v, &p) in mesh.positions.iter().enumerate() {
            let w = if p.is_finite() {
                *seen
                    .entry(position_key(p))
                    .or_insert_with(|| new_vertex(&mut representative, v))
            } else {
                new_vertex(&mut representative, v)
            };
            remap.push(w);
        }
    }
    let triangles = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| remap.get(v as usize).copied().unwrap_or(v)))
        .collect();
    let merged = mesh.positions.len() - representative.len();
    WeldResult {
        mesh: TriMesh {
            name: mesh.name.clone(),
            positions: representative
                .iter()
                .map(|&v| mesh.positions[v as usize])
                .collect(),
            triangles,
            material_ids: mesh.material_ids.clone(),
            alpha_tested: mesh.alpha_tested.clone(),
            group_ids: mesh.group_ids.clone(),
            attributes: if keep_attributes {
                super::gather_all(&mesh.attributes, &representative)
            } else {
                Vec::new()
            },
            triangle_attributes: match keep_attributes {
                true => mesh.triangle_attributes.clone(),
                false => Vec::new(),
            },
        },
        remap,
        merged,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn soup_quad() -> TriMesh {
        // Two triangles of a unit quad, each with its own three vertices.
        TriMesh::new(
            vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::ZERO,
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(-0.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2], [3, 4, 5]],
        )
    }

    #[test]
    fn exact_weld_shares_the_diagonal() {
        let r = weld_exact(&soup_quad());
        assert_eq!(r.merged, 2);
        assert_eq!(r.mesh.positions.len(), 4);
        assert_eq!(r.mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn tolerance_weld_merges_near_points_only() {
        let mut m = soup_quad();
        m.positions[3] = Vec3::new(1e-4, 0.0, 0.0);
        assert_eq!(weld(&m, 1e-3).merged, 2);
        assert_eq!(weld(&m, 1e-5).merged, 1);
    }

    #[test]
    fn seams_stay_and_topology_crosses_them() {
        let mut m = soup_quad();
        // The diagonal's two copies differ in UV on one end: a seam.
        m.attributes.push(crate::mesh::VertexAttribute::from_f32(
            "TEXCOORD_0",
            &[
                [0.0, 0.0],
                [1.0, 0.0],
                [1.0, 1.0],
                [0.5, 0.0],
                [1.0, 1.0],
                [0.0, 1.0],
            ],
        ));
        let r = weld_exact(&m);
        assert_eq!(r.merged, 1);
        assert_eq!(r.mesh.triangles, vec![[0, 1, 2], [3, 2, 4]]);
        assert_eq!(r.mesh.attributes[0].vertex(3), vec![0.5, 0.0]);
        let topology = m.topology();
        assert_eq!(topology.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(topology.attributes.is_empty());
    }

    #[test]
    fn nan_vertices_stay_apart() {
        let mut m = soup_quad();
        m.positions[0] = Vec3::NAN;
        m.positions[3] = Vec3::NAN;
        assert_eq!(weld_exact(&m).merged, 1);
    }

    proptest! {
        #[test]
        fn exact_weld_never_moves_a_triangle(
            points in prop::collection::vec((0u8..4, 0u8..4, 0u8..4), 3..40),
            picks in prop::collection::vec((0usize..1000, 0usize..1000, 0usize..1000), 1..40),
        ) {
            let positions: Vec<Vec3> = points.iter()
                .map(|&(x, y, z)| Vec3::new(x as f32, y as f32, z as f32)).collect();
            let n = positions.len();
            let triangles = picks.iter()
                .map(|&(a, b, c)| [(a % n) as u32, (b % n) as u32, (c % n) as u32]).collect();
            let mesh = TriMesh::new(positions, triangles);
            let r = weld_exact(&mesh);
            prop_assert_eq!(r.mesh.triangles.len(), mesh.triangles.len());
            for t in 0..mesh.triangles.len() {
                prop_assert_eq!(r.mesh.corners(t), mesh.corners(t));
            }
            // No two welded vertices share a position.
            let mut keys: Vec<_> = r.mesh.positions.iter().map(|&p| position_key(p)).collect();
            keys.sort_unstable();
            keys.dedup();
            prop_assert_eq!(keys.len(), r.mesh.positions.len());
        }
    }
}

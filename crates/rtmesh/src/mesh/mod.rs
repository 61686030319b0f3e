//! The mesh model: [`TriMesh`] (one geometry) and [`Scene`] (geometries plus instances).
//!
//! Positions are f32, triangles are u32 vertex indices. Every triangle carries a material
//! id and an alpha-tested flag, so that lint and repair can separate opaque from
//! alpha-tested geometry (NVIDIA's advice) and writers can keep materials.

mod adjacency;
mod duplicates;
mod info;
mod validate;
mod weld;

pub use adjacency::{connected_components, EdgeAdjacency, NO_EDGE};
pub(crate) use adjacency::{has_edges, part_cursors, triangle_part_len, HalfEdgeRuns, SharedSlice};
pub use duplicates::{duplicates, Duplicates};
pub use info::MeshInfo;
pub use validate::{validate, Validation};
pub use weld::{weld, weld_exact, WeldResult};

use crate::geom::Aabb;
use glam::{Affine3A, Vec3};
use serde::Serialize;

/// A material as far as ray tracing cares: its name and whether it is alpha-tested
/// (any-hit shaders run on its triangles).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Material {
    /// Name from the file (`usemtl`, glTF material name), or empty.
    pub name: String,
    /// True for cut-out materials: OBJ `map_d` or `d < 1`, glTF `alphaMode` MASK or BLEND.
    pub alpha_tested: bool,
}

/// One triangle geometry: shared vertices, indexed triangles and per-triangle attributes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Name from the file (OBJ group/object, glTF mesh), or empty.
    pub name: String,
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Triangles as three indices into `positions`, in file order.
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle: index into [`Scene::materials`].
    pub material_ids: Vec<u32>,
    /// Per triangle: true when the triangle's material is alpha-tested.
    pub alpha_tested: Vec<bool>,
}

impl TriMesh {
    /// A mesh with material 0 and opaque triangles.
    pub fn new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Self {
        let n = triangles.len();
        Self {
            name: String::new(),
            positions,
            triangles,
            material_ids: vec![0; n],
            alpha_tested: vec![false; n],
        }
    }

    /// No triangle is alpha-tested: the geometry may carry DXR's
    /// `D3D12_RAYTRACING_GEOMETRY_FLAG_OPAQUE` (Vulkan `VK_GEOMETRY_OPAQUE_BIT_KHR`),
    /// so that no any-hit shader runs on it.
    pub fn is_opaque(&self) -> bool {
        !self.alpha_tested.contains(&true)
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The three corner positions of triangle `t` (indices must be in range).
    #[inline]
    pub fn corners(&self, t: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[t];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// The corners of triangle `t` when its indices are in range and its corners
    /// finite (what the tracer keeps); `None` otherwise.
    #[inline]
    pub fn finite_corners(&self, t: usize) -> Option<[Vec3; 3]> {
        let n = self.positions.len();
        if self.triangles[t].iter().any(|&v| v as usize >= n) {
            return None;
        }
        let corners = self.corners(t);
        corners.iter().all(|p| p.is_finite()).then_some(corners)
    }

    /// Box of all vertices that triangles use, skipping non-finite positions.
    pub fn bounds(&self) -> Aabb {
        let mut used = vec![false; self.positions.len()];
        for t in &self.triangles {
            for &v in t {
                if let Some(u) = used.get_mut(v as usize) {
                    *u = true;
                }
            }
        }
        self.positions
            .iter()
            .zip(&used)
            .filter(|(p, &u)| u && p.is_finite())
            .fold(Aabb::EMPTY, |b, (&p, _)| b.grown_by_point(p))
    }

    /// Append `other`, with its vertices moved by `transform`; material ids are offset by
    /// `material_offset`.
    pub fn append(&mut self, other: &TriMesh, transform: &Affine3A, material_offset: u32) {
        let base = self.positions.len() as u32;
        self.positions.extend(
            other
                .positions
                .iter()
                .map(|&p| transform.transform_point3(p)),
        );
        self.triangles.extend(
            other
                .triangles
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
        self.material_ids
            .extend(other.material_ids.iter().map(|m| m + material_offset));
        self.alpha_tested.extend_from_slice(&other.alpha_tested);
    }
}

/// One placement of a mesh in the scene: `world = transform * local`.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Index into [`Scene::meshes`].
    pub mesh: usize,
    /// Object-to-world affine transform.
    pub transform: Affine3A,
}

/// Geometries and their placements: the input of a two-level (TLAS/BLAS) structure.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    /// The geometries (BLAS candidates).
    pub meshes: Vec<TriMesh>,
    /// Their placements (TLAS entries). A mesh may be placed several times, or never.
    pub instances: Vec<Instance>,
    /// Materials referenced by the meshes' `material_ids`.
    pub materials: Vec<Material>,
    /// Vertex records in the file the scene was read from, where that differs from the
    /// meshes' vertices (OBJ: unused vertices are dropped and vertices shared between
    /// groups are copied into each group's geometry).
    pub source_vertex_count: Option<usize>,
    /// What the reader dropped or changed on the way in, by documented rule.
    pub read_notes: ReadNotes,
}

/// The documented repairs a reader made, counted (all zero for a scene not read from a
/// file).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ReadNotes {
    /// Triangles of PLY `tristrips` that name a vertex twice: the swaps and joins that
    /// stitch a generalized strip together, which cover no surface. Dropped.
    pub strip_degenerates_dropped: usize,
    /// OBJ `l` (polyline) statements: not triangles, so ignored.
    pub ignored_lines: usize,
    /// OBJ `p` (point) statements: not triangles, so ignored.
    pub ignored_points: usize,
}

impl Scene {
    /// A scene of one mesh placed once, untransformed.
    pub fn from_mesh(mesh: TriMesh) -> Self {
        Self {
            meshes: vec![mesh],
            instances: vec![Instance {
                mesh: 0,
                transform: Affine3A::IDENTITY,
            }],
            materials: vec![Material::default()],
            source_vertex_count: None,
            read_notes: ReadNotes::default(),
        }
    }

    /// Add a mesh placed once with `transform`; returns its mesh index.
    pub fn push_mesh(&mut self, mesh: TriMesh, transform: Affine3A) -> usize {
        self.meshes.push(mesh);
        let index = self.meshes.len() - 1;
        self.instances.push(Instance {
            mesh: index,
            transform,
        });
        index
    }

    /// Triangles in the world: every instance counts its mesh's triangles.
    pub fn instanced_triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh].triangle_count())
            .sum()
    }

    /// How many instances place each mesh (0 for a mesh never placed).
    pub fn placements(&self) -> Vec<usize> {
        let mut placements = vec![0; self.meshes.len()];
        for instance in &self.instances {
            placements[instance.mesh] += 1;
        }
        placements
    }

    /// Vertices in the world: every instance counts its mesh's vertices.
    pub fn instanced_vertex_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh].positions.len())
            .sum()
    }

    /// True when every instance places a distinct mesh once with the identity transform,
    /// so that [`Scene::flatten`] is exactly the meshes one after another.
    pub fn is_flat(&self) -> bool {
        self.instances.len() == self.meshes.len()
            && self
                .instances
                .iter()
                .enumerate()
                .all(|(i, inst)| inst.mesh == i && inst.transform == Affine3A::IDENTITY)
    }

    /// One mesh holding every instance's triangles in world space, in instance order.
    /// The i-th triangle of the result is the i-th triangle in instance order.
    pub fn flatten(&self) -> TriMesh {
        self.concatenate(
            self.instances
                .iter()
                .map(|i| (&self.meshes[i.mesh], i.transform)),
        )
    }

    /// One mesh holding every stored geometry once, untransformed, in mesh order: the
    /// geometry as the file stores it, whatever the instancing.
    pub fn stored_geometry(&self) -> TriMesh {
        self.concatenate(self.meshes.iter().map(|m| (m, Affine3A::IDENTITY)))
    }

    fn concatenate<'a>(
        &'a self,
        parts: impl Iterator<Item = (&'a TriMesh, Affine3A)> + Clone,
    ) -> TriMesh {
        let mut out = TriMesh {
            name: self
                .meshes
                .first()
                .filter(|_| self.meshes.len() == 1)
                .map(|m| m.name.clone())
                .unwrap_or_default(),
            ..TriMesh::default()
        };
        out.positions
            .reserve(parts.clone().map(|(m, _)| m.positions.len()).sum());
        out.triangles
            .reserve(parts.clone().map(|(m, _)| m.triangle_count()).sum());
        for (mesh, transform) in parts {
            out.append(mesh, &transform, 0);
        }
        out
    }

    /// World-space box of all instances.
    pub fn bounds(&self) -> Aabb {
        let mesh_bounds: Vec<Aabb> = self.meshes.iter().map(TriMesh::bounds).collect();
        self.instances.iter().fold(Aabb::EMPTY, |b, inst| {
            b.union(mesh_bounds[inst.mesh].transformed(&inst.transform))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flatten_applies_transforms_in_instance_order() {
        let tri = TriMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
        let mut scene = Scene::from_mesh(tri);
        scene.instances.push(Instance {
            mesh: 0,
            transform: Affine3A::from_translation(Vec3::Z * 2.0),
        });
        let flat = scene.flatten();
        assert_eq!(flat.triangles, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(flat.positions[3], Vec3::new(0.0, 0.0, 2.0));
        assert_eq!(scene.instanced_triangle_count(), 2);
        assert!(!scene.is_flat());
        assert_eq!(scene.bounds().max.z, 2.0);
    }
}

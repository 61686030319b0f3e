//! Hand-built meshes that the lint and repair tests share.
#![allow(dead_code)] // each test file uses some of them

use glam::Vec3;
use rtmesh::lint::{lint, Finding, LintSettings};
use rtmesh::{Scene, TriMesh};
use std::collections::BTreeSet;

/// An `n` × `n` axis-aligned grid of unit quads from `origin`: the clean base.
pub fn grid(n: usize, origin: Vec3) -> TriMesh {
    let mut grid = rtmesh::scenes::quad_grid(n);
    for p in &mut grid.positions {
        *p += origin;
    }
    grid
}

/// `mesh` plus triangles with the given corners (each its own vertices).
pub fn with(mut mesh: TriMesh, extra: &[[Vec3; 3]]) -> TriMesh {
    for corners in extra {
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(corners);
        mesh.triangles.push([base, base + 1, base + 2]);
        mesh.material_ids.push(0);
        mesh.alpha_tested.push(false);
    }
    mesh
}

/// A fan of `n` triangles of radius 4 around (5, 5, −5).
pub fn fan(n: usize) -> TriMesh {
    let centre = Vec3::new(5.0, 5.0, -5.0);
    let mut positions = vec![centre];
    for k in 0..n {
        let angle = std::f32::consts::TAU * k as f32 / n as f32;
        positions.push(centre + 4.0 * Vec3::new(angle.cos(), angle.sin(), 0.0));
    }
    let triangles = (0..n as u32)
        .map(|k| [0, 1 + k, 1 + (k + 1) % n as u32])
        .collect();
    TriMesh::new(positions, triangles)
}

/// The kinds of lint's findings on `scene`.
pub fn kinds(scene: &Scene) -> BTreeSet<&'static str> {
    lint(scene, &LintSettings::default())
        .findings
        .iter()
        .map(|f| f.kind)
        .collect()
}

/// Lint's finding of `kind` on `scene`, which must be there.
pub fn finding(scene: &Scene, kind: &str) -> Finding {
    lint(scene, &LintSettings::default())
        .findings
        .into_iter()
        .find(|f| f.kind == kind)
        .unwrap_or_else(|| panic!("no {kind} finding"))
}

/// The figure called `name` of `finding`.
pub fn figure(finding: &Finding, name: &str) -> f64 {
    finding
        .figures
        .iter()
        .find(|f| f.0 == name)
        .unwrap_or_else(|| panic!("no figure {name}"))
        .1
}

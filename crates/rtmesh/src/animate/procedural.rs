//! Procedural motion of any mesh: `twist` (about the
//! vertical axis, growing with height), `bend` (about a horizontal axis through the
//! bottom), `wave` (a travelling sine along the longest axis), and `explode` (each
//! connected piece, or for a single piece each cell of a grid of about a thousand
//! cells, pushed out from the centre with a spin), standing in for the UNC exploding
//! dragon, which cannot be had here. Frame `f` of `n` is the motion at phase `f / (n −
//! 1)`, from the rest pose at 0 to the strongest at 1. O(V) per frame.

use crate::analysis::Pieces;
use crate::geom::Aabb;
use crate::mesh::{Semantic, TriMesh, VertexAttribute};
use glam::{Mat3, Quat, Vec3};
use rayon::prelude::*;

/// A procedural motion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Procedural {
    /// Rotation about +Y by up to 90° at the top, none at the bottom.
    Twist,
    /// Bend about the X axis through the bottom, up to 90° at the top.
    Bend,
    /// A sine wave along the longest axis, amplitude a tenth of the bounds.
    Wave,
    /// Pieces (or grid cells) thrown out from the centre with a spin, up to half the
    /// bounds' diagonal.
    Explode,
}

impl Procedural {
    /// Every procedural motion, in the order `--help` lists them.
    pub const ALL: [Procedural; 4] = [
        Procedural::Twist,
        Procedural::Bend,
        Procedural::Wave,
        Procedural::Explode,
    ];

    /// The motion's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Procedural::Twist => "twist",
            Procedural::Bend => "bend",
            Procedural::Wave => "wave",
            Procedural::Explode => "explode",
        }
    }
}

/// A mesh's rest pose and what each frame of a procedural motion needs.
pub(super) struct Deform {
    rest: Vec<Vec3>,
    bounds: Aabb,
    motion: Procedural,
    /// Explode: the part (piece or cell) of every vertex, and each part's centre.
    parts: Vec<u32>,
    part_centres: Vec<Vec3>,
    /// The rest pose's normals and tangents, which each frame turns.
    directions: Vec<VertexAttribute>,
}

impl Deform {
    /// `motion` of `mesh` from its current positions.
    pub fn new(mesh: &TriMesh, motion: Procedural) -> Self {
        let bounds = mesh.bounds();
        let (parts, part_centres) = if motion == Procedural::Explode {
            explode_parts(mesh, &bounds)
        } else {
            (Vec::new(), Vec::new())
        };
        Self {
            rest: mesh.positions.clone(),
            bounds,
            motion,
            parts,
            part_centres,
            directions: mesh
                .attributes
                .iter()
                .filter(|a| {
                    matches!(a.semantic(), Semantic::Normal | Semantic::Tangent)
                        && a.vertex_count() == mesh.positions.len()
                })
                .cloned()
                .collect(),
        }
    }

    /// `mesh` (the one it was made from) moved to `phase`: its positions, and its
    /// normals and tangents turned by the motion's Jacobian from their rest values.
    pub fn pose(&self, phase: f32, mesh: &mut TriMesh) {
        if self.directions.is_empty() {
            mesh.positions = self.positions(phase);
            return;
        }
        // Each vertex's motion once, for its position and for every stream it turns.
        let (positions, jacobians): (Vec<Vec3>, Vec<Mat3>) = (0..self.rest.len())
            .into_par_iter()
            .map(|v| self.moved(v, phase))
            .unzip();
        mesh.positions = positions;
        for rest in &self.directions {
            if let Some(a) = mesh.attributes.iter_mut().find(|a| a.name == rest.name) {
                *a = rest.clone();
                a.transform_each(|v| jacobians[v]);
            }
        }
    }

    /// The motion it plays.
    pub fn motion(&self) -> Procedural {
        self.motion
    }

    /// The positions at `phase` in [0, 1].
    pub fn positions(&self, phase: f32) -> Vec<Vec3> {
        (0..self.rest.len())
            .into_par_iter()
            .map(|v| self.moved(v, phase).0)
            .collect()
    }

    /// Vertex `v` at `phase`, and the motion's Jacobian J = ∂f/∂p there, which turns
    /// its tangents (by J) and normals (by J's cofactor). Twist and bend are
    /// rotations R(a) by an angle a = k·(y − y₀) that grows with height, so
    /// f(p) = o + R(a)(p − o) and J = R + (axis × R(p − o)) · k ŷᵀ; the wave is a shear,
    /// J = I + across · ∂offset/∂along; a piece of the explosion moves rigidly, J = its
    /// spin.
    fn moved(&self, v: usize, phase: f32) -> (Vec3, Mat3) {
        let b = &self.bounds;
        let extent = b.extent().max(Vec3::splat(f32::MIN_POSITIVE));
        let centre = b.center();
        let p = self.rest[v];
        // A rotation about `axis` through `origin` by k·(y − y₀).
        let turned_with_height = |axis: Vec3, origin: Vec3| {
            let k = phase * std::f32::consts::FRAC_PI_2 / extent.y;
            let q = Quat::from_axis_angle(axis, k * (p.y - b.min.y));
            let arm = q * (p - origin);
            let shear = Mat3::from_cols(Vec3::ZERO, axis.cross(arm) * k, Vec3::ZERO);
            (origin + arm, Mat3::from_quat(q) + shear)
        };
        match self.motion {
            Procedural::Twist => turned_with_height(Vec3::Y, centre),
            Procedural::Bend => turned_with_height(Vec3::X, Vec3::new(centre.x, b.min.y, centre.z)),
            Procedural::Wave => {
                let axis = extent.max_element();
                let (a, across) = if axis == extent.x {
                    (0, Vec3::Y)
                } else if axis == extent.y {
                    (1, Vec3::Z)
                } else {
                    (2, Vec3::Y)
                };
                let along = (p[a] - b.min[a]) / extent[a];
                let (sin, cos) = (std::f32::consts::TAU * 2.0 * along).sin_cos();
                let amplitude = 0.1 * axis * phase;
                let mut shear = [Vec3::ZERO; 3];
                shear[a] = across * (amplitude * cos * std::f32::consts::TAU * 2.0 / extent[a]);
                (
                    p + across * (amplitude * sin),
                    Mat3::IDENTITY + Mat3::from_cols(shear[0], shear[1], shear[2]),
                )
            }
            Procedural::Explode => {
                let part = self.parts[v] as usize;
                let c = self.part_centres[part];
                let away = (c - centre).normalize_or(Vec3::Y);
                let spin = Quat::from_axis_angle(
                    away.any_orthonormal_vector(),
                    phase * std::f32::consts::PI,
                );
                let moved = c + away * phase * 0.5 * b.diagonal_length();
                (moved + spin * (p - c), Mat3::from_quat(spin))
            }
        }
    }
}

/// For `explode`: each vertex's part (its connected piece, or its cell of a grid of
/// about 10³ cells when the mesh is one piece) and each part's centre.
fn explode_parts(mesh: &TriMesh, bounds: &Aabb) -> (Vec<u32>, Vec<Vec3>) {
    let pieces = Pieces::of(mesh);
    let mut parts = vec![u32::MAX; mesh.positions.len()];
    if pieces.boxes.len() > 1 {
        for (t, &piece) in pieces.of_triangle.iter().enumerate() {
            for &v in &mesh.triangles[t] {
                if let Some(slot) = parts.get_mut(v as usize) {
                    *slot = piece.min(pieces.boxes.len() as u32 - 1);
                }
            }
        }
    }
    let extent = bounds.extent().max(Vec3::splat(f32::MIN_POSITIVE));
    let cells = 10u32;
    for (v, part) in parts.iter_mut().enumerate() {
        if *part == u32::MAX {
            let q = ((mesh.positions[v] - bounds.min) / extent * cells as f32)
                .clamp(Vec3::ZERO, Vec3::splat(cells as f32 - 1.0));
            *part =
                pieces.boxes.len() as u32 + q.x as u32 + cells * (q.y as u32 + cells * q.z as u32);
        }
    }
    let count = parts.iter().copied().max().map_or(0, |m| m as usize + 1);
    let mut sums = vec![(Vec3::ZERO, 0u32); count];
    for (v, &part) in parts.iter().enumerate() {
        sums[part as usize].0 += mesh.positions[v];
        sums[part as usize].1 += 1;
    }
    let centres = sums
        .into_iter()
        .map(|(s, n)| if n > 0 { s / n as f32 } else { Vec3::ZERO })
        .collect();
    (parts, centres)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phase_zero_is_the_rest_pose_and_twist_keeps_the_bottom() {
        let mesh = crate::scenes::scan_blob(2_000, 1);
        for motion in [
            Procedural::Twist,
            Procedural::Bend,
            Procedural::Wave,
            Procedural::Explode,
        ] {
            let animation = Deform::new(&mesh, motion);
            let rest = animation.positions(0.0);
            for (a, b) in rest.iter().zip(&mesh.positions) {
                assert!((*a - *b).length() < 1e-5, "{motion:?}");
            }
            let moved = animation.positions(1.0);
            assert!(moved
                .iter()
                .zip(&mesh.positions)
                .any(|(a, b)| (*a - *b).length() > 1e-2));
        }
        let bounds = mesh.bounds();
        let twisted = Deform::new(&mesh, Procedural::Twist).positions(1.0);
        for (p, q) in mesh.positions.iter().zip(&twisted) {
            if p.y == bounds.min.y {
                assert!((*p - *q).length() < 1e-5, "the bottom stays");
            }
            // A twist about the vertical axis keeps heights.
            assert!((p.y - q.y).abs() < 1e-5);
        }
    }

    /// Area-weighted vertex normals of `positions` over `mesh`'s triangles, and which
    /// vertices they do not stand for: those with a triangle whose corners lie in
    /// different parts of `deform`, or whose triangles' normals spread (where the
    /// weighted sum is under 0.9 of the sum of the areas, it turns with small changes
    /// of shape).
    fn vertex_normals(
        mesh: &TriMesh,
        positions: &[Vec3],
        deform: &Deform,
    ) -> (Vec<Vec3>, Vec<bool>) {
        let mut sums = vec![(Vec3::ZERO, 0.0f32); positions.len()];
        let mut torn = vec![false; positions.len()];
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|v| positions[v as usize]);
            let parts = t.map(|v| deform.parts.get(v as usize).copied());
            let area = (b - a).cross(c - a);
            for &v in t {
                sums[v as usize].0 += area;
                sums[v as usize].1 += area.length();
                torn[v as usize] |= parts[0] != parts[1] || parts[1] != parts[2];
            }
        }
        let normals = sums.iter().map(|s| s.0.normalize()).collect();
        for (v, s) in sums.iter().enumerate() {
            torn[v] |= s.0.length() < 0.9 * s.1;
        }
        (normals, torn)
    }

    #[test]
    fn the_jacobian_is_the_derivative_of_the_motion() {
        let mesh = crate::scenes::scan_blob(2_000, 3);
        let step = 1e-3 * mesh.bounds().diagonal_length();
        for motion in [Procedural::Twist, Procedural::Bend, Procedural::Wave] {
            let deform = Deform::new(&mesh, motion);
            let phase = 0.7;
            for v in (0..mesh.positions.len()).step_by(17) {
                // f at p ± step along each axis, as vertices of a copy whose bounds
                // are the same (each displaced point is moved back inside them).
                let jacobian = deform.moved(v, phase).1;
                for axis in 0..3 {
                    let d = Vec3::AXES[axis] * step;
                    let mut probe = deform.rest.clone();
                    let p = probe[v];
                    let inside = |q: Vec3| q.clamp(deform.bounds.min, deform.bounds.max);
                    let (lo, hi) = (inside(p - d), inside(p + d));
                    probe.push(lo);
                    probe.push(hi);
                    let at = Deform {
                        rest: probe,
                        ..Deform::new(&mesh, motion)
                    };
                    let n = at.rest.len();
                    let difference =
                        (at.moved(n - 1, phase).0 - at.moved(n - 2, phase).0) / (hi - lo)[axis];
                    let column = jacobian.col(axis);
                    assert!(
                        (difference - column).length() < 2e-2 * column.length().max(1.0),
                        "{motion:?}, vertex {v}, axis {axis}: {difference} against {column}"
                    );
                }
            }
        }
    }

    /// `motion` at full strength posed on a scan of `triangles` with area-weighted
    /// normals and tangents across them: the angles between the posed normals and the
    /// moved surface's own area-weighted normals (and, second, the rest normals'),
    /// sorted by the first, over the vertices whose normals stand for their surface.
    fn posed_normal_errors(motion: Procedural, triangles: usize) -> Vec<(f32, f32)> {
        let mut mesh = crate::scenes::scan_blob(triangles, 5);
        let (rest_normals, spread) =
            vertex_normals(&mesh, &mesh.positions, &Deform::new(&mesh, motion));
        let tangents: Vec<[f32; 4]> = rest_normals
            .iter()
            .map(|n| n.any_orthonormal_vector().extend(-1.0).to_array())
            .collect();
        let normals: Vec<[f32; 3]> = rest_normals.iter().map(|n| n.to_array()).collect();
        mesh.attributes
            .push(VertexAttribute::from_f32("NORMAL", &normals));
        mesh.attributes
            .push(VertexAttribute::from_f32("TANGENT", &tangents));
        let deform = Deform::new(&mesh, motion);
        let mut posed = mesh.clone();
        // Twice: a frame is posed from the rest pose, not from the frame before.
        deform.pose(1.0, &mut posed);
        deform.pose(1.0, &mut posed);
        let (expected, torn) = vertex_normals(&mesh, &posed.positions, &deform);
        let stream = |name: &str| posed.attribute(name).unwrap().to_f32();
        let (turned, tangents) = (stream("NORMAL"), stream("TANGENT"));
        let mut errors = Vec::new();
        for v in (0..expected.len()).filter(|&v| !torn[v] && !spread[v]) {
            let [n, t] = [&turned, &tangents].map(|a| {
                let x = a.vertex(v);
                Vec3::new(x[0] as f32, x[1] as f32, x[2] as f32)
            });
            assert!((n.length() - 1.0).abs() < 1e-5 && (t.length() - 1.0).abs() < 1e-5);
            assert!(
                n.dot(t).abs() < 1e-4,
                "{motion:?}: a tangent left its surface"
            );
            assert_eq!(tangents.vertex(v)[3], -1.0, "the handedness is kept");
            errors.push((
                n.angle_between(expected[v]),
                rest_normals[v].angle_between(expected[v]),
            ));
        }
        errors.sort_by(|a, b| a.0.total_cmp(&b.0));
        errors
    }

    #[test]
    fn posed_normals_are_the_moved_surfaces_normals_and_tangents_stay_across_them() {
        let mean = |e: &[(f32, f32)], k: fn(&(f32, f32)) -> f32| {
            e.iter().map(k).sum::<f32>() / e.len() as f32
        };
        for motion in Procedural::ALL {
            let (coarse, fine) = (
                posed_normal_errors(motion, 20_000),
                posed_normal_errors(motion, 80_000),
            );
            let (turned, unturned) = (mean(&fine, |e| e.0), mean(&fine, |e| e.1));
            let p99 = fine[fine.len() * 99 / 100].0;
            // Area-weighted normals follow the turned ones to first order in the
            // triangles' size: a quarter of the triangles' area, half the mean angle
            // (measured: 2.9–8.1 mrad, p99 10–47 mrad at 80k, 0.02 mrad for the rigid explosion).
            assert!(
                turned < 0.01 && p99 < 0.06,
                "{motion:?}: mean {turned}, p99 {p99} rad"
            );
            assert!(
                turned < 0.6 * mean(&coarse, |e| e.0) || turned < 1e-4,
                "{motion:?}: no closer on a finer mesh"
            );
            assert!(
                unturned > 0.3,
                "{motion:?}: the motion turns the surface ({unturned} rad)"
            );
        }
    }

    #[test]
    fn phase_zero_keeps_normals_bit_for_bit() {
        let mut mesh = crate::scenes::scan_blob(500, 2);
        let normals: Vec<[f32; 3]> = (0..mesh.positions.len())
            .map(|v| [0.6, 0.0, 0.8 + v as f32 * 1e-9])
            .collect();
        mesh.attributes
            .push(VertexAttribute::from_f32("NORMAL", &normals));
        for motion in Procedural::ALL {
            let mut posed = mesh.clone();
            Deform::new(&mesh, motion).pose(0.0, &mut posed);
            assert_eq!(posed.attributes, mesh.attributes, "{motion:?}");
        }
    }
}

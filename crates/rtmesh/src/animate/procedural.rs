//! Procedural motion of any mesh: `twist` (about the
//! vertical axis, growing with height), `bend` (about a horizontal axis through the
//! bottom), `wave` (a travelling sine along the longest axis), and `explode` (each
//! connected piece, or for a single piece each cell of a grid of about a thousand
//! cells, pushed out from the centre with a spin), standing in for the UNC exploding
//! dragon, which cannot be had here. Frame `f` of `n` is the motion at phase `f / (n −
//! 1)`, from the rest pose at 0 to the strongest at 1. O(V) per frame.

use crate::analysis::Pieces;
use crate::geom::Aabb;
use crate::mesh::TriMesh;
use glam::{Quat, Vec3};
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
        }
    }

    /// The motion it plays.
    pub fn motion(&self) -> Procedural {
        self.motion
    }

    /// The positions at `phase` in [0, 1].
    pub fn positions(&self, phase: f32) -> Vec<Vec3> {
        let b = &self.bounds;
        let extent = b.extent().max(Vec3::splat(f32::MIN_POSITIVE));
        let centre = b.center();
        (0..self.rest.len())
            .into_par_iter()
            .map(|v| {
                let p = self.rest[v];
                match self.motion {
                    Procedural::Twist => {
                        let h = (p.y - b.min.y) / extent.y;
                        let angle = phase * std::f32::consts::FRAC_PI_2 * h;
                        let q = Quat::from_rotation_y(angle);
                        centre + q * (p - centre)
                    }
                    Procedural::Bend => {
                        let h = (p.y - b.min.y) / extent.y;
                        let angle = phase * std::f32::consts::FRAC_PI_2 * h;
                        let pivot = Vec3::new(centre.x, b.min.y, centre.z);
                        pivot + Quat::from_rotation_x(angle) * (p - pivot)
                    }
                    Procedural::Wave => {
                        let axis = extent.max_element();
                        let (along, across) = if axis == extent.x {
                            ((p.x - b.min.x) / extent.x, Vec3::Y)
                        } else if axis == extent.y {
                            ((p.y - b.min.y) / extent.y, Vec3::Z)
                        } else {
                            ((p.z - b.min.z) / extent.z, Vec3::Y)
                        };
                        let offset =
                            0.1 * axis * phase * (std::f32::consts::TAU * 2.0 * along).sin();
                        p + across * offset
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
                        moved + spin * (p - c)
                    }
                }
            })
            .collect()
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
}

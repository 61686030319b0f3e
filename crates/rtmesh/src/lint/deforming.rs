//! Rebuild or refit, for a deforming mesh: the rest pose's BVH refitted to each pose,
//! its SAH cost against a BVH rebuilt for that pose. Cost: a build per pose.

use super::{Finding, Severity};
use crate::mesh::Scene;

/// Why [`lint_deforming`] could not compare the poses.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DeformingError {
    /// A pose's topology is not the rest pose's.
    #[error(transparent)]
    Mismatch(#[from] PoseMismatch),
    /// A pose holds too many instanced triangles to flatten into one geometry.
    #[error(transparent)]
    TooLarge(#[from] crate::mesh::TooManyToFlatten),
}

/// A pose given to [`lint_deforming`] whose topology is not the rest pose's.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("pose {pose} does not have the rest pose's topology ({triangles} triangles, {vertices} vertices)")]
pub struct PoseMismatch {
    /// The pose, counted from 1.
    pub pose: usize,
    /// The rest pose's triangles.
    pub triangles: usize,
    /// The rest pose's vertices.
    pub vertices: usize,
}

/// Rebuild or refit, for a deforming mesh: `rest` and each of `poses` must have the
/// same topology (same triangles, positions moved). Builds the tracer's BVH on the
/// rest pose, refits it to each pose, and compares its SAH cost with a BVH rebuilt on
/// that pose. Scenes are flattened to one geometry. Returns the finding, or an error
/// naming the pose whose topology differs.
pub fn lint_deforming(rest: &Scene, poses: &[Scene]) -> Result<Finding, DeformingError> {
    use crate::bvh::BuildSettings;
    use crate::trace::SceneAccel;
    let rest = Scene::from_mesh(rest.flatten()?);
    let mut accel = SceneAccel::build(&rest, &BuildSettings::default());
    let mut degradations = Vec::with_capacity(poses.len());
    for (k, pose) in poses.iter().enumerate() {
        let pose = Scene::from_mesh(pose.flatten()?);
        if pose.meshes[0].triangles != rest.meshes[0].triangles
            || pose.meshes[0].positions.len() != rest.meshes[0].positions.len()
        {
            return Err(PoseMismatch {
                pose: k + 1,
                triangles: rest.meshes[0].triangle_count(),
                vertices: rest.meshes[0].positions.len(),
            }
            .into());
        }
        accel.refit(&pose);
        let refit = accel.stats().sah_cost;
        let rebuilt = SceneAccel::build(&pose, &BuildSettings::default())
            .stats()
            .sah_cost;
        degradations.push(refit as f64 / (rebuilt as f64).max(f64::MIN_POSITIVE));
    }
    let worst = degradations.iter().copied().fold(1.0, f64::max);
    let rebuild = worst > 1.25;
    Ok(Finding {
        kind: "deforming-mesh",
        severity: if rebuild {
            Severity::Warning
        } else {
            Severity::Info
        },
        geometry: 0,
        count: poses.len(),
        worst: (0..degradations.len() as u32)
            .filter(|&k| degradations[k as usize] > 1.25)
            .collect(),
        figures: vec![("worst_refit_over_rebuild_sah", worst)],
        advice: if rebuild {
            "refitting loses more than 25% of the SAH quality on some poses: rebuild the \
             BVH for them (or every few frames), refit in between"
        } else {
            "refitting keeps the SAH cost within 25% of a rebuild: refit for these poses"
        },
    })
}

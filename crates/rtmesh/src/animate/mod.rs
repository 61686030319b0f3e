//! Animation for the dynamic-scene experiments: procedural motion of any mesh
//! (`procedural.rs`: twist, bend, wave, explode) and a glTF file's own animation
//! (`gltf.rs`: node channels, morph targets, linear-blend skinning). Either way a frame
//! is a set of positions for one mesh whose triangles never change, which is what a
//! per-frame BVH build, a refit or precomputed clusters need.

mod gltf;
mod procedural;

pub use procedural::Procedural;

use crate::mesh::{Scene, Semantic, TriMesh};
use glam::Vec3;
use std::fmt;
use std::str::FromStr;

/// A motion: procedural, or one of a glTF file's animations.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Motion {
    /// Procedural motion of the scene's first geometry.
    Procedural(Procedural),
    /// A glTF animation of the whole scene: the named one (or the one at that index),
    /// the first when `None`.
    Gltf(Option<String>),
}

impl FromStr for Motion {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if let Some(p) = Procedural::ALL.into_iter().find(|p| p.name() == s) {
            return Ok(Motion::Procedural(p));
        }
        match s.split_once(':') {
            _ if s == "gltf" => Ok(Motion::Gltf(None)),
            Some(("gltf", name)) if !name.is_empty() => Ok(Motion::Gltf(Some(name.to_owned()))),
            _ => Err(format!(
                "unknown motion `{s}`: expected twist, bend, wave, explode, gltf or gltf:NAME"
            )),
        }
    }
}

impl fmt::Display for Motion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Motion::Procedural(p) => f.write_str(p.name()),
            Motion::Gltf(None) => f.write_str("gltf"),
            Motion::Gltf(Some(name)) => write!(f, "gltf:{name}"),
        }
    }
}

impl serde::Serialize for Motion {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// Why a motion cannot be made for a scene.
#[derive(Debug, thiserror::Error)]
pub enum AnimationError {
    /// `gltf` on a file that is not glTF.
    #[error("motion gltf needs a glTF or GLB file")]
    NotGltf,
    /// `gltf` on a glTF file without animations.
    #[error("the file has no animations")]
    NoAnimations,
    /// `gltf:NAME` where no animation is called NAME.
    #[error("no animation is called or numbered `{wanted}`; the file has: {available}")]
    UnknownAnimation {
        /// The name asked for.
        wanted: String,
        /// The file's animations, by name (or index when unnamed).
        available: String,
    },
    /// The animation's data is malformed.
    #[error("{0}")]
    Invalid(String),
    /// Nothing to animate.
    #[error("the scene has no geometry to animate")]
    NoGeometry,
}

/// A motion made for one mesh: [`Animation::positions`] gives its vertices at any
/// phase.
pub struct Animation(Kind);

enum Kind {
    Procedural(procedural::Deform),
    Gltf(Box<gltf::GltfMotion>),
}

impl Animation {
    /// Procedural `motion` of `mesh`, from its current positions.
    pub fn procedural(mesh: &TriMesh, motion: Procedural) -> Self {
        Self(Kind::Procedural(procedural::Deform::new(mesh, motion)))
    }

    /// `motion` for `scene`, with the mesh it moves: the first geometry for a
    /// procedural motion; for a glTF animation the whole scene flattened into world
    /// space ([`Scene::flatten`]) without the skin and morph attributes, which a frame
    /// has applied.
    pub fn of(scene: &Scene, motion: &Motion) -> Result<(TriMesh, Self), AnimationError> {
        match motion {
            Motion::Procedural(p) => {
                let mesh = scene.meshes.first().ok_or(AnimationError::NoGeometry)?;
                Ok((mesh.clone(), Self::procedural(mesh, *p)))
            }
            Motion::Gltf(name) => {
                // Checked first: the motion keeps every instance's rest data too.
                let too_large = |e: crate::mesh::TooManyToFlatten| {
                    AnimationError::Invalid(format!("cannot flatten the scene: {e}"))
                };
                scene.check_flattenable().map_err(too_large)?;
                let motion = gltf::GltfMotion::new(scene, name.as_deref())?;
                let mut mesh = scene.flatten().map_err(too_large)?;
                if mesh.triangles.is_empty() {
                    return Err(AnimationError::NoGeometry);
                }
                mesh.attributes.retain(|a| {
                    !matches!(
                        a.semantic(),
                        Semantic::Joints | Semantic::Weights | Semantic::MorphDelta
                    )
                });
                // The directions each frame turns, as f32 (a quantized file stores
                // them as normalized integers, which a turned unit vector would not fit
                // exactly).
                for a in &mut mesh.attributes {
                    if DIRECTIONS.contains(&a.name.as_str()) {
                        *a = a.to_f32();
                    }
                }
                Ok((mesh, Self(Kind::Gltf(Box::new(motion)))))
            }
        }
    }

    /// The name of what plays: the procedural motion, or the glTF animation's name.
    pub fn name(&self) -> String {
        match &self.0 {
            Kind::Procedural(d) => d.motion().name().to_owned(),
            Kind::Gltf(g) => g.name.clone(),
        }
    }

    /// The positions at `phase` in [0, 1]: for a glTF animation, the time that far from
    /// its first key to its last.
    pub fn positions(&self, phase: f32) -> Vec<Vec3> {
        match &self.0 {
            Kind::Procedural(d) => d.positions(phase),
            Kind::Gltf(g) => g.evaluate(Self::time(g, phase), false).0,
        }
    }

    /// `mesh` (the one [`Animation::of`] gave) moved to `phase`: its positions, and its
    /// `NORMAL`s and `TANGENT`s turned with it (a tangent's w, the bitangent's sign,
    /// kept): by a procedural motion's Jacobian, or morphed and turned with a glTF
    /// animation's skin.
    pub fn pose(&self, phase: f32, mesh: &mut TriMesh) {
        match &self.0 {
            Kind::Procedural(d) => d.pose(phase, mesh),
            Kind::Gltf(g) => {
                let (positions, directions) = g.evaluate(Self::time(g, phase), true);
                mesh.positions = positions;
                let streams = [
                    ("NORMAL", directions.normals),
                    ("TANGENT", directions.tangents),
                ];
                for (name, turned) in streams {
                    let attribute = mesh.attributes.iter_mut().find(|a| a.name == name);
                    let Some(attribute) = attribute.filter(|a| a.vertex_count() == turned.len())
                    else {
                        continue;
                    };
                    let components = attribute.components;
                    if let crate::mesh::AttributeValues::F32(values) = &mut attribute.values {
                        for (slot, d) in values.chunks_exact_mut(components).zip(&turned) {
                            slot[..3].copy_from_slice(&d.to_array());
                        }
                    }
                }
            }
        }
    }

    fn time(g: &gltf::GltfMotion, phase: f32) -> f32 {
        let (start, end) = g.span();
        start + (end - start) * phase.clamp(0.0, 1.0)
    }
}

/// The vertex attributes a glTF frame turns with its skin and morphs.
const DIRECTIONS: [&str; 2] = ["NORMAL", "TANGENT"];

#[cfg(test)]
mod tests;

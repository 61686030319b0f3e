//! A glTF file's own animation, evaluated as the glTF 2.0 specification defines it
//! (§3.7.3 skins, §3.8 animations, Appendix C interpolation):
//!
//! - **Node channels.** Translation, rotation, scale and morph-target weights, sampled
//!   with `STEP` (the key at or before t), `LINEAR` (lerp; slerp for rotations) or
//!   `CUBICSPLINE` (the Hermite spline of each key's in-tangent, value and out-tangent,
//!   tangents scaled by the key interval; rotations renormalized). Before the first key
//!   the first value holds, after the last the last. A node given as a matrix keeps it
//!   until a channel targets it; it is then decomposed into T·R·S.
//! - **World transforms**, parent before child.
//! - **Morph targets.** `p = p₀ + Σₖ wₖ·δₖ`, the weights from a `weights` channel, else
//!   the node's, else the mesh's, else zero; normals and tangents take their targets'
//!   deltas the same way.
//! - **Linear-blend skinning.** A skinned vertex is `Σᵢ wᵢ · W(jointᵢ) · IBMᵢ · p`: the
//!   spec's joint matrix `W(mesh node)⁻¹ · W(joint) · IBM` followed by the mesh node's
//!   own world transform, which cancel. Weights are used as stored (the spec asks that
//!   they sum to one; the writer renormalizes them, the reader does not). Normals go
//!   through the inverse transpose of the blended matrix, tangents (their xyz; w, the
//!   bitangent's sign, is kept) through the matrix itself, and both are renormalized.
//!
//! The positions come out in world space in [`Scene::flatten`]'s order, so that one
//! mesh per frame can be built and traced. Every accessor is checked against its buffer
//! and its type before it is read, and every joint index against its skin. Cost per
//! frame: O(channels · log keys + nodes + Σ vertices · (4 · joint sets + targets)).

use super::AnimationError;
use crate::io::gltf::{check_accessor, ReadBudget};
use crate::io::{Document, GltfDocument};
use crate::mesh::{morph_name, Scene, TriMesh};
use glam::{Mat3, Mat4, Quat, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::animation::{Interpolation, Property};
use rayon::prelude::*;

/// A node's local transform: translation, rotation, scale.
#[derive(Clone, Copy, Debug)]
struct Trs {
    translation: Vec3,
    rotation: Quat,
    scale: Vec3,
}

/// What a channel animates, with its width in floats per key.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Path {
    Translation,
    Rotation,
    Scale,
    Weights(usize),
}

impl Path {
    fn width(self) -> usize {
        match self {
            Path::Translation | Path::Scale => 3,
            Path::Rotation => 4,
            Path::Weights(n) => n,
        }
    }
}

/// One channel: its target node and property, and its sampler's keys.
struct Channel {
    node: usize,
    path: Path,
    interpolation: Interpolation,
    times: std::sync::Arc<[f32]>,
    /// `width` floats per key, or 3·`width` for CUBICSPLINE (in-tangent, value,
    /// out-tangent).
    values: Vec<f32>,
}

/// A skin: its joints' nodes and inverse bind matrices.
struct Skin {
    joints: Vec<usize>,
    inverse_bind: Vec<Mat4>,
}

/// One instance of the scene, as the flattened mesh holds it.
struct Placement {
    node: Option<usize>,
    /// The instance's transform at rest (used when it has no node).
    rest_world: Mat4,
    skin: Option<usize>,
    rest: Vec<Vec3>,
    normals: Option<Directions>,
    /// TANGENT's xyz.
    tangents: Option<Directions>,
    /// Per vertex, 4 per joint set: the joint (an index into the skin's joints) and its
    /// weight.
    joints: Vec<u32>,
    weights: Vec<f32>,
    influences: usize,
    /// Morph target position deltas, target after target.
    deltas: Vec<Vec<Vec3>>,
    /// The weights the node or mesh gives its targets when no channel does.
    default_weights: Vec<f32>,
}

/// A stream of unit directions of an instance at rest (NORMAL, or TANGENT's xyz), with
/// the deltas of each morph target (`None` for a target that moves none).
struct Directions {
    rest: Vec<Vec3>,
    deltas: Vec<Option<Vec<Vec3>>>,
}

impl Directions {
    /// Vertex `v`'s direction under morph weights `weights`, before skinning.
    fn morphed(&self, v: usize, weights: &[f32]) -> Vec3 {
        let mut d = self.rest[v];
        for (delta, &w) in self.deltas.iter().zip(weights) {
            if let Some(delta) = delta {
                d += delta[v] * w;
            }
        }
        d
    }
}

/// The directions of a frame, in [`Scene::flatten`]'s order: for each stream, one per
/// vertex where any instance has it (zero where an instance has not, as flattening
/// fills it), else none.
#[derive(Default)]
pub(super) struct FrameDirections {
    pub(super) normals: Vec<Vec3>,
    pub(super) tangents: Vec<Vec3>,
}

/// A glTF animation ready to be evaluated at any time.
pub(super) struct GltfMotion {
    rest: Vec<Trs>,
    /// Nodes given as a matrix, with it.
    matrices: Vec<Option<Mat4>>,
    parents: Vec<Option<usize>>,
    /// Every node, parents before children.
    order: Vec<usize>,
    channels: Vec<Channel>,
    skins: Vec<Skin>,
    placements: Vec<Placement>,
    start: f32,
    end: f32,
    /// The animation's name, or its index when it has none.
    pub(super) name: String,
}

impl GltfMotion {
    /// Animation `wanted` (a name, or an index; the first when `None`) of `scene`.
    pub(super) fn new(scene: &Scene, wanted: Option<&str>) -> Result<Self, AnimationError> {
        let Some(Document::Gltf(source)) = scene.document.as_deref() else {
            return Err(AnimationError::NotGltf);
        };
        let GltfDocument { root, buffers } = source.as_ref();
        let document = gltf::Document::from_json(root.clone())
            .map_err(|e| AnimationError::Invalid(e.to_string()))?;
        let animations: Vec<gltf::Animation> = document.animations().collect();
        let name_of = |a: &gltf::Animation| {
            a.name()
                .map_or_else(|| a.index().to_string(), str::to_owned)
        };
        let animation = match wanted {
            None => animations.first(),
            Some(w) => animations
                .iter()
                .find(|a| a.name() == Some(w))
                .or_else(|| w.parse::<usize>().ok().and_then(|i| animations.get(i))),
        }
        .ok_or_else(|| {
            if animations.is_empty() {
                AnimationError::NoAnimations
            } else {
                AnimationError::UnknownAnimation {
                    wanted: wanted.unwrap_or_default().to_owned(),
                    available: animations
                        .iter()
                        .map(name_of)
                        .collect::<Vec<_>>()
                        .join(", "),
                }
            }
        })?;
        let buffer = |b: gltf::Buffer| buffers.get(b.index()).map(|d| &d[..]);
        // Channels commonly share their samplers' key times: each input is read once.
        let mut budget = ReadBudget::new(buffers.iter().map(Vec::len).sum());
        let mut inputs: std::collections::HashMap<usize, std::sync::Arc<[f32]>> =
            Default::default();
        let typed = |accessor: &gltf::Accessor,
                     what: &str,
                     dimensions: Dimensions,
                     float_only: bool|
         -> Result<(), AnimationError> {
            check_accessor(accessor, buffers)
                .map_err(|e| AnimationError::Invalid(format!("{what}: {e}")))?;
            let float = accessor.data_type() == DataType::F32;
            let normalized = accessor.normalized() && accessor.data_type() != DataType::U32;
            if accessor.dimensions() != dimensions || !(float || (!float_only && normalized)) {
                return Err(AnimationError::Invalid(format!(
                    "{what}: accessor {} is {:?} {:?}{}, expected {dimensions:?} of floats{}",
                    accessor.index(),
                    accessor.data_type(),
                    accessor.dimensions(),
                    if accessor.normalized() {
                        " normalized"
                    } else {
                        ""
                    },
                    if float_only {
                        ""
                    } else {
                        " or normalized integers"
                    }
                )));
            }
            Ok(())
        };

        let nodes: Vec<gltf::Node> = document.nodes().collect();
        let mut rest = Vec::with_capacity(nodes.len());
        let mut matrices = Vec::with_capacity(nodes.len());
        let mut parents = vec![None; nodes.len()];
        for node in &nodes {
            match node.transform() {
                gltf::scene::Transform::Matrix { matrix } => {
                    let m = Mat4::from_cols_array_2d(&matrix);
                    let (scale, rotation, translation) = m.to_scale_rotation_translation();
                    rest.push(Trs {
                        translation,
                        rotation,
                        scale,
                    });
                    matrices.push(Some(m));
                }
                gltf::scene::Transform::Decomposed {
                    translation,
                    rotation,
                    scale,
                } => {
                    rest.push(Trs {
                        translation: Vec3::from(translation),
                        rotation: Quat::from_array(rotation),
                        scale: Vec3::from(scale),
                    });
                    matrices.push(None);
                }
            }
            for child in node.children() {
                parents[child.index()] = Some(node.index());
            }
        }
        // Parents before children: a walk down from every node without a parent (the
        // reader refused nodes with two parents and cycles under the scene; nodes in a
        // cycle outside it are never reached and keep their local transform).
        let mut order = Vec::with_capacity(nodes.len());
        let mut stack: Vec<usize> = (0..nodes.len())
            .rev()
            .filter(|&n| parents[n].is_none())
            .collect();
        let mut seen = vec![false; nodes.len()];
        while let Some(n) = stack.pop() {
            if std::mem::replace(&mut seen[n], true) {
                continue;
            }
            order.push(n);
            stack.extend(nodes[n].children().map(|c| c.index()));
        }

        let mut channels = Vec::new();
        let (mut start, mut end) = (f32::INFINITY, f32::NEG_INFINITY);
        for (c, channel) in animation.channels().enumerate() {
            let what = format!("animation '{}' channel {c}", name_of(animation));
            let sampler = channel.sampler();
            let node = channel.target().node();
            let path = match channel.target().property() {
                Property::Translation => Path::Translation,
                Property::Rotation => Path::Rotation,
                Property::Scale => Path::Scale,
                Property::MorphTargetWeights => Path::Weights(
                    node.mesh()
                        .and_then(|m| m.primitives().next())
                        .map_or(0, |p| p.morph_targets().len()),
                ),
            };
            let input = sampler.input();
            typed(&input, &format!("{what} input"), Dimensions::Scalar, true)?;
            let output = sampler.output();
            let dimensions = match path {
                Path::Translation | Path::Scale => Dimensions::Vec3,
                Path::Rotation => Dimensions::Vec4,
                Path::Weights(_) => Dimensions::Scalar,
            };
            typed(
                &output,
                &format!("{what} output"),
                dimensions,
                matches!(path, Path::Translation | Path::Scale),
            )?;
            let charge = |budget: &mut ReadBudget, accessor: &gltf::Accessor, part: &str| {
                budget
                    .take(accessor.count().saturating_mul(accessor.size()), || {
                        format!("{what} {part}")
                    })
                    .map_err(AnimationError::Invalid)
            };
            let reader = channel.reader(buffer);
            let times = match inputs.get(&input.index()) {
                Some(times) => times.clone(),
                None => {
                    charge(&mut budget, &input, "input")?;
                    let times: std::sync::Arc<[f32]> = reader
                        .read_inputs()
                        .ok_or_else(|| {
                            AnimationError::Invalid(format!("{what}: unreadable input"))
                        })?
                        .collect();
                    inputs.insert(input.index(), times.clone());
                    times
                }
            };
            if times.is_empty()
                || times.iter().any(|t| !t.is_finite())
                || times.windows(2).any(|w| w[1] < w[0])
            {
                return Err(AnimationError::Invalid(format!(
                    "{what}: its {} keyframe times are not finite and increasing",
                    times.len()
                )));
            }
            charge(&mut budget, &output, "output")?;
            let values: Vec<f32> = match reader.read_outputs() {
                Some(gltf::animation::util::ReadOutputs::Translations(v))
                | Some(gltf::animation::util::ReadOutputs::Scales(v)) => v.flatten().collect(),
                Some(gltf::animation::util::ReadOutputs::Rotations(v)) => {
                    v.into_f32().flatten().collect()
                }
                Some(gltf::animation::util::ReadOutputs::MorphTargetWeights(v)) => {
                    v.into_f32().collect()
                }
                None => {
                    return Err(AnimationError::Invalid(format!(
                        "{what}: unreadable output"
                    )))
                }
            };
            let interpolation = sampler.interpolation();
            let per_key = path.width()
                * if interpolation == Interpolation::CubicSpline {
                    3
                } else {
                    1
                };
            if values.len() != times.len() * per_key {
                return Err(AnimationError::Invalid(format!(
                    "{what}: {} output values for {} keys of {per_key}",
                    values.len(),
                    times.len()
                )));
            }
            start = start.min(times[0]);
            end = end.max(times[times.len() - 1]);
            channels.push(Channel {
                node: node.index(),
                path,
                interpolation,
                times,
                values,
            });
        }
        if channels.is_empty() {
            (start, end) = (0.0, 0.0);
        }

        let mut skins = Vec::new();
        for skin in document.skins() {
            let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
            let inverse_bind = match skin.inverse_bind_matrices() {
                Some(accessor) => {
                    let what = format!("skin {} inverseBindMatrices", skin.index());
                    typed(&accessor, &what, Dimensions::Mat4, true)?;
                    budget
                        .take(accessor.count().saturating_mul(accessor.size()), || {
                            what.clone()
                        })
                        .map_err(AnimationError::Invalid)?;
                    let matrices: Vec<Mat4> = skin
                        .reader(buffer)
                        .read_inverse_bind_matrices()
                        .ok_or_else(|| AnimationError::Invalid(format!("{what}: unreadable")))?
                        .map(|m| Mat4::from_cols_array_2d(&m))
                        .collect();
                    if matrices.len() < joints.len() {
                        return Err(AnimationError::Invalid(format!(
                            "{what}: {} matrices for {} joints",
                            matrices.len(),
                            joints.len()
                        )));
                    }
                    matrices
                }
                None => vec![Mat4::IDENTITY; joints.len()],
            };
            skins.push(Skin {
                joints,
                inverse_bind,
            });
        }

        let placements = scene
            .instances
            .iter()
            .map(|instance| {
                let mesh = &scene.meshes[instance.mesh];
                let node = instance.source_node.map(|n| n as usize);
                let gltf_node = node.and_then(|n| nodes.get(n));
                let skin = gltf_node.and_then(|n| n.skin()).map(|s| s.index());
                let default_weights = gltf_node
                    .and_then(|n| n.weights().or_else(|| n.mesh().and_then(|m| m.weights())))
                    .map(<[f32]>::to_vec)
                    .unwrap_or_default();
                placement(
                    mesh,
                    node,
                    Mat4::from(instance.transform),
                    skin.map(|s| (s, skins[s].joints.len())),
                    default_weights,
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            rest,
            matrices,
            parents,
            order,
            channels,
            skins,
            placements,
            start,
            end,
            name: name_of(animation),
        })
    }

    /// The animation's time span in seconds: its first and last key over all channels.
    pub(super) fn span(&self) -> (f32, f32) {
        (self.start, self.end)
    }

    /// Each node's world transform and each node's morph weights from a channel, at
    /// time `t`.
    fn pose(&self, t: f32) -> (Vec<Mat4>, Vec<Option<Vec<f32>>>) {
        let mut local = self.rest.clone();
        let mut animated = vec![false; local.len()];
        let mut weights: Vec<Option<Vec<f32>>> = vec![None; local.len()];
        let mut value = Vec::new();
        for channel in &self.channels {
            sample(channel, t, &mut value);
            let trs = &mut local[channel.node];
            match channel.path {
                Path::Translation => trs.translation = Vec3::from_slice(&value),
                Path::Rotation => {
                    trs.rotation = Quat::from_vec4(Vec4::from_slice(&value)).normalize()
                }
                Path::Scale => trs.scale = Vec3::from_slice(&value),
                Path::Weights(_) => weights[channel.node] = Some(value.clone()),
            }
            animated[channel.node] = true;
        }
        let mut world = vec![Mat4::IDENTITY; local.len()];
        for &n in &self.order {
            let own = match self.matrices[n] {
                Some(m) if !animated[n] => m,
                _ => Mat4::from_scale_rotation_translation(
                    local[n].scale,
                    local[n].rotation,
                    local[n].translation,
                ),
            };
            world[n] = match self.parents[n] {
                Some(p) => world[p] * own,
                None => own,
            };
        }
        (world, weights)
    }

    /// The world-space positions of every instance's vertices at time `t`, in
    /// [`Scene::flatten`]'s order, and with `with_directions` their normals and
    /// tangents.
    pub(super) fn evaluate(&self, t: f32, with_directions: bool) -> (Vec<Vec3>, FrameDirections) {
        let (world, channel_weights) = self.pose(t);
        let mut positions = Vec::new();
        let mut directions = FrameDirections::default();
        let any = |pick: fn(&Placement) -> bool| self.placements.iter().any(pick);
        let with_normals = with_directions && any(|p| p.normals.is_some());
        let with_tangents = with_directions && any(|p| p.tangents.is_some());
        for placement in &self.placements {
            let weights = placement
                .node
                .and_then(|n| channel_weights[n].as_deref())
                .unwrap_or(&placement.default_weights);
            let node_world = placement.node.map_or(placement.rest_world, |n| world[n]);
            let joint_matrices: Vec<Mat4> = placement.skin.map_or_else(Vec::new, |s| {
                let skin = &self.skins[s];
                skin.joints
                    .iter()
                    .zip(&skin.inverse_bind)
                    .map(|(&j, ibm)| world[j] * *ibm)
                    .collect()
            });
            let matrix_of = |v: usize| -> Mat4 {
                if placement.skin.is_none() {
                    return node_world;
                }
                let k = placement.influences;
                let mut m = Mat4::ZERO;
                for i in v * k..(v + 1) * k {
                    let w = placement.weights[i];
                    if w != 0.0 {
                        m += joint_matrices[placement.joints[i] as usize] * w;
                    }
                }
                m
            };
            let start = positions.len();
            positions.par_extend((0..placement.rest.len()).into_par_iter().map(|v| {
                let mut p = placement.rest[v];
                for (delta, &w) in placement.deltas.iter().zip(weights) {
                    p += delta[v] * w;
                }
                matrix_of(v).transform_point3(p)
            }));
            debug_assert_eq!(positions.len() - start, placement.rest.len());
            let vertices = placement.rest.len();
            // Zeros where this instance has no such stream, as flattening fills it.
            let turned = |stream: &Option<Directions>, out: &mut Vec<Vec3>, normal: bool| {
                let Some(stream) = stream else {
                    out.resize(out.len() + vertices, Vec3::ZERO);
                    return;
                };
                out.par_extend((0..vertices).into_par_iter().map(|v| {
                    let d = stream.morphed(v, weights);
                    let linear = Mat3::from_mat4(matrix_of(v));
                    let linear = if normal {
                        linear.inverse().transpose()
                    } else {
                        linear
                    };
                    (linear * d).normalize_or(d)
                }));
            };
            if with_normals {
                turned(&placement.normals, &mut directions.normals, true);
            }
            if with_tangents {
                turned(&placement.tangents, &mut directions.tangents, false);
            }
        }
        (positions, directions)
    }
}

/// Channel `channel`'s value at time `t`, into `out`.
fn sample(channel: &Channel, t: f32, out: &mut Vec<f32>) {
    let width = channel.path.width();
    let times = &channel.times;
    let cubic = channel.interpolation == Interpolation::CubicSpline;
    // Key k's value, and for CUBICSPLINE its in- and out-tangents.
    let stride = if cubic { 3 * width } else { width };
    let value = |k: usize| {
        let at = k * stride + if cubic { width } else { 0 };
        &channel.values[at..at + width]
    };
    out.clear();
    let after = times.partition_point(|&key| key <= t);
    if after == 0 || after == times.len() || channel.interpolation == Interpolation::Step {
        out.extend_from_slice(value(after.saturating_sub(1)));
        return;
    }
    let k = after - 1;
    let interval = times[k + 1] - times[k];
    let s = if interval > 0.0 {
        (t - times[k]) / interval
    } else {
        0.0
    };
    let (a, b) = (value(k), value(k + 1));
    match channel.interpolation {
        Interpolation::Linear if channel.path == Path::Rotation => {
            let q = Quat::from_vec4(Vec4::from_slice(a))
                .normalize()
                .slerp(Quat::from_vec4(Vec4::from_slice(b)).normalize(), s);
            out.extend_from_slice(&q.to_array());
        }
        Interpolation::Linear => out.extend(a.iter().zip(b).map(|(x, y)| x + (y - x) * s)),
        _ => {
            let out_tangent = &channel.values[k * stride + 2 * width..][..width];
            let in_tangent = &channel.values[(k + 1) * stride..][..width];
            let (s2, s3) = (s * s, s * s * s);
            out.extend((0..width).map(|i| {
                (2.0 * s3 - 3.0 * s2 + 1.0) * a[i]
                    + interval * (s3 - 2.0 * s2 + s) * out_tangent[i]
                    + (-2.0 * s3 + 3.0 * s2) * b[i]
                    + interval * (s3 - s2) * in_tangent[i]
            }));
        }
    }
}

/// An instance's rest data: positions, normals, joints and weights (checked against
/// the skin's joint count), morph deltas.
fn placement(
    mesh: &TriMesh,
    node: Option<usize>,
    rest_world: Mat4,
    skin: Option<(usize, usize)>,
    default_weights: Vec<f32>,
) -> Result<Placement, AnimationError> {
    let vertices = mesh.positions.len();
    // The numbers stored values stand for (quantized normals are normalized integers).
    let xyz = |a: &crate::mesh::VertexAttribute| -> Vec<Vec3> {
        (0..vertices)
            .map(|v| {
                Vec3::new(
                    a.value(v, 0) as f32,
                    a.value(v, 1) as f32,
                    a.value(v, 2) as f32,
                )
            })
            .collect()
    };
    let mut deltas = Vec::new();
    while let Some(delta) = mesh.attribute(&morph_name(deltas.len(), "POSITION")) {
        deltas.push(xyz(delta));
    }
    let directions = |name: &str, components: usize| {
        let rest = mesh
            .attribute(name)
            .filter(|a| a.components == components)?;
        Some(Directions {
            rest: xyz(rest),
            deltas: (0..deltas.len())
                .map(|k| mesh.attribute(&morph_name(k, name)).map(xyz))
                .collect(),
        })
    };
    let (normals, tangents) = (directions("NORMAL", 3), directions("TANGENT", 4));
    let (mut joints, mut weights) = (Vec::new(), Vec::new());
    let mut sets = 0;
    if let Some((s, joint_count)) = skin {
        while let (Some(j), Some(w)) = (
            mesh.attribute(&format!("JOINTS_{sets}")),
            mesh.attribute(&format!("WEIGHTS_{sets}")),
        ) {
            if j.components != 4 || w.components != 4 {
                return Err(AnimationError::Invalid(format!(
                    "JOINTS_{sets} and WEIGHTS_{sets} must be VEC4"
                )));
            }
            sets += 1;
        }
        if sets == 0 {
            return Err(AnimationError::Invalid(format!(
                "mesh '{}' is skinned (skin {s}) but has no JOINTS_0 and WEIGHTS_0",
                mesh.name
            )));
        }
        joints.reserve(vertices * 4 * sets);
        weights.reserve(vertices * 4 * sets);
        for v in 0..vertices {
            for set in 0..sets {
                let j = mesh.attribute(&format!("JOINTS_{set}")).expect("counted");
                let w = mesh.attribute(&format!("WEIGHTS_{set}")).expect("counted");
                let scale = match &w.values {
                    _ if !w.normalized => 1.0,
                    crate::mesh::AttributeValues::U8(_) => 1.0 / 255.0,
                    crate::mesh::AttributeValues::U16(_) => 1.0 / 65535.0,
                    _ => 1.0,
                };
                for c in 0..4 {
                    let weight = (w.get(v, c) * scale) as f32;
                    let joint = j.get(v, c);
                    if weight != 0.0 && !(joint >= 0.0 && (joint as usize) < joint_count) {
                        return Err(AnimationError::Invalid(format!(
                            "mesh '{}' vertex {v} names joint {joint} (weight {weight}) but skin {s} has {joint_count} joints",
                            mesh.name
                        )));
                    }
                    if !weight.is_finite() {
                        return Err(AnimationError::Invalid(format!(
                            "mesh '{}' vertex {v} has weight {weight}",
                            mesh.name
                        )));
                    }
                    joints.push(if weight != 0.0 { joint as u32 } else { 0 });
                    weights.push(weight);
                }
            }
        }
    }
    Ok(Placement {
        node,
        rest_world,
        skin: skin.map(|(s, _)| s),
        rest: mesh.positions.clone(),
        normals,
        tangents,
        joints,
        weights,
        influences: 4 * sets,
        deltas,
        default_weights,
    })
}

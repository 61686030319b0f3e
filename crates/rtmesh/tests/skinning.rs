//! glTF animation against a reference: the specification's formulas written again in
//! f64, straight from the gltf crate's readers (node TRS sampled LINEAR or STEP,
//! world transforms down the scene's trees, Σ wᵢ · W(jointᵢ) · IBMᵢ · p), compared
//! with `Animation::positions` corner by corner on every sample model in
//! `animated/`, at five times through each animation.

use glam::{DMat4, DQuat, DVec3};
use gltf::animation::util::ReadOutputs;
use gltf::animation::{Interpolation, Property};
use rtmesh::animate::{Animation, Motion};
use rtmesh::data::mesh_data_dir;

/// Sampled value at `t`: the keys' values `values[k]` (each of `width` f64).
fn sample(times: &[f64], values: &[Vec<f64>], step: bool, rotation: bool, t: f64) -> Vec<f64> {
    let after = times.iter().filter(|&&k| k <= t).count();
    if after == 0 || after == times.len() || step {
        return values[after.max(1) - 1].clone();
    }
    let k = after - 1;
    let s = (t - times[k]) / (times[k + 1] - times[k]);
    if rotation {
        let q = |v: &[f64]| DQuat::from_xyzw(v[0], v[1], v[2], v[3]).normalize();
        let mut b = q(&values[k + 1]);
        let a = q(&values[k]);
        if a.dot(b) < 0.0 {
            b = -b;
        }
        return a.slerp(b, s).to_array().to_vec();
    }
    values[k]
        .iter()
        .zip(&values[k + 1])
        .map(|(a, b)| a + (b - a) * s)
        .collect()
}

/// Every triangle corner's world position at time `t`, in the reader's order (nodes
/// depth first from the scene's roots, primitives in order).
fn reference(
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    animation: usize,
    t: f64,
) -> Vec<DVec3> {
    let get = |b: gltf::Buffer| Some(&buffers[b.index()].0[..]);
    let mut local: Vec<(DVec3, DQuat, DVec3)> = document
        .nodes()
        .map(|n| {
            let (t, r, s) = n.transform().decomposed();
            (
                DVec3::from(t.map(f64::from)),
                DQuat::from_array(r.map(f64::from)),
                DVec3::from(s.map(f64::from)),
            )
        })
        .collect();
    let animation = document.animations().nth(animation).unwrap();
    for channel in animation.channels() {
        let reader = channel.reader(get);
        let times: Vec<f64> = reader.read_inputs().unwrap().map(f64::from).collect();
        let values: Vec<Vec<f64>> = match reader.read_outputs().unwrap() {
            ReadOutputs::Translations(v) | ReadOutputs::Scales(v) => {
                v.map(|x| x.map(f64::from).to_vec()).collect()
            }
            ReadOutputs::Rotations(v) => v.into_f32().map(|x| x.map(f64::from).to_vec()).collect(),
            ReadOutputs::MorphTargetWeights(_) => continue,
        };
        let sampler = channel.sampler().interpolation();
        assert_ne!(sampler, Interpolation::CubicSpline, "the samples have none");
        let property = channel.target().property();
        let v = sample(
            &times,
            &values,
            sampler == Interpolation::Step,
            property == Property::Rotation,
            t,
        );
        let node = &mut local[channel.target().node().index()];
        match property {
            Property::Translation => node.0 = DVec3::new(v[0], v[1], v[2]),
            Property::Rotation => node.1 = DQuat::from_xyzw(v[0], v[1], v[2], v[3]).normalize(),
            Property::Scale => node.2 = DVec3::new(v[0], v[1], v[2]),
            Property::MorphTargetWeights => {}
        }
    }
    let mut world = vec![DMat4::IDENTITY; local.len()];
    let mut placed = Vec::new();
    fn walk(
        n: gltf::Node,
        parent: DMat4,
        local: &[(DVec3, DQuat, DVec3)],
        world: &mut [DMat4],
        placed: &mut Vec<usize>,
    ) {
        let (t, r, s) = local[n.index()];
        world[n.index()] = parent * DMat4::from_scale_rotation_translation(s, r, t);
        if n.mesh().is_some() {
            placed.push(n.index());
        }
        for child in n.children() {
            walk(child, world[n.index()], local, world, placed);
        }
    }
    for root in document.default_scene().unwrap().nodes() {
        walk(root, DMat4::IDENTITY, &local, &mut world, &mut placed);
    }
    let nodes: Vec<gltf::Node> = document.nodes().collect();
    let mut corners = Vec::new();
    for &n in &placed {
        let node = &nodes[n];
        let joints: Vec<DMat4> = node.skin().map_or_else(Vec::new, |skin| {
            let ibms: Vec<DMat4> = skin
                .reader(get)
                .read_inverse_bind_matrices()
                .unwrap()
                .map(|m| glam::Mat4::from_cols_array_2d(&m).as_dmat4())
                .collect();
            skin.joints()
                .zip(ibms)
                .map(|(j, ibm)| world[j.index()] * ibm)
                .collect()
        });
        for primitive in node.mesh().unwrap().primitives() {
            let reader = primitive.reader(get);
            let positions: Vec<DVec3> = reader
                .read_positions()
                .unwrap()
                .map(|p| DVec3::from(p.map(f64::from)))
                .collect();
            let moved: Vec<DVec3> = if joints.is_empty() {
                positions
                    .iter()
                    .map(|&p| world[n].transform_point3(p))
                    .collect()
            } else {
                let js: Vec<[u16; 4]> = reader.read_joints(0).unwrap().into_u16().collect();
                let ws: Vec<[f32; 4]> = reader.read_weights(0).unwrap().into_f32().collect();
                positions
                    .iter()
                    .enumerate()
                    .map(|(v, &p)| {
                        (0..4)
                            .filter(|&i| ws[v][i] != 0.0)
                            .map(|i| {
                                ws[v][i] as f64 * joints[js[v][i] as usize].transform_point3(p)
                            })
                            .sum()
                    })
                    .collect()
            };
            let indices: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..positions.len() as u32).collect(),
            };
            corners.extend(indices.iter().map(|&i| moved[i as usize]));
        }
    }
    corners
}

#[test]
fn skinning_matches_the_f64_reference_on_every_sample_model() {
    let Some(dir) = mesh_data_dir() else { return };
    let dir = dir.join("animated");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "glb") {
            continue;
        }
        let scene = rtmesh::io::read(&path).unwrap();
        let (document, buffers, _) = gltf::import(&path).unwrap();
        let (mesh, animation) = Animation::of(&scene, &Motion::Gltf(None)).unwrap();
        let (start, end) = document
            .animations()
            .next()
            .unwrap()
            .channels()
            .flat_map(|c| {
                c.reader(|b| Some(&buffers[b.index()].0[..]))
                    .read_inputs()
                    .unwrap()
            })
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), t| {
                (a.min(t), b.max(t))
            });
        let diagonal = mesh.bounds().diagonal_length() as f64;
        for phase in [0.0f32, 0.25, 0.5, 0.75, 1.0] {
            let t = start as f64 + (end as f64 - start as f64) * phase as f64;
            let expected = reference(&document, &buffers, 0, t);
            let positions = animation.positions(phase);
            let got: Vec<DVec3> = mesh
                .triangles
                .iter()
                .flatten()
                .map(|&v| positions[v as usize].as_dvec3())
                .collect();
            assert_eq!(got.len(), expected.len(), "{}", path.display());
            let worst = got
                .iter()
                .zip(&expected)
                .map(|(a, b)| (*a - *b).length())
                .fold(0.0, f64::max);
            assert!(
                worst < 1e-4 * diagonal,
                "{} at phase {phase}: off by {worst} (diagonal {diagonal})",
                path.display()
            );
        }
        checked += 1;
    }
    assert_eq!(checked, 6, "the six sample models of animated/MANIFEST.tsv");
}

//! Packet traversal returns the single-ray results: for every intersector, camera
//! packets of 2×2, 4×4 and 8×8 rays (partial packets at the image edges included) hit
//! the same triangle at the same `t` as the same rays traced alone (exact ties in `t`
//! between two triangles aside: counted and bounded), and shadow packets from one hit
//! point report the same occlusion.

use glam::Vec3;
use rtmesh::bvh::BuildSettings;
use rtmesh::random::SplitMix64;
use rtmesh::trace::intersect::{
    Intersector, Moller, MollerPacket, MollerPre, Pluecker, Watertight,
};
use rtmesh::trace::packet::PacketBuffer;
use rtmesh::trace::run::{trace_closest_by, trace_packets_closest};
use rtmesh::trace::{Camera, NoCounters, RayCounters, SceneAccel, Workload};
use rtmesh::{Ray, Scene};

fn scenes() -> Vec<(&'static str, Scene)> {
    vec![
        (
            "blob",
            Scene::from_mesh(rtmesh::scenes::scan_blob(20_000, 3)),
        ),
        ("grid", Scene::from_mesh(rtmesh::scenes::rotated_grid(40))),
        (
            "cylinder",
            Scene::from_mesh(rtmesh::scenes::fan_cylinder(64)),
        ),
        ("room (two levels: ray by ray)", rtmesh::scenes::room()),
    ]
}

fn cameras(scene: &Scene, width: usize, height: usize) -> Vec<Camera> {
    let bounds = scene.bounds();
    let centre = bounds.center();
    let distance = 1.5 * bounds.diagonal_length();
    vec![
        Camera::default_for(&bounds, width, height),
        // Straight down −Z: packets in the middle column mix direction signs in x.
        Camera::look_at(centre + Vec3::Z * distance, centre, 50.0, width, height),
    ]
}

fn packets_match_single_rays<I: Intersector>() {
    let (width, height) = (90, 70);
    for (name, scene) in scenes() {
        let accel = SceneAccel::build(&scene, &BuildSettings::default());
        let (mut hits, mut rays) = (0, 0);
        for camera in cameras(&scene, width, height) {
            for side in [2, 4, 8] {
                let (work, starts) = Workload::primary_packets(&camera, width, height, side);
                let (single, single_counts) =
                    trace_closest_by::<I, RayCounters>(&accel, &work.rays);
                let (packed, packed_counts) =
                    trace_packets_closest::<I, RayCounters>(&accel, &work.rays, &starts);
                let uncounted =
                    trace_packets_closest::<I, NoCounters>(&accel, &work.rays, &starts).0;
                assert_eq!(packed, uncounted, "{name}: counters change results");
                let mut ties = 0;
                for (i, (a, b)) in single.iter().zip(&packed).enumerate() {
                    assert_eq!(
                        a.t.to_bits(),
                        b.t.to_bits(),
                        "{name} {}x{side} ray {i}: {a:?} {b:?}",
                        side
                    );
                    if a.triangle == b.triangle {
                        assert_eq!(a, b, "{name} {side}x{side} ray {i}");
                    } else {
                        ties += 1;
                    }
                }
                hits += single.iter().filter(|h| h.is_hit()).count();
                rays += work.rays.len();
                assert!(ties * 1000 <= work.rays.len(), "{name}: {ties} ties");
                let tests = |c: &[RayCounters]| c.iter().map(|c| c.triangle_tests).sum::<u64>();
                assert!(tests(&packed_counts) > 0 && tests(&single_counts) > 0);
            }
        }
        assert!(hits > rays / 10, "{name}: only {hits} hits of {rays} rays");
    }
}

#[test]
fn moller_packets_match_single_rays() {
    packets_match_single_rays::<Moller>();
}

#[test]
fn moller_pre_packets_match_single_rays() {
    packets_match_single_rays::<MollerPre>();
}

#[test]
fn moller_packet_packets_match_single_rays() {
    packets_match_single_rays::<MollerPacket>();
}

#[test]
fn pluecker_packets_match_single_rays() {
    packets_match_single_rays::<Pluecker>();
}

#[test]
fn watertight_packets_match_single_rays() {
    packets_match_single_rays::<Watertight>();
}

/// Shadow packets: from each of a sample of primary hits, 16 rays towards points of an
/// area light above the scene (one origin per packet).
#[test]
fn shadow_packets_match_single_rays() {
    let mut rng = SplitMix64::new(11);
    for (name, scene) in scenes() {
        let accel = SceneAccel::build(&scene, &BuildSettings::default());
        let bounds = scene.bounds();
        let camera = Camera::default_for(&bounds, 64, 64);
        let primary = Workload::primary(&camera, 64, 64);
        let hits = trace_closest_by::<MollerPacket, NoCounters>(&accel, &primary.rays).0;
        let light = bounds.center() + Vec3::Y * bounds.diagonal_length();
        let mut buffer = PacketBuffer::default();
        let mut occluded_rays = 0;
        for (ray, hit) in primary.rays.iter().zip(&hits).step_by(7) {
            if !hit.is_hit() {
                continue;
            }
            let origin = ray.at(hit.t * 0.999);
            let rays: Vec<Ray> = (0..16)
                .map(|_| {
                    let sample = light
                        + Vec3::new(rng.next_f32() - 0.5, 0.0, rng.next_f32() - 0.5)
                            * bounds.diagonal_length();
                    Ray {
                        origin,
                        direction: sample - origin,
                        t_min: 0.0,
                        t_max: 1.0,
                    }
                })
                .collect();
            let mut packed = vec![false; rays.len()];
            let mut counters = vec![NoCounters; rays.len()];
            accel.occluded_packet::<MollerPacket, _>(
                &mut buffer,
                &rays,
                &mut packed,
                &mut counters,
            );
            for (ray, &blocked) in rays.iter().zip(&packed) {
                let alone = accel.occluded_by::<MollerPacket, _>(ray, &mut NoCounters);
                assert_eq!(alone, blocked, "{name}: {ray:?}");
                occluded_rays += blocked as usize;
            }
        }
        eprintln!("{name}: {occluded_rays} occluded shadow rays");
    }
}

/// Packets holding NaN, zero, infinite and axis-parallel directions give exactly what
/// the rays give alone (misses for the broken ones), with no panic.
#[test]
fn awkward_rays_in_packets_match_single_rays() {
    let scene = Scene::from_mesh(rtmesh::scenes::scan_blob(5_000, 6));
    let accel = SceneAccel::build(&scene, &BuildSettings::default());
    let eye = scene.bounds().center() + Vec3::new(0.0, 0.0, 3.0) * scene.bounds().diagonal_length();
    let directions = [
        Vec3::NAN,
        Vec3::ZERO,
        Vec3::new(f32::INFINITY, 0.0, -1.0),
        -Vec3::Z,
        Vec3::new(0.0, 1e-30, -1.0),
        Vec3::new(0.01, -0.01, -1.0),
        Vec3::new(-0.01, 0.01, -1.0),
        Vec3::new(0.0, 0.0, -1e-20),
    ];
    let rays: Vec<Ray> = directions.iter().map(|&d| Ray::new(eye, d)).collect();
    let mut buffer = PacketBuffer::default();
    let mut hits = vec![rtmesh::trace::Hit::MISS; rays.len()];
    let mut counters = vec![NoCounters; rays.len()];
    accel.intersect_packet::<MollerPacket, _>(&mut buffer, &rays, &mut hits, &mut counters);
    let mut occluded = vec![false; rays.len()];
    accel.occluded_packet::<MollerPacket, _>(&mut buffer, &rays, &mut occluded, &mut counters);
    for (i, ray) in rays.iter().enumerate() {
        assert_eq!(
            hits[i],
            accel.intersect_by::<MollerPacket, _>(ray, &mut NoCounters),
            "ray {i}"
        );
        assert_eq!(
            occluded[i],
            accel.occluded_by::<MollerPacket, _>(ray, &mut NoCounters),
            "ray {i}"
        );
    }
    assert!(!hits[0].is_hit() && !hits[1].is_hit());
    assert!(hits[3].is_hit());
}

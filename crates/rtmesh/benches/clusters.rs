//! One animated frame's BVH over precomputed clusters against a full rebuild, on the
//! Stanford dragon (871k triangles) twisted halfway when the data is present, else on
//! the 100k-triangle procedural blob (clusters grouped each frame and at rest); and the
//! two clusterings by Acc(k).

use criterion::{criterion_group, criterion_main, Criterion};
use rtmesh::animate::{Animation, Procedural};
use rtmesh::bvh::BuildSettings;
use rtmesh::cluster::{ClusterFrames, ClusterMethod, ClusterSettings, Grouping, Inside};
use rtmesh::trace::SceneAccel;
use rtmesh::Scene;

fn bench(c: &mut Criterion) {
    let (name, mesh) = rtmesh::data::dragon_or_blob();
    let mut frame = mesh.clone();
    frame.positions = Animation::procedural(&mesh, Procedural::Twist).positions(0.5);
    let scene = Scene::from_mesh(frame.clone());
    let settings = ClusterSettings::default();
    let clusters = ClusterMethod::Grow.cluster(&mesh, &settings);
    let mut group = c.benchmark_group("clusters");
    group.sample_size(10);
    let arrangements = [
        (Inside::Node, Grouping::Frame),
        (Inside::Node, Grouping::Rest),
        (Inside::Flat, Grouping::Frame),
    ];
    for (inside, grouping) in arrangements {
        let mut frames = ClusterFrames::new(&clusters, inside, &mesh).grouped(grouping, &mesh);
        let groups = grouping.name();
        group.bench_function(format!("frame/{inside:?}/{groups}/{name}"), |b| {
            b.iter(|| {
                let accel = frames.build(&frame);
                frames.recycle(accel);
            })
        });
    }
    group.bench_function(format!("rebuild/{name}"), |b| {
        b.iter(|| SceneAccel::build(&scene, &BuildSettings::default()))
    });
    for method in [ClusterMethod::Grow, ClusterMethod::Contract] {
        group.bench_function(format!("{method}/{name}"), |b| {
            b.iter(|| method.cluster(&mesh, &settings))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

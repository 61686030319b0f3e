//! The intersectors and packet traversal, one thread, counters off:
//! - the packet paper's experiment (no BVH, 128×128 primary rays in 2×2 packets,
//!   every ray against every triangle of a 2,000-triangle blob): scalar `moller-pre`,
//!   scalar and 8-wide `moller-packet`;
//! - primary rays at 256×256 on the 100k-triangle blob: single rays against 8×8
//!   packets with `moller-packet`.
//!
//! `rtmesh bench intersect` and `rtmesh bench packets` print the full tables.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rtmesh::bvh::BuildSettings;
use rtmesh::trace::intersect::{closest_without_bvh, MollerPacket, MollerPre, Simd, TriangleSoa};
use rtmesh::trace::run::{trace_closest, trace_packets_closest};
use rtmesh::trace::{Camera, Hit, NoCounters, SceneAccel, Workload};
use rtmesh::Scene;

fn bench(c: &mut Criterion) {
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");

    let mesh = rtmesh::scenes::scan_blob(2_000, 2);
    let soa = TriangleSoa::from_mesh(&mesh);
    let camera = Camera::default_for(&rtmesh::Aabb::from_points(&mesh.positions), 128, 128);
    let (work, _) = Workload::primary_packets(&camera, 128, 128, 2);
    let mut hits = vec![Hit::MISS; work.rays.len()];
    let mut group = c.benchmark_group("intersect/no-bvh");
    group.sample_size(10);
    group.throughput(Throughput::Elements(work.rays.len() as u64));
    group.bench_function("moller-pre scalar", |b| {
        b.iter(|| closest_without_bvh::<MollerPre>(Simd::Scalar, &soa, &work.rays, &mut hits, 4))
    });
    for simd in [Simd::Scalar, Simd::X8] {
        group.bench_function(format!("moller-packet {}", simd.name()), |b| {
            b.iter(|| closest_without_bvh::<MollerPacket>(simd, &soa, &work.rays, &mut hits, 4))
        });
    }
    group.finish();

    let scene = Scene::from_mesh(rtmesh::scenes::scan_blob(100_000, 1));
    let accel = SceneAccel::build(&scene, &BuildSettings::default());
    let camera = Camera::default_for(&scene.bounds(), 256, 256);
    let (work, starts) = Workload::primary_packets(&camera, 256, 256, 8);
    let mut group = c.benchmark_group("packets/blob-primary");
    group.sample_size(10);
    group.throughput(Throughput::Elements(work.rays.len() as u64));
    group.bench_function("single", |b| {
        b.iter(|| one_thread.install(|| trace_closest::<NoCounters>(&accel, &work.rays)))
    });
    group.bench_function("8x8 moller-packet", |b| {
        b.iter(|| {
            one_thread.install(|| {
                trace_packets_closest::<MollerPacket, NoCounters>(&accel, &work.rays, &starts)
            })
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

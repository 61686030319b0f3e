//! BVH build and single-ray traversal on the procedural 100k-triangle blob (always
//! available) and on the Stanford bunny when the data is present: primary and diffuse
//! rays at 256×256, one thread, counters off. Side-by-side comparisons with Embree and
//! obvhs live in `rtmesh bench trace --vs ...`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rtmesh::bvh::BuildSettings;
use rtmesh::trace::run::trace_closest;
use rtmesh::trace::{NoCounters, RayKind, SceneAccel, Workload};
use rtmesh::Scene;

fn scenes() -> Vec<(String, Scene)> {
    let mut scenes = vec![(
        "blob".to_owned(),
        Scene::from_mesh(rtmesh::scenes::scan_blob(100_000, 1)),
    )];
    if let Some(dir) = rtmesh::data::mesh_data_dir() {
        if let Ok(bunny) = rtmesh::io::read(&dir.join("stanford-bunny.obj")) {
            scenes.push(("bunny".to_owned(), bunny));
        }
    }
    scenes
}

fn bench(c: &mut Criterion) {
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    for (name, scene) in scenes() {
        let mut group = c.benchmark_group(format!("trace/{name}"));
        group.sample_size(10);
        group.bench_function("build", |b| {
            b.iter(|| one_thread.install(|| SceneAccel::build(&scene, &BuildSettings::default())))
        });
        let accel = SceneAccel::build(&scene, &BuildSettings::default());
        for kind in [RayKind::Primary, RayKind::Diffuse] {
            let work = Workload::generate(kind, &scene, &accel, 256, 256, 1);
            group.throughput(Throughput::Elements(work.rays.len() as u64));
            group.bench_function(kind.name(), |b| {
                b.iter(|| one_thread.install(|| trace_closest::<NoCounters>(&accel, &work.rays)))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);

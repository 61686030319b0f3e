//! Triangle pairing on the full Stanford dragon (871k triangles, welded) when the data
//! is present, else on the 100k-triangle procedural blob: the published greedy (fast
//! route on one thread and on two, and the plain reference), compressed position keys
//! (on one thread and on two), window-2, and the augmenting paths of sah-max (default
//! pair box limit) and max.

use criterion::{criterion_group, criterion_main, Criterion};
use rtmesh::mesh::weld_exact;
use rtmesh::pair::{compressed, greedy, matching, window, PairSettings};

fn bench(c: &mut Criterion) {
    let (name, mesh) = rtmesh::data::dragon_or_blob();
    let mesh = weld_exact(&mesh).mesh;
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("thread pool");
    let mut group = c.benchmark_group("pairing");
    group.sample_size(10);
    group.bench_function(format!("sah/{name}"), |b| {
        b.iter(|| one_thread.install(|| greedy::pair_sah(&mesh)))
    });
    let two_threads = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("thread pool");
    group.bench_function(format!("sah-2-threads/{name}"), |b| {
        b.iter(|| two_threads.install(|| greedy::pair_sah(&mesh)))
    });
    group.bench_function(format!("sah-reference/{name}"), |b| {
        b.iter(|| greedy::pair_sah_reference(&mesh))
    });
    group.bench_function(format!("sah-compressed/{name}"), |b| {
        b.iter(|| one_thread.install(|| compressed::pair_sah_compressed(&mesh)))
    });
    group.bench_function(format!("sah-compressed-2-threads/{name}"), |b| {
        b.iter(|| two_threads.install(|| compressed::pair_sah_compressed(&mesh)))
    });
    group.bench_function(format!("window-2/{name}"), |b| {
        b.iter(|| window::pair_window(&mesh, 2))
    });
    let greedy = greedy::pair_sah(&mesh);
    let limit = PairSettings::default().pair_box_limit;
    group.bench_function(format!("sah-max-augment/{name}"), |b| {
        b.iter(|| matching::raise(&mesh, &greedy, Some(limit)))
    });
    group.bench_function(format!("max-augment/{name}"), |b| {
        b.iter(|| matching::raise(&mesh, &greedy, None))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! Edge adjacency and exact welding on the full Stanford dragon (871k triangles) when
//! the data is present, else on the 100k-triangle procedural blob.

use criterion::{criterion_group, criterion_main, Criterion};
use rtmesh::mesh::{weld_exact, EdgeAdjacency};

fn bench(c: &mut Criterion) {
    let (name, mesh) = rtmesh::data::dragon_or_blob();
    let welded = weld_exact(&mesh).mesh;
    let mut group = c.benchmark_group("topology");
    group.sample_size(20);
    group.bench_function(format!("adjacency/{name}"), |b| {
        b.iter(|| EdgeAdjacency::build(&welded))
    });
    group.bench_function(format!("weld_exact/{name}"), |b| {
        b.iter(|| weld_exact(&mesh))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

use super::greedy::{pair_sah, pair_sah_reference, pair_sah_with, sorted_half_edge_table};
use super::suitor::EXCLUDED;
use super::*;
use crate::mesh::weld_exact;
use crate::simd::has_avx512;
use glam::Vec3;
use proptest::prelude::*;

/// The worked example of Aman & Fenney: six vertices, five triangles fanned around
/// vertex 5, laid out so that the half-edge table in input order has the paper's BBSA
/// values 0,15,20, 10,10,15, 0,30,10, 18,9,30, 20,20,9.
fn paper_example() -> TriMesh {
    let positions = [
        (0.0, 5.0),
        (0.0, 12.0),
        (10.0, 11.0),
        (10.0, 3.0),
        (4.0, 0.0),
        (5.0, 9.0),
    ]
    .map(|(x, y)| Vec3::new(x, y, 0.0))
    .to_vec();
    let triangles = (0..5).map(|i| [i, (i + 1) % 5, 5]).collect();
    TriMesh::new(positions, triangles)
}

#[test]
fn paper_example_table_and_outcome() {
    let mesh = paper_example();
    let table = greedy::half_edge_table(&mesh);
    let bbsa: Vec<f32> = table.iter().map(|r| r.bbsa).collect();
    assert_eq!(
        bbsa,
        [0., 15., 20., 10., 10., 15., 0., 30., 10., 18., 9., 30., 20., 20., 9.]
    );
    let sorted: Vec<(f32, u32, u32, u32)> = sorted_half_edge_table(&mesh)
        .iter()
        .map(|r| (r.bbsa, r.first, r.second, r.triangle))
        .collect();
    assert_eq!(
        sorted,
        [
            (30., 3, 5, 2), // twins: triangles 2 and 3 free: accepted
            (30., 3, 5, 3),
            (20., 0, 5, 0), // twins: 0 and 4 free: accepted
            (20., 0, 5, 4),
            (20., 0, 4, 4), // boundary
            (18., 3, 4, 3), // boundary
            (15., 1, 5, 0), // twins: 0 taken: rejected
            (15., 1, 5, 1),
            (10., 2, 5, 1), // twins: 2 taken: rejected
            (10., 2, 5, 2),
            (10., 1, 2, 1), // boundary
            (9., 4, 5, 3),  // twins: both taken: rejected
            (9., 4, 5, 4),
            (0., 2, 3, 2), // boundary
            (0., 0, 1, 0), // boundary
        ]
    );
    for pairing in [pair_sah_reference(&mesh), pair_sah(&mesh)] {
        assert_eq!(pairing.pairs, vec![[0, 4], [2, 3]]);
        assert_eq!(pairing.unpaired, vec![1]);
    }
    // The five-cycle has no perfect matching: two pairs is the maximum.
    assert_eq!(
        matching::raise(&mesh, &pair_sah(&mesh), None).pairs.len(),
        2
    );
}

#[test]
fn window_pairs_in_input_order() {
    let mesh = paper_example();
    // Window 1: 0 takes 1, 2 takes 3, 4 is left.
    assert_eq!(window::pair_window(&mesh, 1).pairs, vec![[0, 1], [2, 3]]);
    // Window 2 from 0: 1 (shares edge 1–5) and 2 (shares nothing): takes 1.
    assert_eq!(window::pair_window(&mesh, 2).pairs, vec![[0, 1], [2, 3]]);
}

#[test]
fn quad_convention() {
    // Square 0-1-2-3 split along 1–2, wound counter-clockwise.
    let a = [0, 1, 2];
    let b = [3, 2, 1];
    let (q, [ra, rb]) = quad(&a, &b).unwrap();
    assert_eq!(q, [0, 1, 2, 3]);
    assert_eq!(rotate(a, ra), [q[0], q[1], q[2]]);
    assert_eq!(rotate(b, rb), [q[2], q[1], q[3]]);
    // Same winding: no quad.
    assert_eq!(quad(&[0, 1, 2], &[1, 2, 3]), None);
}

#[test]
fn method_names_round_trip() {
    for m in [
        PairMethod::Sah,
        PairMethod::SahCompressed,
        PairMethod::Window(3),
        PairMethod::SahMax,
        PairMethod::Max,
    ] {
        assert_eq!(m.to_string().parse::<PairMethod>(), Ok(m));
    }
    assert!("window:0".parse::<PairMethod>().is_err());
    assert!("greedy".parse::<PairMethod>().is_err());
}

#[test]
fn prescan_recognises_a_paired_mesh() {
    let mut mesh = weld_exact(&crate::scenes::scan_blob(4_000, 3)).mesh;
    // The blob comes out of its generator in strips, already paired: shuffle it.
    let mut random = crate::random::SplitMix64::new(5);
    for i in (1..mesh.triangles.len()).rev() {
        let j = (random.next_u64() % (i as u64 + 1)) as usize;
        mesh.triangles.swap(i, j);
    }
    let (pairing, report) = pair(&mesh, &PairSettings::default());
    assert!(!report.prescan_skipped);
    let paired = reorder(&mesh, &mesh, &pairing);
    let (again, report) = pair(&paired.mesh, &PairSettings::default());
    assert!(report.prescan_skipped, "{report:?}");
    assert_eq!(again.pairs.len(), pairing.pairs.len());
}

/// Checks every pairing must pass: each pair pairable (by welded position: the
/// compressed mode pairs by position), no triangle twice, every triangle accounted for.
fn assert_valid(mesh: &TriMesh, pairing: &Pairing) {
    let welded = weld_exact(mesh).mesh;
    let n = mesh.triangle_count();
    let mut seen = vec![false; n];
    for &[a, b] in &pairing.pairs {
        assert!(a < b);
        let active = ActiveTriangles::new(mesh);
        assert!(active.get(a as usize) && active.get(b as usize));
        assert!(quad(&welded.triangles[a as usize], &welded.triangles[b as usize]).is_some());
        for t in [a, b] {
            assert!(!std::mem::replace(&mut seen[t as usize], true), "{t} twice");
        }
    }
    for &t in &pairing.unpaired {
        assert!(!std::mem::replace(&mut seen[t as usize], true), "{t} twice");
    }
    assert!(seen.iter().all(|&s| s), "a triangle is lost");
}

/// Random meshes on a small vertex grid with duplicates, flips, degenerates, fins and
/// an out-of-range index or NaN corner now and then.
fn random_mesh() -> impl Strategy<Value = TriMesh> {
    (
        proptest::collection::vec((0u32..12, 0u32..12, 0u32..12), 0..40),
        proptest::collection::vec((0u8..5, 0u8..5, 0u8..3), 12),
        any::<bool>(),
    )
        .prop_map(|(triangles, grid, nan)| {
            let mut positions: Vec<Vec3> = grid
                .iter()
                .map(|&(x, y, z)| Vec3::new(x as f32, y as f32, z as f32 * 0.5))
                .collect();
            if nan {
                positions[11] = Vec3::NAN;
            }
            let mut triangles: Vec<[u32; 3]> =
                triangles.iter().map(|&(a, b, c)| [a, b, c]).collect();
            if let Some(t) = triangles.get_mut(7) {
                t[2] = 40; // out of range
            }
            TriMesh::new(positions, triangles)
        })
}

/// The kernels of [`pair_sah_with`] and [`compressed::pair_sah_compressed_with`] that
/// this CPU runs: the scalar ones, and the AVX-512 ones where it has AVX-512 ([`crate::simd::has_avx512`]).
fn kernel_choices() -> Vec<bool> {
    let mut searches = vec![false];
    if has_avx512() {
        searches.push(true);
    }
    searches
}

/// A pool of `threads` threads.
fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// On one thread (the Suitor matching) and on two (the parallel Suitor); with
    /// the scalar twin search and, where the CPU has it, the AVX-512 one.
    #[test]
    fn fast_greedy_equals_the_published_procedure(mesh in random_mesh()) {
        let reference = pair_sah_reference(&mesh);
        for threads in [1, 2] {
            for avx512 in kernel_choices() {
                let fast = pool(threads).install(|| pair_sah_with(&mesh, avx512));
                prop_assert_eq!(&fast, &reference, "{} threads, AVX-512 {}", threads, avx512);
                assert_valid(&mesh, &fast);
            }
        }
    }

    #[test]
    fn fast_compressed_equals_the_published_procedure(mesh in random_mesh()) {
        let reference = compressed::pair_sah_compressed_reference(&mesh);
        for threads in [1, 2] {
            for avx512 in kernel_choices() {
                let fast = pool(threads)
                    .install(|| compressed::pair_sah_compressed_with(&mesh, avx512));
                prop_assert_eq!(&fast, &reference, "{} threads, AVX-512 {}", threads, avx512);
            }
        }
    }

    /// Bit for bit, on corners of every kind of float: huge, tiny, subnormal, signed
    /// zeros, infinities and NaNs (sums and box areas that overflow), and out-of-range
    /// or repeated indices.
    #[test]
    fn avx512_position_keys_are_the_scalar_keys(
        coordinates in proptest::collection::vec(
            prop_oneof![
                4 => -100.0f32..100.0,
                1 => any::<f32>(),
                1 => prop::sample::select(vec![
                    0.0, -0.0, f32::MAX, f32::MIN, f32::MIN_POSITIVE, 1e-40, f32::INFINITY,
                    f32::NAN,
                ]),
            ],
            3 * 12,
        ),
        triangles in proptest::collection::vec(prop::array::uniform3(0u32..13), 0..70),
    ) {
        let positions = coordinates.chunks(3).map(Vec3::from_slice).collect();
        let mesh = TriMesh::new(positions, triangles);
        if !kernel_choices().contains(&true) {
            return Ok(());
        }
        let (_, scalar_ranked) = compressed::PositionKeys::new(&mesh, false);
        let (keys, ranked) = compressed::PositionKeys::new(&mesh, true);
        #[cfg(target_arch = "x86_64")]
        for first in (0..mesh.triangle_count() / 16 * 16).step_by(16) {
            // SAFETY: the CPU has AVX-512 (`kernel_choices`); the group is the mesh's.
            let (lanes, active) = unsafe { keys.quantiser.group_keys_avx512(&mesh, first) };
            // SAFETY: a vector is 16 words.
            let lanes: [[[u32; 16]; 3]; 3] = unsafe { std::mem::transmute(lanes) };
            for (lane, t) in (first..first + 16).enumerate() {
                let takes_part = active >> lane & 1 == 1;
                prop_assert_eq!(takes_part, ranked.side_ranks[t] != EXCLUDED);
                if takes_part {
                    let key = |k: usize| lanes[k].map(|word| word[lane]);
                    prop_assert_eq!([key(0), key(1), key(2)], keys.side_keys(t));
                }
            }
        }
        prop_assert_eq!(ranked, scalar_ranked);
    }

    #[test]
    fn every_method_gives_a_valid_pairing(mesh in random_mesh(), window in 1usize..4) {
        let greedy = pair_sah(&mesh);
        let raised = matching::raise(&mesh, &greedy, Some(1.0));
        let maximum = matching::raise(&mesh, &greedy, None);
        for pairing in [
            &greedy,
            &window::pair_window(&mesh, window),
            &compressed::pair_sah_compressed(&mesh),
            &raised,
            &maximum,
        ] {
            assert_valid(&mesh, pairing);
        }
        prop_assert!(raised.pairs.len() >= greedy.pairs.len());
        prop_assert!(maximum.pairs.len() >= raised.pairs.len());
        if let Some(exact) = brute_force_maximum(&mesh) {
            prop_assert_eq!(maximum.pairs.len(), exact);
        }
    }

    #[test]
    fn reorder_keeps_every_triangle_and_its_winding(mesh in random_mesh()) {
        let pairing = pair_sah(&mesh);
        let out = reorder(&mesh, &mesh, &pairing);
        let mut ids = out.input_triangle.clone();
        ids.sort_unstable();
        prop_assert_eq!(ids, (0..mesh.triangle_count() as u32).collect::<Vec<_>>());
        for (i, &t) in out.input_triangle.iter().enumerate() {
            let original = mesh.triangles[t as usize];
            let written = out.mesh.triangles[i];
            prop_assert!((0..3).any(|r| rotate(original, r) == written), "winding changed");
        }
        for p in 0..out.pair_count {
            let [a, b] = [out.mesh.triangles[2 * p], out.mesh.triangles[2 * p + 1]];
            // (v0, v1, v2) and (v2, v1, v3).
            prop_assert_eq!([b[0], b[1]], [a[2], a[1]]);
        }
    }
}

/// A `w` × `h` grid of unit cells, each cut along a diagonal its bit in `diagonals`
/// picks (so vertices have odd valences, and the dual graph odd cycles), with the
/// triangles whose bit in `holes` is set left out.
fn cut_grid(w: usize, h: usize, diagonals: u128, holes: u128) -> TriMesh {
    let vertex = |i: usize, j: usize| (j * (w + 1) + i) as u32;
    let positions = (0..=h)
        .flat_map(|j| (0..=w).map(move |i| Vec3::new(i as f32, j as f32, 0.0)))
        .collect();
    let mut triangles = Vec::new();
    for j in 0..h {
        for i in 0..w {
            let cell = j * w + i;
            let [a, b, c, d] = [
                vertex(i, j),
                vertex(i + 1, j),
                vertex(i + 1, j + 1),
                vertex(i, j + 1),
            ];
            let halves = if diagonals >> cell & 1 == 0 {
                [[a, b, c], [a, c, d]]
            } else {
                [[a, b, d], [b, c, d]]
            };
            for (k, half) in halves.into_iter().enumerate() {
                if holes >> ((2 * cell + k) % 128) & 1 == 0 {
                    triangles.push(half);
                }
            }
        }
    }
    TriMesh::new(positions, triangles)
}

/// The size of a maximum matching of the graph on `n` vertices with edges `edges`, by
/// Lovász's randomised method: half the rank of the Tutte matrix (`x_ij` above the
/// diagonal for edge `ij`, `-x_ij` below) with random `x_ij` modulo a prime. The rank
/// falls short with probability at most n / p.
fn tutte_rank_maximum(n: usize, edges: &[(usize, usize)], seed: u64) -> usize {
    const P: u64 = (1 << 61) - 1;
    let mul = |a: u64, b: u64| (a as u128 * b as u128 % P as u128) as u64;
    let mut rng = crate::random::SplitMix64::new(seed);
    let mut random = || rng.next_u64() % (P - 1) + 1;
    let mut m = vec![vec![0u64; n]; n];
    for &(a, b) in edges {
        let x = random();
        m[a][b] = x;
        m[b][a] = P - x;
    }
    let power = |mut base: u64, mut e: u64| {
        let mut r = 1;
        while e > 0 {
            if e & 1 == 1 {
                r = mul(r, base);
            }
            base = mul(base, base);
            e >>= 1;
        }
        r
    };
    let mut rank = 0;
    for column in 0..n {
        let Some(pivot) = (rank..n).find(|&r| m[r][column] != 0) else {
            continue;
        };
        m.swap(rank, pivot);
        let inverse = power(m[rank][column], P - 2);
        let (pivot_rows, below) = m.split_at_mut(rank + 1);
        let pivot_row = &pivot_rows[rank][column..];
        for row in below {
            let factor = mul(row[column], inverse);
            if factor != 0 {
                for (x, &p) in row[column..].iter_mut().zip(pivot_row) {
                    *x = (*x + P - mul(factor, p)) % P;
                }
            }
        }
        rank += 1;
    }
    rank / 2
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Grids of up to 200 triangles with odd valences and holes: many blossoms, nested
    /// ones among them. `max` (from no pairs, and from the greedy pairing) reaches the
    /// maximum that the Tutte matrix's rank gives.
    #[test]
    fn max_reaches_the_tutte_rank_on_cut_grids(
        (w, h) in (2usize..11, 2usize..11),
        diagonals in any::<u128>(),
        holes in any::<u128>().prop_map(|h| h & h.rotate_left(7)),
        seed in any::<u64>(),
    ) {
        let mesh = cut_grid(w, h, diagonals, holes);
        let n = mesh.triangle_count();
        let edges: Vec<(usize, usize)> = (0..n)
            .flat_map(|a| (a + 1..n).map(move |b| (a, b)))
            .filter(|&(a, b)| shared_side(&mesh.triangles[a], &mesh.triangles[b]).is_some())
            .collect();
        let exact = tutte_rank_maximum(n, &edges, seed);
        let none = Pairing::from_partners(&vec![UNPAIRED; n]);
        for start in [none, pair_sah(&mesh)] {
            let maximum = matching::raise(&mesh, &start, None);
            assert_valid(&mesh, &maximum);
            prop_assert_eq!(maximum.pairs.len(), exact);
        }
    }
}

/// Maximum matching size by exhaustive search with memoisation over the set of free
/// triangles (meshes of up to 20 triangles), else None.
fn brute_force_maximum(mesh: &TriMesh) -> Option<usize> {
    let n = mesh.triangle_count();
    if n > 20 {
        return None;
    }
    let active = ActiveTriangles::new(mesh);
    let neighbours: Vec<u32> = (0..n)
        .map(|a| {
            (0..n)
                .filter(|&b| {
                    a != b
                        && active.get(a)
                        && active.get(b)
                        && shared_side(&mesh.triangles[a], &mesh.triangles[b]).is_some()
                })
                .fold(0u32, |m, b| m | 1 << b)
        })
        .collect();
    fn best(
        free: u32,
        neighbours: &[u32],
        memo: &mut std::collections::HashMap<u32, usize>,
    ) -> usize {
        if free == 0 {
            return 0;
        }
        if let Some(&m) = memo.get(&free) {
            return m;
        }
        let v = free.trailing_zeros();
        let rest = free & !(1 << v);
        let mut result = best(rest, neighbours, memo);
        let mut candidates = neighbours[v as usize] & rest;
        while candidates != 0 {
            let u = candidates.trailing_zeros();
            candidates &= candidates - 1;
            result = result.max(1 + best(rest & !(1 << u), neighbours, memo));
        }
        memo.insert(free, result);
        result
    }
    let all = if n == 32 { u32::MAX } else { (1u32 << n) - 1 };
    Some(best(
        all,
        &neighbours,
        &mut std::collections::HashMap::new(),
    ))
}

/// Above 32k triangles and 16k vertices the twin search and (with no edge of three or
/// more half-edges) the matching split their work over the pool's threads: the same
/// pairing as one thread and as the published procedure, with and without
/// non-manifold edges; by index and by position (whose blocks are cells of space).
#[test]
fn parallel_parts_pair_like_one_thread() {
    let manifold = crate::mesh::weld_exact(&crate::scenes::scan_blob(80_000, 3)).mesh;
    // Three triangles on one edge, and a duplicate triangle, in different parts.
    let mut shared = manifold.clone();
    let [a, b, _] = shared.triangles[10];
    let far = shared.triangles.len() as u32 - 1;
    let c = shared.triangles[far as usize][2];
    shared.triangles.push([b, a, c]);
    shared.triangles.push(shared.triangles[5]);
    for (name, mesh) in [("manifold", manifold), ("shared edge", shared)] {
        assert_fast_routes_pair_like_the_references(&mesh, &[1, 2, 3], name);
    }
}

/// Both fast routes, by index and by position, with each of [`kernel_choices`], give
/// the published procedures' pairings of `mesh` in a pool of each of `thread_counts`;
/// returns the indexed one.
fn assert_fast_routes_pair_like_the_references(
    mesh: &TriMesh,
    thread_counts: &[usize],
    what: &str,
) -> Pairing {
    let reference = pair_sah_reference(mesh);
    let by_position = compressed::pair_sah_compressed_reference(mesh);
    for &threads in thread_counts {
        let pool = pool(threads);
        for avx512 in kernel_choices() {
            assert_eq!(
                pool.install(|| pair_sah_with(mesh, avx512)),
                reference,
                "{what}, {threads} threads, AVX-512 {avx512}"
            );
            assert_eq!(
                pool.install(|| compressed::pair_sah_compressed_with(mesh, avx512)),
                by_position,
                "{what}, {threads} threads, by position, AVX-512 {avx512}"
            );
        }
    }
    reference
}

/// A cylinder's caps are fans: each centre is the smaller vertex of a run of 2 × 60k
/// half-edges, and the spokes' box areas rise with the angle over each quarter turn,
/// a chain of couples that a matching in rounds (the pointer algorithm, which this
/// route once took on several threads) pairs a few at a time. Both took O(T²)
/// (minutes here); the long run is sorted by edge. Same pairing as the published procedure.
#[test]
fn long_fans_pair_like_the_published_procedure() {
    let mesh = crate::scenes::fan_cylinder(60_000);
    let reference = assert_fast_routes_pair_like_the_references(&mesh, &[1, 2], "fans");
    assert!(reference.pair_ratio() > 0.99, "{}", reference.pair_ratio());
}

/// A book: `ahead` pages on edge 0 → 1 and `back` pages on edge 1 → 0, all around
/// one spine.
fn book(ahead: usize, back: usize) -> TriMesh {
    let mut positions = vec![Vec3::ZERO, Vec3::Z];
    let mut triangles = Vec::new();
    for i in 0..ahead + back {
        let angle = i as f32 / (ahead + back) as f32 * std::f32::consts::TAU;
        positions.push(Vec3::new(angle.cos(), angle.sin(), 0.5));
        let page = 2 + i as u32;
        triangles.push(if i < ahead {
            [0, 1, page]
        } else {
            [1, 0, page]
        });
    }
    TriMesh::new(positions, triangles)
}

/// An edge of k half-edges, half each way, had O(k²) links in the dual graph of
/// `sah-max` and `max` (hours for these books): now a band of them, with which the
/// edge still pairs as many pages as the smaller side has.
#[test]
fn books_of_many_pages_pair_in_linear_links() {
    for (ahead, back) in [(100_000, 100_000), (150_000, 50_000), (3, 200_000)] {
        let mesh = book(ahead, back);
        let greedy = pair_sah(&mesh);
        let maximum = matching::raise(&mesh, &greedy, None);
        assert_valid(&mesh, &maximum);
        assert_eq!(
            maximum.pairs.len(),
            ahead.min(back),
            "{ahead} + {back} pages"
        );
        assert_valid(&mesh, &matching::raise(&mesh, &greedy, Some(1.0)));
    }
}

/// On a regular grid every diagonal has one box area and every other edge area 0, so
/// the order between couples rests on the vertex ids alone: the Suitor matching must
/// still be the scan's, on the grid and on the grid with its axes turned.
#[test]
fn tied_edge_areas_pair_like_the_published_procedure() {
    for mesh in [
        crate::scenes::quad_grid(40),
        crate::scenes::rotated_grid(40),
    ] {
        let fast = pair_sah(&mesh);
        assert_eq!(fast, pair_sah_reference(&mesh));
        assert!(fast.pair_ratio() > 0.85, "{}", fast.pair_ratio());
        assert_eq!(
            compressed::pair_sah_compressed(&mesh),
            compressed::pair_sah_compressed_reference(&mesh)
        );
    }
}

/// A cone of 24 triangles around vertex 0 (which has the smallest index, so all 48
/// half-edges of its spokes sort under it) and a fin on one spoke: the twin search's
/// long-run path (past its fixed window) must pair like the published procedure. So
/// must the cone with its even triangles listed first, which puts twins far apart in
/// the run.
#[test]
fn long_vertex_runs_pair_like_the_published_procedure() {
    let spokes = 24u32;
    let mut positions = vec![glam::Vec3::new(0.0, 0.0, 1.0)];
    for i in 0..spokes {
        let angle = i as f32 * std::f32::consts::TAU / spokes as f32;
        positions.push(glam::Vec3::new(
            angle.cos(),
            angle.sin() * 1.3,
            0.1 * i as f32,
        ));
    }
    positions.push(glam::Vec3::new(0.5, 0.5, -1.0));
    let mut triangles: Vec<[u32; 3]> = (0..spokes)
        .map(|i| [0, 1 + i, 1 + (i + 1) % spokes])
        .collect();
    let mut with_fin = triangles.clone();
    with_fin.push([0, spokes + 1, 1]);
    let evens_first = (0..2).flat_map(|odd| triangles.iter().skip(odd).step_by(2));
    let evens_first = evens_first.copied().collect();
    triangles.push([1, 2, 3]);
    for triangles in [triangles, with_fin, evens_first] {
        let mesh = TriMesh::new(positions.clone(), triangles);
        let fast = pair_sah(&mesh);
        assert_eq!(fast, pair_sah_reference(&mesh));
        assert!(fast.pairs.len() >= 10, "{fast:?}");
        assert_eq!(
            compressed::pair_sah_compressed(&mesh),
            compressed::pair_sah_compressed_reference(&mesh)
        );
    }
}

/// The indexed twin search compares an edge's larger vertex modulo 2²⁰ first (one
/// word with its run), so edges (0, 1) of triangle A and (1 + 2²⁰, 0) of C look alike
/// there, and run opposite ways: they must not couple. A's true couple is B, across
/// (0, 2), and C has none.
#[test]
fn larger_vertices_alike_modulo_a_word_do_not_couple() {
    let far = 1 + (1 << 20);
    let mut positions = vec![Vec3::ZERO; far as usize + 1];
    for (v, p) in [
        (1, Vec3::new(3.0, 3.0, 0.0)),
        (2, Vec3::new(1.0, 0.0, 0.0)),
        (3, Vec3::new(-1.0, 0.0, 0.0)),
        (4, Vec3::new(0.0, 1.0, 0.0)),
        (far, Vec3::new(-3.0, -3.0, 0.0)),
    ] {
        positions[v as usize] = p;
    }
    let mesh = TriMesh::new(positions, vec![[0, 1, 2], [0, 2, 4], [far, 0, 3]]);
    let reference = assert_fast_routes_pair_like_the_references(&mesh, &[1], "far vertices");
    assert_eq!(reference.pairs, [[0, 1]]);
    assert_eq!(reference.unpaired, [2]);
}

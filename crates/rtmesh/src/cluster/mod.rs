//! Precomputed triangle clusters for animated meshes: the clusters are found once, on
//! the rest pose, and every frame only their boxes are recomputed and a BVH is built
//! over them.
//!
//! This work is based on B. Garanzha, "The Use of Precomputed Triangle Clusters for
//! Accelerated Ray Tracing in Dynamic Scenes", EGSR 2009 (the slide transcript is
//! `../shared/papers/clusters-garanzha-slides.txt`). The slides give the acceptance
//! heuristic only as its three requirements; no source we found keeps the formula.
//!
//! **Acc(k), as used here**, for a connected set k of |T| triangles on |V| distinct
//! vertices, bounding sphere S(k) of radius r (centred on the vertices' mean, a cheap
//! stand-in for the smallest sphere), unit normals n_t with area-weighted mean m:
//!
//! ```text
//! Acc(k) = min( 1 − r / R(k),          compactness: S(k) within the disk of k's area
//!               cone(k) − cos θmax,     disk-like: the normals within θmax of m
//!               1 − |V| / Vmax )        the vertex budget (≤ 256 for u8 indices)
//!          − α · |V| / |T|              dense connectivity: fewer new vertices
//!
//! R(k)    = MaxSize · sqrt(AvgSA · |T| / π)   the radius of a disk of k's expected area
//! cone(k) = min over t of n_t · m
//! ```
//!
//! with AvgSA the mesh's mean triangle area, MaxSize 3 ([`DEFAULT_MAX_SIZE`]), θmax
//! 75°, α 0.05 (the
//! connectivity term ranks candidates: 0.5 vertices per triangle for a large regular
//! patch, 3 for a lone triangle). A set is accepted while Acc(k) > 0 and |T| ≤ MaxCount
//! triangles. **Iterative growing** ([`grow`]) starts a cluster at the first triangle
//! not yet taken (in the order of a Morton curve over the centroids, so that clusters
//! tile the surface) and adds, one at a time, the neighbour across an edge whose Acc of
//! the grown set is largest, while it is positive. **Iterative contraction**
//! ([`contract`]) starts from one cluster per triangle and contracts the dual graph's
//! edge of largest Acc(k₁ ∪ k₂) while it is positive. Both then merge the fragments
//! they leave (clusters of under MaxCount / 2 triangles) into a neighbour the union
//! fits ([`merge_small`]). Optionally (not in the slides; `refine_passes`, off by
//! default), [`refine`] then moves border triangles between clusters where that
//! lowers the clusters' SAH-like cost.
//!
//! **Storage** ([`Clusters`]): per cluster its list of global vertex indices (at most
//! 256) and its triangles as three u8 indices into that list, with the input triangle
//! ids, 3 bytes per triangle plus 4 per cluster vertex against 12 per triangle.
//!
//! **Per frame** ([`ClusterFrames::build`]): per cluster, its vertices' positions are
//! gathered once and its triangles written through the u8 indices into the tracer's
//! 4-wide blocks (in place, at a fixed spot kept from frame to frame), with the
//! cluster's box; then a binned-SAH BVH over the cluster boxes whose leaves hold up to 8
//! nearby clusters, as one 8-wide node over their boxes (the slides put a few nearby
//! clusters in a leaf). Which clusters share a leaf is chosen by every frame's build
//! ([`Grouping::Frame`], as in the slides) or, by default, once by the same build on
//! the rest pose ([`Grouping::Rest`]: a frame builds over the groups' boxes, an eighth
//! as many). A cluster is one flat leaf of its blocks, as in the slides
//! ([`Inside::Flat`]), or a small BVH over its blocks, built once by SAH on the rest
//! pose and refitted by the frame's pass ([`Inside::Node`]: one 8-wide node up to 8
//! blocks).
//!
//! Cost: growing is O(T · F) for F candidates on a cluster's frontier (tens); a frame is
//! O(T) for the boxes and triangle blocks plus a build over T / |k| boxes that stops at
//! groups of 8 (over T / 8|k| group boxes under [`Grouping::Rest`]).

mod contract;
mod grow;
pub mod meshopt;
mod refine;

pub use contract::contract;
pub use grow::grow;

use crate::bvh::{BuildSettings, Bvh, Child, Primitive};
use crate::bvh::{BvhNode, WIDTH};
use crate::geom::Aabb;
use crate::mesh::{EdgeAdjacency, TriMesh, NO_EDGE};
use crate::trace::triangle::{Triangle4, TRIANGLE4_LANES};
use crate::trace::SceneAccel;
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use serde::Serialize;

/// MaxSize by default. Against 2 (measured on the dragon at MaxCount 32,
/// `docs/measurements/clusters.md`): a fifth fewer clusters, so a per-frame build 12%
/// faster and a precompute 8% faster, with the same or a lower SAH and trace time;
/// at 4 the explosion's last frames trace 7% slower.
pub const DEFAULT_MAX_SIZE: f32 = 3.0;

/// Limits of a cluster.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClusterSettings {
    /// Most triangles per cluster, MaxCount (at most [`MAX_CLUSTER_TRIANGLES`]; at most
    /// [`MAX_FLAT_TRIANGLES`] for [`Inside::Flat`]). The slides' leaves hold up to 32.
    pub max_triangles: usize,
    /// Most distinct vertices per cluster (at most 256, for u8 local indices).
    pub max_vertices: usize,
    /// MaxSize: the bounding radius may reach this times the radius of a disk of the
    /// cluster's expected area ([`DEFAULT_MAX_SIZE`] by default).
    pub max_size: f32,
    /// Widest angle between a triangle's normal and the cluster's mean, degrees.
    pub max_normal_angle: f32,
    /// Passes of boundary refinement after growing or contraction (not in the slides;
    /// [`refine`]): 0 keeps the published clusters.
    pub refine_passes: usize,
}

impl Default for ClusterSettings {
    fn default() -> Self {
        Self {
            max_triangles: 32,
            max_vertices: 256,
            max_size: DEFAULT_MAX_SIZE,
            max_normal_angle: 75.0,
            refine_passes: 0,
        }
    }
}

/// The largest MaxCount: 64 blocks of four, two levels of 8-wide nodes
/// ([`Inside::Node`]).
pub const MAX_CLUSTER_TRIANGLES: usize = 256;

/// The largest MaxCount of a cluster that is one leaf ([`Inside::Flat`]): a leaf holds
/// at most 15 blocks of four.
pub const MAX_FLAT_TRIANGLES: usize = 60;

/// How clusters are found: `grow`, `contract` or `meshopt`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ClusterMethod {
    /// Iterative growing by Acc(k) ([`grow`]).
    Grow,
    /// Iterative contraction by Acc(k₁ ∪ k₂) ([`contract`]).
    Contract,
    /// meshoptimizer's spatial clusterizer, the baseline ([`meshopt::spatial`]).
    Meshopt,
}

impl ClusterMethod {
    /// Every method.
    pub const ALL: [ClusterMethod; 3] = [Self::Grow, Self::Contract, Self::Meshopt];

    /// The method's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Grow => "grow",
            Self::Contract => "contract",
            Self::Meshopt => "meshopt",
        }
    }

    /// The clusters of `mesh` by this method.
    pub fn cluster(self, mesh: &TriMesh, settings: &ClusterSettings) -> Clusters {
        match self {
            Self::Grow => grow(mesh, settings),
            Self::Contract => contract(mesh, settings),
            Self::Meshopt => meshopt::spatial(mesh, settings),
        }
    }
}

impl std::fmt::Display for ClusterMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for ClusterMethod {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                format!("unknown clustering method `{s}`: use grow, contract or meshopt")
            })
    }
}

/// Triangles grouped into clusters, stored compactly.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Clusters {
    /// Cluster `c`'s triangles are `local_triangles[triangle_start[c]..triangle_start[c + 1]]`.
    pub triangle_start: Vec<u32>,
    /// Cluster `c`'s vertices are `vertices[vertex_start[c]..vertex_start[c + 1]]`.
    pub vertex_start: Vec<u32>,
    /// Global vertex indices, cluster by cluster.
    pub vertices: Vec<u32>,
    /// Each triangle as three indices into its cluster's vertex list.
    pub local_triangles: Vec<[u8; 3]>,
    /// The input triangle id of each triangle, in cluster order.
    pub input_triangle: Vec<u32>,
}

impl Clusters {
    /// Number of clusters.
    pub fn len(&self) -> usize {
        self.triangle_start.len().saturating_sub(1)
    }

    /// No cluster.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Triangle ids (positions in cluster order) of cluster `c`.
    pub fn triangles_of(&self, c: usize) -> std::ops::Range<usize> {
        self.triangle_start[c] as usize..self.triangle_start[c + 1] as usize
    }

    /// Global vertex indices of cluster `c`.
    pub fn vertices_of(&self, c: usize) -> &[u32] {
        &self.vertices[self.vertex_start[c] as usize..self.vertex_start[c + 1] as usize]
    }

    /// Triangle `i` (in cluster order) of cluster `c` by global vertex indices.
    pub fn triangle(&self, c: usize, i: usize) -> [u32; 3] {
        let vertices = self.vertices_of(c);
        self.local_triangles[i].map(|l| vertices[l as usize])
    }

    /// Append a cluster of `mesh`'s triangles `triangles` (at most 256 distinct
    /// vertices), each stored with its corners in order.
    pub fn push(&mut self, mesh: &TriMesh, triangles: &[u32]) {
        if self.triangle_start.is_empty() {
            self.triangle_start.push(0);
            self.vertex_start.push(0);
        }
        let first = self.vertices.len();
        for &t in triangles {
            let local = mesh.triangles[t as usize].map(|v| {
                let mine = &self.vertices[first..];
                let at = mine.iter().position(|&w| w == v).unwrap_or_else(|| {
                    self.vertices.push(v);
                    self.vertices.len() - 1 - first
                });
                debug_assert!(at < 256, "a cluster holds at most 256 vertices");
                at as u8
            });
            self.local_triangles.push(local);
            self.input_triangle.push(t);
        }
        self.triangle_start.push(self.local_triangles.len() as u32);
        self.vertex_start.push(self.vertices.len() as u32);
    }

    /// The sum over the clusters of [`disk_vertex_floor`] of their sizes: the fewest
    /// vertices clusters of these sizes could have on a regular mesh.
    pub fn floor_vertices(&self) -> usize {
        (0..self.len())
            .map(|c| disk_vertex_floor(self.triangles_of(c).len()))
            .sum()
    }

    /// Bytes of this storage: 3 per triangle (u8 indices), 4 per input triangle id, 4
    /// per cluster vertex, 8 per cluster (the two offsets).
    pub fn bytes(&self) -> usize {
        3 * self.local_triangles.len()
            + 4 * self.input_triangle.len()
            + 4 * self.vertices.len()
            + 8 * self.len()
    }
}

/// The fewest vertices a disk-shaped patch of `triangles` triangles can have on a
/// regular mesh (every inner vertex of valence 6, as a scan's are on average). Euler's
/// formula for a disk, V − E + F = 1, with 3F = 2E − B for its B boundary edges, gives
/// V = 1 + (F + B) / 2, and B is at least the least perimeter of a polyiamond of F
/// cells, 2⌈(F + √(6F)) / 2⌉ − F (Harary and Harborth, "Extremal animals", 1976):
/// the smallest B ≥ √(6F) with the parity of F. So 32 triangles need at least 24
/// vertices, 0.75 a triangle, and fewer triangles need more a triangle. The floor is
/// for disks on such a mesh: a patch with holes, or around vertices of higher valence,
/// can have fewer.
pub fn disk_vertex_floor(triangles: usize) -> usize {
    if triangles == 0 {
        return 0;
    }
    let f = triangles;
    let mut b = (6.0 * f as f64).sqrt() as usize;
    while b * b < 6 * f || !(b + f).is_multiple_of(2) {
        b += 1;
    }
    1 + (f + b) / 2
}

/// Figures of a clustering, with the keys of `rtmesh cluster --json`.
#[derive(Clone, Debug, Serialize)]
pub struct ClusterReport {
    /// Triangles clustered.
    pub triangles: usize,
    /// Clusters made.
    pub clusters: usize,
    /// Mean triangles per cluster.
    pub mean_triangles: f64,
    /// Cluster vertices over triangles (0.5 for a large regular patch).
    pub mean_vertices_per_triangle: f64,
    /// The least `mean_vertices_per_triangle` clusters of the same sizes could have on
    /// a regular mesh ([`Clusters::floor_vertices`]): what fuller clusters, not better
    /// shaped ones, would lower.
    pub floor_vertices_per_triangle: f64,
    /// Bytes of the cluster storage ([`Clusters::bytes`]).
    pub bytes: usize,
    /// Bytes of the same triangles as three u32 indices each.
    pub indexed_bytes: usize,
    /// Clusters that are not connected through shared edges (none from [`grow`]).
    pub disconnected: usize,
    /// Seconds the clustering took.
    pub seconds: f64,
}

impl ClusterReport {
    /// The figures of `clusters`, found in `seconds`.
    pub fn of(clusters: &Clusters, seconds: f64) -> Self {
        Self::of_all(std::slice::from_ref(clusters), seconds)
    }

    /// The figures of the clusters of several meshes together, all found in `seconds`:
    /// counts and bytes summed, means over every triangle and cluster.
    pub fn of_all(all: &[Clusters], seconds: f64) -> Self {
        let sum = |f: fn(&Clusters) -> usize| all.iter().map(f).sum::<usize>();
        let triangles = sum(|c| c.local_triangles.len());
        let clusters = sum(Clusters::len);
        let per_triangle = |n: usize| n as f64 / triangles.max(1) as f64;
        Self {
            triangles,
            clusters,
            mean_triangles: triangles as f64 / clusters.max(1) as f64,
            mean_vertices_per_triangle: per_triangle(sum(|c| c.vertices.len())),
            floor_vertices_per_triangle: per_triangle(sum(Clusters::floor_vertices)),
            bytes: sum(Clusters::bytes),
            indexed_bytes: 12 * triangles,
            disconnected: 0,
            seconds,
        }
    }
}

/// Clusters of `clusters` whose triangles are not all connected through edges they
/// share by position (none from [`grow`]; meshoptimizer's spatial clusters may be).
pub fn disconnected(mesh: &TriMesh, clusters: &Clusters) -> usize {
    let topology = mesh.topology();
    let mut edges: std::collections::HashMap<[u32; 2], usize> = Default::default();
    (0..clusters.len())
        .filter(|&c| {
            let range = clusters.triangles_of(c);
            let mut parent: Vec<usize> = (0..range.len()).collect();
            fn root(parent: &mut [usize], mut i: usize) -> usize {
                while parent[i] != i {
                    parent[i] = parent[parent[i]];
                    i = parent[i];
                }
                i
            }
            edges.clear();
            for (i, k) in range.clone().enumerate() {
                let t = topology.triangles[clusters.input_triangle[k] as usize];
                for side in 0..3 {
                    let (a, b) = (t[side], t[(side + 1) % 3]);
                    let edge = [a.min(b), a.max(b)];
                    match edges.get(&edge) {
                        Some(&j) => {
                            let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                            parent[ri] = rj;
                        }
                        None => {
                            edges.insert(edge, i);
                        }
                    }
                }
            }
            let r0 = root(&mut parent, 0);
            (1..range.len()).any(|i| root(&mut parent, i) != r0)
        })
        .count()
}

/// The figures Acc(k) needs of a set of triangles: its distinct vertices, their sum,
/// its unit normals, their area-weighted sum, its area and triangle count.
#[derive(Clone, Copy)]
pub(crate) struct Summary<'a> {
    pub vertices: &'a [u32],
    /// The vertices' positions, in the same order (read without a gather).
    pub points: &'a [Vec3],
    pub vertex_sum: Vec3,
    pub normals: &'a [Vec3],
    pub normal_sum: Vec3,
    pub area: f32,
    pub triangles: usize,
}

/// A set of triangles with the running figures of its [`Summary`].
#[derive(Clone, Default)]
pub(crate) struct Set {
    pub triangles: Vec<u32>,
    pub vertices: Vec<u32>,
    pub points: Vec<Vec3>,
    pub vertex_sum: Vec3,
    pub normals: Vec<Vec3>,
    pub normal_sum: Vec3,
    pub area: f32,
}

impl Set {
    /// The set of triangle `t` alone.
    pub fn of(mesh: &TriMesh, t: u32, shape: (Vec3, f32)) -> Self {
        let mut set = Self::default();
        set.add(mesh, t, shape);
        set
    }

    /// Add triangle `t`, of unit normal and area `shape`.
    pub fn add(&mut self, mesh: &TriMesh, t: u32, (normal, area): (Vec3, f32)) {
        self.triangles.push(t);
        for &v in &mesh.triangles[t as usize] {
            if !self.vertices.contains(&v) {
                let p = mesh.positions[v as usize];
                self.vertices.push(v);
                self.points.push(p);
                self.vertex_sum += p;
            }
        }
        self.normal_sum += normal * area.max(f32::MIN_POSITIVE);
        self.area += area;
        self.normals.push(normal);
    }

    /// Take in all of `other` (disjoint from this set); `marks` is scratch.
    pub fn absorb(&mut self, mesh: &TriMesh, other: Set, marks: &mut Marks) {
        marks.mark(&self.vertices);
        let mut fresh = other.vertices;
        fresh.retain(|&v| !marks.is_marked(v));
        for &v in &fresh {
            let p = mesh.positions[v as usize];
            self.points.push(p);
            self.vertex_sum += p;
        }
        self.vertices.extend(fresh);
        self.triangles.extend(other.triangles);
        self.normals.extend(other.normals);
        self.normal_sum += other.normal_sum;
        self.area += other.area;
    }

    /// Its figures for Acc(k).
    pub fn summary(&self) -> Summary<'_> {
        Summary {
            vertices: &self.vertices,
            points: &self.points,
            vertex_sum: self.vertex_sum,
            normals: &self.normals,
            normal_sum: self.normal_sum,
            area: self.area,
            triangles: self.triangles.len(),
        }
    }
}

/// Vertex marks for set unions in O(|V₁| + |V₂|): mark one set, then test the other's
/// vertices (a vertex is marked when its mark equals the current stamp).
pub(crate) struct Marks {
    seen: Vec<u32>,
    stamp: u32,
}

impl Marks {
    /// Marks for a mesh of `vertex_count` vertices.
    pub fn new(vertex_count: usize) -> Self {
        Self {
            seen: vec![0; vertex_count],
            stamp: 0,
        }
    }

    /// Mark `vertices`, and only them.
    fn mark(&mut self, vertices: &[u32]) {
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.seen.fill(0);
            self.stamp = 1;
        }
        self.mark_also(vertices);
    }

    /// Mark `vertices` too.
    fn mark_also(&mut self, vertices: &[u32]) {
        for &v in vertices {
            self.seen[v as usize] = self.stamp;
        }
    }

    /// Whether `v` was among the vertices last marked.
    #[inline]
    fn is_marked(&self, v: u32) -> bool {
        self.seen[v as usize] == self.stamp
    }
}

/// What Acc(k) is measured against: the settings and the mesh's figures.
pub(crate) struct AcceptanceScale<'s> {
    pub settings: &'s ClusterSettings,
    /// AvgSA, the mesh's mean triangle area.
    pub average_area: f32,
    /// cos θmax.
    pub cos_max: f32,
}

impl<'s> AcceptanceScale<'s> {
    /// The scale for `mesh` whose triangles have the unit normals and areas `shape`.
    pub fn new(settings: &'s ClusterSettings, shape: &[(Vec3, f32)]) -> Self {
        Self {
            settings,
            average_area: shape.iter().map(|s| s.1).sum::<f32>() / shape.len().max(1) as f32,
            cos_max: settings.max_normal_angle.to_radians().cos(),
        }
    }
}

/// Unit normal and area of triangle `t` (zero for a degenerate one).
fn normal_and_area(mesh: &TriMesh, t: usize) -> (Vec3, f32) {
    let [a, b, c] = mesh.corners(t);
    let n = (b - a).cross(c - a);
    let length = n.length();
    if length > 0.0 && length.is_finite() {
        (n / length, 0.5 * length)
    } else {
        (Vec3::ZERO, 0.0)
    }
}

/// What Acc(a ∪ b) needs besides the two reductions over the sets' points and normals
/// ([`farthest`], [`widest`]): the union's counts, centre, mean normal and disk.
pub(crate) struct Union {
    triangle_count: usize,
    vertex_count: usize,
    pub centre: Vec3,
    pub mean: Vec3,
    disk: f32,
}

impl Union {
    /// The union of disjoint sets `a` and `b`, or `None` past a hard limit (MaxCount
    /// triangles, the vertex limit); `in_a` tells a vertex of `a`.
    pub fn of(
        a: Summary,
        b: Summary,
        scale: &AcceptanceScale,
        in_a: impl Fn(u32) -> bool,
    ) -> Option<Self> {
        let settings = scale.settings;
        let triangle_count = a.triangles + b.triangles;
        if triangle_count > settings.max_triangles {
            return None;
        }
        let mut vertex_count = a.vertices.len();
        let mut vertex_sum = a.vertex_sum;
        for (&v, &p) in b.vertices.iter().zip(b.points) {
            if !in_a(v) {
                vertex_count += 1;
                vertex_sum += p;
            }
        }
        if vertex_count > settings.max_vertices {
            return None;
        }
        // The disk of k's own area, or of its expected area where its triangles are
        // smaller than the mesh's average (a sliver strip must not pass as compact).
        let expected = (a.area + b.area).max(scale.average_area * triangle_count as f32 * 0.25);
        Some(Self {
            triangle_count,
            vertex_count,
            centre: vertex_sum / vertex_count as f32,
            mean: (a.normal_sum + b.normal_sum).normalize_or_zero(),
            disk: settings.max_size * (expected / std::f32::consts::PI).sqrt(),
        })
    }

    /// Acc of the union, given the largest squared distance of its points from
    /// `centre` and the smallest cosine of its normals to `mean`.
    pub fn acceptance(&self, farthest_squared: f32, widest: f32, scale: &AcceptanceScale) -> f32 {
        let compact = 1.0 - farthest_squared.sqrt() / self.disk.max(f32::MIN_POSITIVE);
        let budget = 1.0 - self.vertex_count as f32 / (scale.settings.max_vertices as f32 + 1.0);
        compact.min(widest - scale.cos_max).min(budget)
            - 0.05 * self.vertex_count as f32 / self.triangle_count as f32
    }
}

/// The largest squared distance of `points` from `centre` (0 for none).
#[inline]
pub(crate) fn farthest(points: &[Vec3], centre: Vec3) -> f32 {
    points
        .iter()
        .map(|&p| (p - centre).length_squared())
        .fold(0.0f32, f32::max)
}

/// The smallest cosine of `normals` to `mean` (1 for none).
#[inline]
pub(crate) fn widest(normals: &[Vec3], mean: Vec3) -> f32 {
    normals.iter().map(|n| n.dot(mean)).fold(1.0f32, f32::min)
}

/// Acc(a ∪ b) of the module header for disjoint sets `a` and `b`, or `None` past a
/// hard limit (MaxCount triangles, the vertex limit); `in_a` tells a vertex of `a`.
pub(crate) fn acceptance(
    a: Summary,
    b: Summary,
    scale: &AcceptanceScale,
    in_a: impl Fn(u32) -> bool,
) -> Option<f32> {
    let union = Union::of(a, b, scale, in_a)?;
    let far = farthest(a.points, union.centre).max(farthest(b.points, union.centre));
    let wide = widest(a.normals, union.mean).min(widest(b.normals, union.mean));
    Some(union.acceptance(far, wide, scale))
}

/// Morton code of a point in `bounds` (10 bits per axis).
fn morton(p: Vec3, bounds: &Aabb) -> u32 {
    let extent = bounds.extent().max(Vec3::splat(f32::MIN_POSITIVE));
    let q = ((p - bounds.min) / extent * 1023.0).clamp(Vec3::ZERO, Vec3::splat(1023.0));
    crate::geom::morton_code(q.as_uvec3()) as u32
}

/// `mesh`'s triangle ids in the order of a Morton curve over their centroids (those
/// with a non-finite centroid last), so that clusters made in this order tile the
/// surface.
pub(crate) fn morton_order(mesh: &TriMesh) -> Vec<u32> {
    let bounds = mesh.bounds();
    // The code above the triangle id, so that one integer sort orders both.
    let mut order: Vec<u64> = (0..mesh.triangle_count() as u32)
        .map(|t| {
            let centroid = mesh.centroid(t as usize);
            let code = if centroid.is_finite() {
                morton(centroid, &bounds)
            } else {
                u32::MAX
            };
            u64::from(code) << 32 | u64::from(t)
        })
        .collect();
    order.par_sort_unstable();
    order.into_iter().map(|key| key as u32).collect()
}

/// What both methods by Acc(k) start from, `settings` checked: the mesh's edge
/// adjacency (by position), each triangle's unit normal and area, the scale of Acc and
/// the vertex marks.
pub(crate) fn prepare<'s>(
    mesh: &TriMesh,
    settings: &'s ClusterSettings,
) -> (EdgeAdjacency, Vec<(Vec3, f32)>, AcceptanceScale<'s>, Marks) {
    assert!((1..=MAX_CLUSTER_TRIANGLES).contains(&settings.max_triangles));
    assert!(settings.max_vertices >= 3 && settings.max_vertices <= 256);
    let adjacency = EdgeAdjacency::build(&mesh.topology());
    let shape: Vec<(Vec3, f32)> = (0..mesh.triangle_count())
        .map(|t| normal_and_area(mesh, t))
        .collect();
    let scale = AcceptanceScale::new(settings, &shape);
    (adjacency, shape, scale, Marks::new(mesh.positions.len()))
}

/// Most triangles on an edge that clustering joins across. A wider non-manifold edge
/// (a book's spine, a stack of copies of one triangle) joins none of them: it is no
/// surface to grow over, and taking it would make every step scan all its triangles.
pub(crate) const WIDEST_JOINING_EDGE: usize = 8;

/// The triangles that share an edge with triangle `t` (itself included), over edges of
/// at most [`WIDEST_JOINING_EDGE`] triangles.
pub(crate) fn edge_neighbours(
    adjacency: &EdgeAdjacency,
    t: usize,
) -> impl Iterator<Item = u32> + '_ {
    adjacency.triangle_edges[t]
        .iter()
        .filter(|&&e| e != NO_EDGE)
        .map(|&e| adjacency.triangles_of(e))
        .filter(|shared| shared.len() <= WIDEST_JOINING_EDGE)
        .flatten()
        .copied()
}

/// The clusters of `groups` (each a list of `mesh`'s triangle ids), after
/// [`merge_small`].
pub(crate) fn finish(
    mesh: &TriMesh,
    adjacency: &EdgeAdjacency,
    mut groups: Vec<Vec<u32>>,
    settings: &ClusterSettings,
) -> Clusters {
    merge_small(mesh, adjacency, &mut groups, settings);
    refine::refine(mesh, adjacency, &mut groups, settings);
    let mut out = Clusters {
        triangle_start: vec![0],
        vertex_start: vec![0],
        ..Clusters::default()
    };
    for triangles in &mut groups {
        split_into_blocks(mesh, triangles);
        out.push(mesh, triangles);
    }
    out
}

/// Order a cluster's triangles so that each run of four (one traced block) is
/// compact: split them where the surface area heuristic is lowest, recursively, down
/// to four. A split is taken along each axis in centroid order, after a whole number
/// of blocks, and costs Σ halfArea(box of a side) · blocks of that side: the cost of
/// the blocks as leaves. The tracer's node over a cluster's blocks then boxes nearby
/// triangles together, as a BVH built inside the cluster would. Cost: O(n log² n) for
/// n triangles (at most 256).
pub(crate) fn split_into_blocks(mesh: &TriMesh, triangles: &mut [u32]) {
    if triangles.len() <= TRIANGLE4_LANES {
        return;
    }
    let mut items: Vec<(Vec3, Aabb, u32)> = triangles
        .iter()
        .map(|&t| {
            let corners = mesh.corners(t as usize);
            (
                corners[0] + corners[1] + corners[2],
                Aabb::from_points(&corners),
                t,
            )
        })
        .collect();
    let mut suffix = vec![Aabb::EMPTY; items.len() + 1];
    split_blocks(&mut items, &mut suffix);
    for (slot, item) in triangles.iter_mut().zip(&items) {
        *slot = item.2;
    }
}

/// [`split_into_blocks`] over (three times the centroid, box, id); `suffix` is room for
/// the boxes of the right sides.
fn split_blocks(items: &mut [(Vec3, Aabb, u32)], suffix: &mut [Aabb]) {
    let n = items.len();
    if n <= TRIANGLE4_LANES {
        return;
    }
    let blocks = |count: usize| count.div_ceil(TRIANGLE4_LANES) as f32;
    // Each axis's order as sorted keys: the centroid coordinate's bits, ordered as
    // `total_cmp` orders the floats, above the item's place (ties in place order).
    let ordered = |x: f32| {
        let bits = x.to_bits();
        if bits >> 31 == 1 {
            !bits
        } else {
            bits | 1 << 31
        }
    };
    // Without a finite cost (non-finite corners), halves of whole blocks along x.
    let mut best_cost = f32::INFINITY;
    let mut best_k = n.div_ceil(2 * TRIANGLE4_LANES) * TRIANGLE4_LANES;
    let (mut order, mut best_order) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for axis in 0..3 {
        order.clear();
        order.extend(
            items
                .iter()
                .enumerate()
                .map(|(i, item)| u64::from(ordered(item.0[axis])) << 32 | i as u64),
        );
        order.sort_unstable();
        let item = |key: u64| &items[key as u32 as usize];
        suffix[n] = Aabb::EMPTY;
        for i in (0..n).rev() {
            suffix[i] = suffix[i + 1].union(item(order[i]).1);
        }
        let mut improved = false;
        let mut left = Aabb::EMPTY;
        for (i, &key) in order.iter().enumerate().take(n - 1) {
            left = left.union(item(key).1);
            let k = i + 1;
            if k % TRIANGLE4_LANES != 0 {
                continue;
            }
            let cost = left.half_area() * blocks(k) + suffix[k].half_area() * blocks(n - k);
            if cost < best_cost {
                (best_cost, best_k, improved) = (cost, k, true);
            }
        }
        // The x order stands in until an axis with a finite cost.
        if improved || axis == 0 {
            std::mem::swap(&mut order, &mut best_order);
        }
    }
    let sorted: Vec<_> = best_order
        .iter()
        .map(|&key| items[key as u32 as usize])
        .collect();
    items.copy_from_slice(&sorted);
    let (low, high) = items.split_at_mut(best_k);
    split_blocks(low, suffix);
    split_blocks(high, suffix);
}

/// Distinct vertices of `triangles` (of `mesh`), counted against a cluster's limit.
fn vertex_count<'a>(mesh: &TriMesh, triangles: impl Iterator<Item = &'a u32>) -> usize {
    let mut seen: Vec<u32> = Vec::new();
    for &t in triangles {
        for &v in &mesh.triangles[t as usize] {
            if !seen.contains(&v) {
                seen.push(v);
            }
        }
    }
    seen.len()
}

/// Growing leaves fragments between the clusters it grew first. Merge each cluster of
/// fewer than half of MaxCount triangles into the smallest neighbour (across a shared
/// edge) that the union still fits (MaxCount triangles, the vertex limit), smallest
/// clusters first, so that merged clusters stay connected.
fn merge_small(
    mesh: &TriMesh,
    adjacency: &EdgeAdjacency,
    groups: &mut Vec<Vec<u32>>,
    settings: &ClusterSettings,
) {
    let mut owner = vec![u32::MAX; mesh.triangle_count()];
    for (g, triangles) in groups.iter().enumerate() {
        for &t in triangles {
            owner[t as usize] = g as u32;
        }
    }
    let mut by_size: Vec<usize> = (0..groups.len()).collect();
    by_size.sort_by_key(|&g| (groups[g].len(), g));
    for g in by_size {
        let size = groups[g].len();
        if size == 0 || 2 * size >= settings.max_triangles {
            continue;
        }
        let mut neighbours: Vec<u32> = groups[g]
            .iter()
            .flat_map(|&t| edge_neighbours(adjacency, t as usize))
            .map(|u| owner[u as usize])
            .filter(|&h| h != g as u32)
            .collect();
        neighbours.sort_unstable();
        neighbours.dedup();
        let best = neighbours
            .into_iter()
            .filter(|&h| {
                let h = h as usize;
                groups[h].len() + size <= settings.max_triangles
                    && vertex_count(mesh, groups[h].iter().chain(&groups[g]))
                        <= settings.max_vertices
            })
            .min_by_key(|&h| (groups[h as usize].len(), h));
        if let Some(h) = best {
            let moved = std::mem::take(&mut groups[g]);
            for &t in &moved {
                owner[t as usize] = h;
            }
            groups[h as usize].extend(moved);
        }
    }
    groups.retain(|g| !g.is_empty());
}

/// A group's box in one frame, the primitive of the per-frame BVH (a group is one
/// cluster under [`Grouping::Frame`]).
#[derive(Clone, Copy, Debug)]
struct GroupBox {
    bounds: Aabb,
    group: u32,
}

impl Primitive for GroupBox {
    fn bounds(&self) -> Aabb {
        self.bounds
    }
}

/// How the per-frame BVH's leaves gather clusters: each leaf becomes one 8-wide node
/// over up to 8 clusters' boxes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Grouping {
    /// Chosen by every frame's build, as in the slides: the SAH stops at up to 8
    /// nearby clusters.
    Frame,
    /// Chosen once, by the same build over the clusters' boxes in the rest pose; each
    /// frame builds over the groups' boxes (an eighth as many primitives: 5,011
    /// groups of 37,947 clusters on the dragon) and gives each group a node over its
    /// clusters' current boxes. Not in the slides. The default: on the dragon a
    /// frame's build is 0.6x the time and the trace 1.03-1.1x (1.14x at the full
    /// explosion, where groups part), so build + trace is 4-18% less
    /// (`docs/measurements/clusters.md`).
    #[default]
    Rest,
}

/// What a cluster is inside the per-frame BVH.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Inside {
    /// One leaf of all its triangle blocks, as the slides keep no branches inside a
    /// cluster: every ray that reaches it tests all its triangles.
    Flat,
    /// A small BVH over its blocks, a block a leaf: built once by binned SAH over the
    /// blocks' boxes in the pose the clusters were found on, refitted every frame
    /// (one 8-wide node for up to 8 blocks, 32 triangles).
    Node,
}

impl Inside {
    /// The name `--inside` takes.
    pub fn name(self) -> &'static str {
        match self {
            Self::Flat => "flat",
            Self::Node => "node",
        }
    }
}

impl Grouping {
    /// The name `--groups` takes.
    pub fn name(self) -> &'static str {
        match self {
            Self::Frame => "frame",
            Self::Rest => "rest",
        }
    }
}

impl std::str::FromStr for Grouping {
    type Err = String;

    fn from_str(name: &str) -> Result<Self, String> {
        [Self::Frame, Self::Rest]
            .into_iter()
            .find(|g| g.name() == name)
            .ok_or_else(|| format!("the grouping is frame or rest, not `{name}`"))
    }
}

/// The per-frame build's settings over cluster boxes (`Frame`) or group boxes
/// (`Rest`). A top leaf of clusters holds up to 8 nearby ones and becomes one 8-wide
/// node over their boxes: the SAH charges it one test (`leaf_block`), so the build stops
/// there instead of splitting down to single clusters for the collapse to join. A group
/// is a leaf of its own.
fn top_settings(grouping: Grouping) -> BuildSettings {
    let leaf = match grouping {
        Grouping::Frame => WIDTH,
        Grouping::Rest => 1,
    };
    BuildSettings {
        max_leaf_size: leaf,
        leaf_block: leaf,
        ..BuildSettings::default()
    }
}

/// The per-frame build over cluster boxes, keeping what frames share: each cluster's
/// triangle blocks, and its node under [`Inside::Node`], sit at a fixed place (cluster
/// order, lanes fixed), so a frame rewrites them in place, with no allocation, and the
/// top tree's leaves point at them wherever the build puts the cluster.
pub struct ClusterFrames<'c> {
    clusters: &'c Clusters,
    /// Cluster `c`'s blocks are `blocks[block_start[c]..block_start[c + 1]]`.
    block_start: Vec<u32>,
    /// Cluster `c`'s nodes are `nodes[node_start[c]..node_start[c + 1]]`, its root
    /// first; none when it is one leaf.
    node_start: Vec<u32>,
    /// The clusters' nodes as [`Self::new`] made them (their children; boxes are
    /// refitted every frame), for a frame whose scene was not recycled.
    cluster_nodes: Vec<BvhNode>,
    /// The blocks of the last frame, taken back from its scene ([`Self::recycle`]).
    blocks: Vec<Triangle4>,
    /// The nodes of the last frame, likewise: the clusters' nodes first, at the places
    /// `node_start` gives, refitted in place each frame, then the top tree's.
    nodes: Vec<BvhNode>,
    /// Under [`Grouping::Rest`], group `g`'s clusters are
    /// `group_clusters[group_start[g]..group_start[g + 1]]`; empty under
    /// [`Grouping::Frame`], where each cluster is its own group.
    group_start: Vec<u32>,
    group_clusters: Vec<u32>,
}

/// A block's box in the rest pose, the primitive of a cluster's own BVH.
#[derive(Clone, Copy, Debug)]
struct BlockBox {
    bounds: Aabb,
    /// The block, counted from the cluster's first.
    block: u32,
}

impl Primitive for BlockBox {
    fn bounds(&self) -> Aabb {
        self.bounds
    }
}

/// Cluster `c`'s own BVH under [`Inside::Node`], over its blocks' boxes in `rest`: its
/// nodes, root first, whose leaves name blocks from `first_block` (one each) and whose
/// inner children count from its root; none for a cluster of one block. The boxes are
/// left for the frames to refit.
fn cluster_tree(clusters: &Clusters, c: usize, rest: &[Vec3], first_block: u32) -> Vec<BvhNode> {
    let range = clusters.triangles_of(c);
    let corners = |i: usize| clusters.triangle(c, i).map(|v| rest[v as usize]);
    let boxes: Vec<BlockBox> = range
        .clone()
        .step_by(TRIANGLE4_LANES)
        .enumerate()
        .map(|(block, first)| {
            let bounds = (first..(first + TRIANGLE4_LANES).min(range.end))
                .fold(Aabb::EMPTY, |b, i| b.union(Aabb::from_points(&corners(i))));
            // The builder leaves out bad boxes; a block with a NaN corner at rest
            // still gets its leaf (at the origin), for the frames where it is finite.
            BlockBox {
                bounds: if bounds.is_finite() {
                    bounds
                } else {
                    Aabb::from_point(Vec3::ZERO)
                },
                block: block as u32,
            }
        })
        .collect();
    if boxes.len() < 2 {
        return Vec::new();
    }
    let settings = BuildSettings {
        max_leaf_size: 1,
        leaf_block: 1,
        parallel_threshold: usize::MAX,
        ..BuildSettings::default()
    };
    let tree = Bvh::build(boxes, &settings);
    let placed = |reference: u32| match Child::decode(reference) {
        Child::Leaf { first, count } => Child::Leaf {
            first: first_block + tree.primitives[first as usize].block,
            count,
        }
        .encode(),
        Child::Inner(_) | Child::Empty => reference,
    };
    tree.nodes
        .iter()
        .map(|node| BvhNode {
            children: node.children.map(placed),
            ..BvhNode::EMPTY
        })
        .collect()
}

/// `node` with its inner children moved `by` places (its leaves stay).
fn shifted(node: &BvhNode, by: u32) -> BvhNode {
    BvhNode {
        children: node
            .children
            .map(|reference| match Child::decode(reference) {
                Child::Inner(n) => Child::Inner(by + n).encode(),
                Child::Leaf { .. } | Child::Empty => reference,
            }),
        ..*node
    }
}

impl<'c> ClusterFrames<'c> {
    /// Frames of `clusters`, arranged as `inside` says; each cluster's own BVH
    /// ([`Inside::Node`]) is built on `rest`, the pose the clusters were found on.
    pub fn new(clusters: &'c Clusters, inside: Inside, rest: &TriMesh) -> Self {
        let mut block_start = Vec::with_capacity(clusters.len() + 1);
        block_start.push(0u32);
        for c in 0..clusters.len() {
            let blocks = clusters.triangles_of(c).len().div_ceil(TRIANGLE4_LANES);
            assert!(
                inside == Inside::Node || blocks <= MAX_FLAT_TRIANGLES / TRIANGLE4_LANES,
                "a flat cluster holds at most {MAX_FLAT_TRIANGLES} triangles"
            );
            block_start.push(block_start[c] + blocks as u32);
        }
        // Each cluster's tree, numbered from its root, is moved to where it lands.
        let trees: Vec<Vec<BvhNode>> = match inside {
            Inside::Flat => vec![Vec::new(); clusters.len()],
            Inside::Node => (0..clusters.len())
                .into_par_iter()
                .map(|c| cluster_tree(clusters, c, &rest.positions, block_start[c]))
                .collect(),
        };
        let mut node_start = Vec::with_capacity(clusters.len() + 1);
        node_start.push(0u32);
        let mut cluster_nodes = Vec::with_capacity(trees.iter().map(Vec::len).sum());
        for tree in trees {
            let first_node = cluster_nodes.len() as u32;
            cluster_nodes.extend(tree.iter().map(|node| shifted(node, first_node)));
            node_start.push(cluster_nodes.len() as u32);
        }
        Self {
            clusters,
            block_start,
            cluster_nodes,
            node_start,
            blocks: Vec::new(),
            nodes: Vec::new(),
            group_start: Vec::new(),
            group_clusters: Vec::new(),
        }
    }

    /// Gather the clusters into the top tree's leaves as `grouping` says; under
    /// [`Grouping::Rest`], by a build over their boxes in `rest`.
    pub fn grouped(mut self, grouping: Grouping, rest: &TriMesh) -> Self {
        self.group_start.clear();
        self.group_clusters.clear();
        if grouping == Grouping::Frame {
            return self;
        }
        let boxes: Vec<GroupBox> = (0..self.clusters.len())
            .map(|c| GroupBox {
                bounds: Aabb::from_points(
                    self.clusters
                        .vertices_of(c)
                        .iter()
                        .map(|&v| &rest.positions[v as usize]),
                ),
                group: c as u32,
            })
            .collect();
        let leaves = Bvh::build(boxes, &top_settings(Grouping::Frame))
            .map_leaves(|leaf| leaf.iter().map(|b| b.group).collect::<Vec<u32>>())
            .primitives;
        self.group_start.push(0);
        let mut grouped = vec![false; self.clusters.len()];
        for group in &leaves {
            for &c in group {
                grouped[c as usize] = true;
            }
            self.group_clusters.extend(group);
            self.group_start.push(self.group_clusters.len() as u32);
        }
        // Clusters the build left out (a non-finite box at rest) are a group each.
        for c in (0..self.clusters.len() as u32).filter(|&c| !grouped[c as usize]) {
            self.group_clusters.push(c);
            self.group_start.push(self.group_clusters.len() as u32);
        }
        self
    }

    /// Take back the blocks and nodes of the scene [`Self::build`] returned, so that
    /// the next frame rewrites in place only what moves: the blocks' corners and edges
    /// and the nodes' boxes (the blocks keep their triangle ids, the clusters' nodes
    /// their children). A scene of another size is dropped, and the next frame starts
    /// afresh.
    pub fn recycle(&mut self, accel: SceneAccel) {
        let total = self.block_start[self.block_start.len() - 1] as usize;
        if let Some(bvh) = accel.into_single_blas() {
            if bvh.primitives.len() == total && bvh.nodes.len() >= self.cluster_nodes.len() {
                self.blocks = bvh.primitives;
                self.nodes = bvh.nodes;
            }
        }
    }

    /// Build the tracer's scene for `mesh` (its current positions). In parallel, per
    /// cluster: its vertices' positions gathered once (at most 256), its blocks
    /// rewritten in place from them through the u8 indices, with their boxes, its node
    /// (under [`Inside::Node`]) and its box. Then a binned-SAH BVH over the cluster
    /// boxes with up to 8 clusters a leaf, each leaf one node over its clusters' nodes
    /// or blocks (hits name `mesh`'s triangle ids).
    pub fn build(&mut self, mesh: &TriMesh) -> SceneAccel {
        let start = std::time::Instant::now();
        let clusters = self.clusters;
        let total = self.block_start[self.block_start.len() - 1] as usize;
        // Recycled blocks keep their ids and their unused lanes' zero edges, recycled
        // nodes their children.
        let fresh = self.blocks.len() != total;
        if fresh {
            self.blocks.clear();
            self.blocks.resize(total, EMPTY_BLOCK);
            self.nodes.clone_from(&self.cluster_nodes);
        }
        self.nodes.truncate(self.cluster_nodes.len());
        let mut boxes: Vec<GroupBox> = Vec::with_capacity(clusters.len());
        self.cluster_parts()
            .into_par_iter()
            .enumerate()
            .map_init(Vec::new, |local, (c, part)| GroupBox {
                bounds: write_cluster(clusters, c, &mesh.positions, part, fresh, local),
                group: c as u32,
            })
            .collect_into_vec(&mut boxes);
        let (group_start, group_clusters) = (&self.group_start, &self.group_clusters);
        let members = |g: u32| {
            &group_clusters[group_start[g as usize] as usize..group_start[g as usize + 1] as usize]
        };
        let grouping = if group_start.is_empty() {
            Grouping::Frame
        } else {
            Grouping::Rest
        };
        let top_boxes = match grouping {
            Grouping::Frame => std::mem::take(&mut boxes),
            Grouping::Rest => {
                // A group keeps its rest-pose clusters, however far they move apart:
                // opening a group whose box spread out (its half area against its
                // clusters', over the same at rest) to build over its clusters one by
                // one was measured not to pay (docs/measurements/clusters.md).
                (0..group_start.len() as u32 - 1)
                    .map(|g| GroupBox {
                        bounds: members(g)
                            .iter()
                            .fold(Aabb::EMPTY, |b, &c| b.union(boxes[c as usize].bounds)),
                        group: g,
                    })
                    .collect()
            }
        };
        let over_boxes = Bvh::build(top_boxes, &top_settings(grouping));
        // The clusters' nodes stay where they are, first; the top tree's nodes follow
        // them, then the leaves' group nodes. Their boxes are the clusters' boxes, which
        // were made from the blocks: no refit is needed.
        let first_top = self.cluster_nodes.len() as u32;
        let first_group = first_top + over_boxes.nodes.len() as u32;
        let (block_start, node_start) = (&self.block_start, &self.node_start);
        let cluster = |c: u32| {
            let c = c as usize;
            if node_start[c] == node_start[c + 1] {
                Child::Leaf {
                    first: block_start[c],
                    count: block_start[c + 1] - block_start[c],
                }
                .encode()
            } else {
                Child::Inner(node_start[c]).encode()
            }
        };
        // A top leaf's clusters and their boxes (at most 8: a leaf of up to 8
        // clusters, or of one group of up to 8).
        let gather = |first: u32, count: u32| {
            let (mut leaf, mut n) = ([(0u32, Aabb::EMPTY); WIDTH], 0);
            for top in &over_boxes.primitives[first as usize..(first + count) as usize] {
                match grouping {
                    Grouping::Frame => {
                        leaf[n] = (top.group, top.bounds);
                        n += 1;
                    }
                    Grouping::Rest => {
                        for &c in members(top.group) {
                            leaf[n] = (c, boxes[c as usize].bounds);
                            n += 1;
                        }
                    }
                }
            }
            (leaf, n)
        };
        let mut group_nodes = Vec::new();
        let mut remap = |reference: u32| match Child::decode(reference) {
            Child::Leaf { first, count } => match gather(first, count) {
                (leaf, 1) => cluster(leaf[0].0),
                (leaf, n) => {
                    let mut node = BvhNode::EMPTY;
                    for (lane, &(c, bounds)) in leaf[..n].iter().enumerate() {
                        node.children[lane] = cluster(c);
                        node.set_child_bounds(lane, bounds);
                    }
                    group_nodes.push(node);
                    Child::Inner(first_group + group_nodes.len() as u32 - 1).encode()
                }
            },
            Child::Inner(n) => Child::Inner(first_top + n).encode(),
            Child::Empty => reference,
        };
        let mut nodes = std::mem::take(&mut self.nodes);
        let root = remap(over_boxes.root);
        nodes.extend(over_boxes.nodes.iter().map(|node| BvhNode {
            children: node.children.map(&mut remap),
            ..*node
        }));
        nodes.extend_from_slice(&group_nodes);
        let bvh = Bvh {
            root,
            nodes,
            primitives: std::mem::take(&mut self.blocks),
            build_seconds: 0.0,
        };
        SceneAccel::from_single_blas(bvh, mesh.triangle_count(), start)
    }

    /// Each cluster's first block index and first node index, its blocks and its
    /// nodes, as disjoint slices.
    fn cluster_parts(&mut self) -> Vec<ClusterPart<'_>> {
        let mut parts = Vec::with_capacity(self.clusters.len());
        let (mut blocks, mut nodes) = (&mut self.blocks[..], &mut self.nodes[..]);
        for c in 0..self.clusters.len() {
            let block_count = (self.block_start[c + 1] - self.block_start[c]) as usize;
            let (my_blocks, rest) = std::mem::take(&mut blocks).split_at_mut(block_count);
            blocks = rest;
            let node_count = (self.node_start[c + 1] - self.node_start[c]) as usize;
            let (my_nodes, rest) = std::mem::take(&mut nodes).split_at_mut(node_count);
            nodes = rest;
            parts.push(ClusterPart {
                first_block: self.block_start[c],
                blocks: my_blocks,
                first_node: self.node_start[c],
                nodes: my_nodes,
            });
        }
        parts
    }
}

/// Where one cluster's blocks and nodes go in a frame's scene.
struct ClusterPart<'f> {
    first_block: u32,
    blocks: &'f mut [Triangle4],
    first_node: u32,
    nodes: &'f mut [BvhNode],
}

/// A block before it is written.
const EMPTY_BLOCK: Triangle4 = Triangle4 {
    v0: [[0.0; 4]; 3],
    e1: [[0.0; 4]; 3],
    e2: [[0.0; 4]; 3],
    ids: [u32::MAX; 4],
};

/// Write cluster `c`'s blocks (packed as [`Triangle4::new`] packs them; their triangle
/// ids only when `fresh`, else they are last frame's) and its nodes' boxes from
/// `positions`, through `local` (its vertices' positions, gathered once), and
/// return its box: the union of its triangles' boxes as the leaf test sees them (from
/// the stored corner and edges, as [`crate::trace::Triangle`]'s).
fn write_cluster(
    clusters: &Clusters,
    c: usize,
    positions: &[Vec3],
    part: ClusterPart<'_>,
    fresh: bool,
    local: &mut Vec<Vec3>,
) -> Aabb {
    let ClusterPart {
        first_block,
        blocks,
        first_node,
        nodes,
    } = part;
    local.clear();
    local.extend(
        clusters
            .vertices_of(c)
            .iter()
            .map(|&v| positions[v as usize]),
    );
    let range = clusters.triangles_of(c);
    let mut block_bounds = [Aabb::EMPTY; MAX_CLUSTER_TRIANGLES / TRIANGLE4_LANES];
    for ((block, block_box), first) in blocks
        .iter_mut()
        .zip(&mut block_bounds)
        .zip(range.clone().step_by(TRIANGLE4_LANES))
    {
        let used = (range.end - first).min(TRIANGLE4_LANES);
        if fresh {
            for lane in 0..used {
                block.ids[lane] = clusters.input_triangle[first + lane];
            }
        }
        // The box in SSE registers: `p.min(low)` keeps `low` where `p` is NaN, as
        // `f32::min` does, in one instruction instead of a NaN-checking blend.
        let (mut low, mut high) = (Vec4::splat(f32::INFINITY), Vec4::splat(f32::NEG_INFINITY));
        for lane in 0..used {
            let [a, b, d] = clusters.local_triangles[first + lane].map(|l| local[l as usize]);
            let (e1, e2) = (b - a, d - a);
            for axis in 0..3 {
                block.v0[axis][lane] = a[axis];
                block.e1[axis][lane] = e1[axis];
                block.e2[axis][lane] = e2[axis];
            }
            for p in [a, a + e1, a + e2] {
                let p = p.extend(0.0);
                (low, high) = (p.min(low), p.max(high));
            }
        }
        *block_box = Aabb {
            min: low.truncate(),
            max: high.truncate(),
        };
        // Unused lanes repeat the first corner with zero edges, as `Triangle4::new`.
        for lane in used..TRIANGLE4_LANES {
            for axis in 0..3 {
                block.v0[axis][lane] = block.v0[axis][0];
            }
        }
    }
    let block_bounds = &block_bounds[..blocks.len()];
    // The cluster's own tree, children after parents: refitted in one reverse pass.
    for n in (0..nodes.len()).rev() {
        for lane in 0..WIDTH {
            let bounds = match Child::decode(nodes[n].children[lane]) {
                Child::Leaf { first, .. } => block_bounds[(first - first_block) as usize],
                Child::Inner(child) => nodes[(child - first_node) as usize].bounds(),
                Child::Empty => continue,
            };
            nodes[n].set_child_bounds(lane, bounds);
        }
    }
    block_bounds.iter().fold(Aabb::EMPTY, |b, &p| b.union(p))
}

/// The per-frame build over cluster boxes, for one frame.
pub struct ClusterAccel;

impl ClusterAccel {
    /// The scene of one frame ([`ClusterFrames::build`] without reuse).
    pub fn build(mesh: &TriMesh, clusters: &Clusters, inside: Inside) -> SceneAccel {
        ClusterFrames::new(clusters, inside, mesh).build(mesh)
    }
}

#[cfg(test)]
mod tests;

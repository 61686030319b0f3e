//! Triangle pairing: group triangles that share an edge into quads, so that tracers and
//! hardware that test triangles two at a time get more and tighter pairs.
//!
//! Methods ([`PairMethod`]):
//! - `sah`: Aman & Fenney, "Fast Triangle Pairing for Ray Tracing" (Imagination, HPG
//!   2024): half-edges sorted by [edge box surface area, first vertex, second vertex],
//!   descending; a linear scan pairs twins whose triangles are both free
//!   ([`greedy`]).
//! - `sah-compressed`: the same on position-only input, with the paper's 16-byte edge
//!   keys (edge midpoint and box area quantised to 24 bits each) ([`compressed`]).
//! - `window:N`: the paper's baseline over the input order ([`window`]).
//! - `sah-max` and `max`: the greedy result raised by augmenting paths towards a
//!   maximum matching of the dual graph ([`matching`]).
//!
//! Two triangles are *pairable* when both are active (indices in range, three distinct
//! vertices, finite corners) and they share an edge that they traverse in opposite
//! directions, so that the pair is a quad with one winding. (The published procedure
//! does not look at direction; on consistently oriented meshes the two agree. A
//! flipped neighbour stays unpaired rather than becoming a quad that is neither way
//! round.)
//!
//! **The quad convention.** A pair is the quad `(v0, v1, v2, v3)` made of the
//! triangles `(v0, v1, v2)` and `(v2, v1, v3)`: the shared edge is `v1–v2`, listed as
//! sides 1→2 and 0→1 of the two triangles. [`reorder`] writes every pair as two
//! consecutive triangles rotated into this form (rotation keeps the winding), then the
//! unpaired triangles, with the map back to input triangle ids.

pub mod compressed;
pub mod first_fit;
pub mod greedy;
pub mod matching;
mod suitor;
pub mod window;

use crate::geom::Aabb;
pub use crate::mesh::rotate;
use crate::mesh::TriMesh;
use glam::Vec3;
use serde::Serialize;
use std::fmt;
use std::str::FromStr;

/// "No partner" in a partner array.
pub const UNPAIRED: u32 = u32::MAX;

/// How to pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PairMethod {
    /// Greedy by edge box surface area over indexed input (the published method).
    Sah,
    /// Greedy by edge box surface area over positions only (16-byte quantised keys).
    SahCompressed,
    /// Each triangle in input order takes the best free partner among the next `N`.
    Window(usize),
    /// `sah`, then augmenting paths that add pairs whose box is no worse than the two
    /// triangles' own boxes ([`PairSettings::pair_box_limit`]).
    SahMax,
    /// `sah`, then augmenting paths to a maximum-cardinality matching of the dual
    /// graph, with no limit on the pair box (the true maximum number of pairs).
    Max,
}

impl fmt::Display for PairMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PairMethod::Sah => write!(f, "sah"),
            PairMethod::SahCompressed => write!(f, "sah-compressed"),
            PairMethod::Window(n) => write!(f, "window:{n}"),
            PairMethod::SahMax => write!(f, "sah-max"),
            PairMethod::Max => write!(f, "max"),
        }
    }
}

/// A pairing method's name that [`PairMethod`]'s `FromStr` does not know.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown pairing method `{0}`: expected sah, sah-compressed, window:N (N ≥ 1), sah-max or max"
)]
pub struct UnknownPairMethod(pub String);

impl FromStr for PairMethod {
    type Err = UnknownPairMethod;
    fn from_str(s: &str) -> Result<Self, UnknownPairMethod> {
        match s {
            "sah" => Ok(PairMethod::Sah),
            "sah-compressed" => Ok(PairMethod::SahCompressed),
            "sah-max" => Ok(PairMethod::SahMax),
            "max" => Ok(PairMethod::Max),
            "window" => Ok(PairMethod::Window(2)),
            _ => match s.strip_prefix("window:").map(str::parse::<usize>) {
                Some(Ok(n)) if n >= 1 => Ok(PairMethod::Window(n)),
                _ => Err(UnknownPairMethod(s.to_owned())),
            },
        }
    }
}

/// Settings of [`pair`].
#[derive(Clone, Debug)]
pub struct PairSettings {
    /// The method.
    pub method: PairMethod,
    /// Skip the optimisation when this share of the triangles already sit in
    /// consecutive pairable couples `(2i, 2i + 1)` (the paper's pre-scan); `None`
    /// always optimises.
    pub prescan_threshold: Option<f64>,
    /// `sah-max` adds a pair only when its box's surface area is at most this times
    /// the sum of the two triangles' box areas. At 1.0 one box test on the pair costs
    /// no more, by SAH, than two on the triangles, but that bars 2% of the dragon's
    /// couples (it pairs 97.78%); the default 1.25 lets the box grow by a quarter and
    /// pairs 99.99% of the dragon and 100.00% of the bunny, with the same box tests
    /// per ray within 0.5%.
    pub pair_box_limit: f32,
    /// Pair only triangles whose shared edge has the same two vertex *indices*
    /// (same position and same attributes), not only the same positions: pairs then
    /// never cross a UV seam or a normal crease, and a hardware pairer that matches
    /// indices (Embree's quadifier, HIPRT, AMD GPURT) recovers every one of them. Weld
    /// first (identical vertices), or split vertices stay unpaired.
    pub by_index: bool,
}

impl Default for PairSettings {
    fn default() -> Self {
        Self {
            method: PairMethod::Sah,
            prescan_threshold: Some(0.85),
            pair_box_limit: 1.25,
            by_index: false,
        }
    }
}

/// Which triangles are paired.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Pairing {
    /// Pairs `[a, b]` of input triangle ids, `a < b`, ascending by `a`.
    pub pairs: Vec<[u32; 2]>,
    /// Unpaired input triangle ids, ascending.
    pub unpaired: Vec<u32>,
}

impl Pairing {
    /// From `partner[t]` (the other triangle of `t`'s pair, or [`UNPAIRED`]).
    pub fn from_partners(partner: &[u32]) -> Self {
        Self::from_partner_fn(partner.len(), |t| partner[t])
    }

    /// From `partner(t)` for `triangle_count` triangles (as in [`Self::from_partners`]).
    /// Every triangle's id is written to both lists and kept in the one it belongs to:
    /// whether a triangle is paired, and whether first, is a coin toss that a branch
    /// would mispredict.
    pub(crate) fn from_partner_fn(triangle_count: usize, partner: impl Fn(usize) -> u32) -> Self {
        let mut pairs: Vec<[u32; 2]> = Vec::with_capacity(triangle_count / 2 + 1);
        let mut unpaired: Vec<u32> = Vec::with_capacity(triangle_count + 1);
        let (mut pair_count, mut unpaired_count) = (0, 0);
        {
            let (pair_slots, unpaired_slots) =
                (pairs.spare_capacity_mut(), unpaired.spare_capacity_mut());
            for t in 0..triangle_count {
                let p = partner(t);
                pair_slots[pair_count].write([t as u32, p]);
                unpaired_slots[unpaired_count].write(t as u32);
                pair_count += ((p != UNPAIRED) & (p as usize > t)) as usize;
                unpaired_count += (p == UNPAIRED) as usize;
            }
        }
        // SAFETY: every slot below each count was written.
        unsafe {
            pairs.set_len(pair_count);
            unpaired.set_len(unpaired_count);
        }
        unpaired.shrink_to_fit();
        Pairing { pairs, unpaired }
    }

    /// `partner[t]` for `triangle_count` triangles.
    pub fn partners(&self, triangle_count: usize) -> Vec<u32> {
        let mut partner = vec![UNPAIRED; triangle_count];
        for &[a, b] in &self.pairs {
            partner[a as usize] = b;
            partner[b as usize] = a;
        }
        partner
    }

    /// Triangles in pairs.
    pub fn paired_triangles(&self) -> usize {
        2 * self.pairs.len()
    }

    /// Paired triangles over all triangles (0 for an empty mesh).
    pub fn pair_ratio(&self) -> f64 {
        let n = self.paired_triangles() + self.unpaired.len();
        if n == 0 {
            0.0
        } else {
            self.paired_triangles() as f64 / n as f64
        }
    }
}

/// What [`pair`] did, with the keys of `rtmesh pair --json`.
#[derive(Clone, Debug, Serialize)]
pub struct PairReport {
    /// Input triangles.
    pub triangles: usize,
    /// Triangles in pairs.
    pub paired_triangles: usize,
    /// `paired_triangles / triangles`.
    pub pair_ratio: f64,
    /// The method, as `--method` spells it.
    pub method: String,
    /// Seconds the pairing took (not counting reading or welding).
    pub seconds: f64,
    /// Whether the pre-scan found the input already paired and kept its order.
    pub prescan_skipped: bool,
}

/// Pair every geometry of `scene` in place, on its topology (vertices welded by
/// position, so pairs cross UV seams, but not primitives or materials:
/// [`TriMesh::topology_within_groups`]): each mesh becomes its paired, reordered form
/// (pairs first, as consecutive triangles, then the unpaired ones), its vertices and
/// attributes as they were. The report sums the geometries.
pub fn pair_scene(scene: &mut crate::Scene, settings: &PairSettings) -> PairReport {
    pair_scene_mapped(scene, settings).0
}

/// [`pair_scene`], also returning per geometry the input id of every output triangle.
pub fn pair_scene_mapped(
    scene: &mut crate::Scene,
    settings: &PairSettings,
) -> (PairReport, Vec<Vec<u32>>) {
    let mut total = PairReport {
        triangles: 0,
        paired_triangles: 0,
        pair_ratio: 0.0,
        method: settings.method.to_string(),
        seconds: 0.0,
        prescan_skipped: !scene.meshes.is_empty(),
    };
    let mut maps = Vec::with_capacity(scene.meshes.len());
    for mesh in &mut scene.meshes {
        let topology = if settings.by_index {
            mesh.indices_within_groups()
        } else {
            mesh.topology_within_groups()
        };
        let (pairing, report) = pair(&topology, settings);
        let paired = reorder(mesh, &topology, &pairing);
        *mesh = paired.mesh;
        maps.push(paired.input_triangle);
        total.triangles += report.triangles;
        total.paired_triangles += report.paired_triangles;
        total.seconds += report.seconds;
        total.prescan_skipped &= report.prescan_skipped;
    }
    total.pair_ratio = total.paired_triangles as f64 / total.triangles.max(1) as f64;
    (total, maps)
}

/// Pair the triangles of `mesh` (by vertex index: weld first to join split vertices,
/// except for `sah-compressed`, which keys edges by position).
pub fn pair(mesh: &TriMesh, settings: &PairSettings) -> (Pairing, PairReport) {
    let start = std::time::Instant::now();
    let consecutive = settings
        .prescan_threshold
        .map(|threshold| (prescan(mesh), threshold))
        .filter(|(p, threshold)| p.pair_ratio() >= *threshold && p.pair_ratio() > 0.0);
    let prescan_skipped = consecutive.is_some();
    let pairing = match consecutive {
        Some((pairing, _)) => pairing,
        None => match settings.method {
            PairMethod::Sah => greedy::pair_sah(mesh),
            PairMethod::SahCompressed => compressed::pair_sah_compressed(mesh),
            PairMethod::Window(n) => window::pair_window(mesh, n),
            PairMethod::SahMax => {
                matching::raise(mesh, &greedy::pair_sah(mesh), Some(settings.pair_box_limit))
            }
            PairMethod::Max => matching::raise(mesh, &greedy::pair_sah(mesh), None),
        },
    };
    let report = PairReport {
        triangles: mesh.triangle_count(),
        paired_triangles: pairing.paired_triangles(),
        pair_ratio: pairing.pair_ratio(),
        method: settings.method.to_string(),
        seconds: start.elapsed().as_secs_f64(),
        prescan_skipped,
    };
    (pairing, report)
}

/// Every mesh of `scene` welded by exact position and paired with `method` (no
/// pre-scan): the scene to build pair leaves from, and one pairing per mesh.
pub fn weld_and_pair(scene: &crate::Scene, method: PairMethod) -> (crate::Scene, Vec<Pairing>) {
    let mut welded = scene.clone();
    let settings = PairSettings {
        method,
        prescan_threshold: None,
        ..PairSettings::default()
    };
    let pairings = welded
        .meshes
        .iter_mut()
        .map(|mesh| {
            *mesh = mesh.topology();
            pair(mesh, &settings).0
        })
        .collect();
    (welded, pairings)
}

/// The paper's pre-scan: the consecutive couples `(2i, 2i + 1)` of the input order
/// that are pairable. When they cover most triangles the input was paired before.
pub fn prescan(mesh: &TriMesh) -> Pairing {
    let active = ActiveTriangles::new(mesh);
    let mut partner = vec![UNPAIRED; mesh.triangle_count()];
    for a in (0..mesh.triangle_count().saturating_sub(1)).step_by(2) {
        let b = a + 1;
        if active.get(a)
            && active.get(b)
            && shared_side(&mesh.triangles[a], &mesh.triangles[b]).is_some()
        {
            partner[a] = b as u32;
            partner[b] = a as u32;
        }
    }
    Pairing::from_partners(&partner)
}

/// Half the surface area of the box of edge `p–q` (`dx·dy + dy·dz + dz·dx`; an
/// axis-aligned edge has 0). The paper's BBSA up to a factor 2, which no sort sees.
#[inline(always)]
pub fn edge_bbsa(p: Vec3, q: Vec3) -> f32 {
    let d = (q - p).abs();
    d.x * d.y + d.y * d.z + d.z * d.x
}

/// Which triangles may be paired: indices in range, three distinct vertices, finite
/// corners (NaN marks an inactive triangle).
pub(crate) struct ActiveTriangles<'m> {
    mesh: &'m TriMesh,
}

impl<'m> ActiveTriangles<'m> {
    pub(crate) fn new(mesh: &'m TriMesh) -> Self {
        Self { mesh }
    }

    #[inline]
    pub(crate) fn get(&self, t: usize) -> bool {
        let tri @ [a, b, c] = self.mesh.triangles[t];
        crate::mesh::has_edges(&tri, self.mesh.positions.len())
            && self.mesh.positions[a as usize].is_finite()
            && self.mesh.positions[b as usize].is_finite()
            && self.mesh.positions[c as usize].is_finite()
    }
}

/// The side `(i, j)` such that side `i` of `a` (corners `i → i+1`) is side `j` of `b`
/// traversed the other way, if any (the first such side of `a`).
#[inline]
pub fn shared_side(a: &[u32; 3], b: &[u32; 3]) -> Option<(usize, usize)> {
    (0..3).find_map(|i| {
        let (x, y) = (a[i], a[(i + 1) % 3]);
        (0..3)
            .find(|&j| b[j] == y && b[(j + 1) % 3] == x)
            .map(|j| (i, j))
    })
}

/// The quad `(v0, v1, v2, v3)` of pairable triangles `a` and `b`: `a` rotated to
/// `(v0, v1, v2)` and `b` to `(v2, v1, v3)`. Also returns the rotations applied
/// (`a` starts at its corner `ra`, `b` at its corner `rb`).
pub fn quad(a: &[u32; 3], b: &[u32; 3]) -> Option<([u32; 4], [usize; 2])> {
    let (i, j) = shared_side(a, b)?;
    // a's side i is v1 → v2, so a starts at corner i + 2; b's side j is v2 → v1.
    let ra = (i + 2) % 3;
    let rb = j;
    Some((
        [a[ra], a[(ra + 1) % 3], a[(ra + 2) % 3], b[(rb + 2) % 3]],
        [ra, rb],
    ))
}

/// A paired mesh: pairs first as two consecutive triangles in the quad convention,
/// then the unpaired triangles.
#[derive(Clone, Debug)]
pub struct PairedMesh {
    /// The reordered mesh (same vertices and attributes, triangles rotated and
    /// reordered).
    pub mesh: TriMesh,
    /// `input_triangle[i]` is the input id of output triangle `i`.
    pub input_triangle: Vec<u32>,
    /// The first `2 · pair_count` output triangles are pairs.
    pub pair_count: usize,
}

/// Reorder `mesh` by `pairing`, found on `topology` (the same triangles, possibly
/// welded: its indices decide the rotations, `mesh`'s indices are written).
pub fn reorder(mesh: &TriMesh, topology: &TriMesh, pairing: &Pairing) -> PairedMesh {
    assert_eq!(mesh.triangle_count(), topology.triangle_count());
    let n = mesh.triangle_count();
    let mut input_triangle = Vec::with_capacity(n);
    let mut rotations = Vec::with_capacity(2 * pairing.pairs.len());
    for &[a, b] in &pairing.pairs {
        let (_, [ra, rb]) = quad(
            &topology.triangles[a as usize],
            &topology.triangles[b as usize],
        )
        .expect("paired triangles share an edge in opposite directions");
        input_triangle.extend([a, b]);
        rotations.extend([ra, rb]);
    }
    input_triangle.extend_from_slice(&pairing.unpaired);
    let mut out = mesh.reordered(&input_triangle);
    for (t, r) in out.triangles.iter_mut().zip(rotations) {
        *t = rotate(*t, r);
    }
    PairedMesh {
        mesh: out,
        input_triangle,
        pair_count: pairing.pairs.len(),
    }
}

/// Box of triangle `t`'s corners.
#[inline]
pub(crate) fn triangle_box(mesh: &TriMesh, t: usize) -> Aabb {
    Aabb::from_points(&mesh.corners(t))
}

#[cfg(test)]
mod tests;

//! Strip-RT: SAH-aware triangle strips (C. Lauterbach, "Interactive ray tracing of
//! massive and deformable models", PhD thesis, UNC 2010, ch. 3, the ReduceM
//! stripification; `../shared/papers/strip-rt-lauterbach-thesis.txt`).
//!
//! 1. **Adjacency**: each triangle's strip neighbour across each side
//!    ([`super::strip_neighbours`]: two-triangle edges of the index topology, the
//!    other way round, within one group and material).
//! 2. **Partitioning**: a binned-SAH BVH down to single triangles (rtmesh's builder with
//!    leaves of one); each triangle keeps the node that references it. The 8-wide
//!    collapse makes up to eight triangles share a node, at distance 0. Or, not as
//!    published ([`PartitionMethod::Morton`]), the octree of the centroids' Morton
//!    codes: a sort, not a build.
//! 3. **Ordering**: every triangle starts as a sequence of length one, tied to its node.
//!    Each round, every active sequence ranks each merge with an adjacent active
//!    sequence at its open ends (up to four open sides; three for a lone triangle) by
//!
//!    ```text
//!    score = (1 − d(a, b) / (depth(a) + depth(b)))    tree distance, relative
//!          + 4·|a|·|b| / (|a| + |b|)²                 balance: harmonic mean of the
//!                                                     lengths over their total, × 2
//!    ```
//!
//!    (both terms in [0, 1], weighted equally, as published). The merges are taken best
//!    first, each sequence in at most one merge per round; the merged sequence gets the
//!    lowest common ancestor of the two nodes. A sequence with no possible merge leaves
//!    the active list; no merge may pass `max_length` triangles.
//! 4. **Tunnelling** (not in the thesis; [`super::tunnel`]): strips rerouted through up
//!    to `tunnel_cuts` cuts wherever that leaves fewer of them.
//! 5. **Output** in rtmesh's strip format ([`super::Strips`]), strips in the order the
//!    BVH's leaves reach their first triangle, so that neighbouring strips are near in
//!    memory.
//!
//! The ordering runs on the triangles renumbered in the BVH's leaf order, so that
//! neighbours are near in memory; names each node by its path from the root, so that a
//! lowest common ancestor is a common prefix; and keeps, per triangle, the sequence it
//! is an end of, so that a merge touches four entries and relabels nothing.
//!
//! Cost: O(T log T) for the partition (SAH: 0.7 µs a triangle, about 60% of the whole
//! on the dragon; Morton: under a tenth of that); each ordering round is O(active)
//! with a sort of the candidate merges, and the rounds number about log₂ L plus a
//! tail (9 on the dragon); tunnelling and output add about a fifth (0.2 s of 1.1 s on
//! the dragon, one core).

use super::{strip_neighbours, Encoder, Strips, NONE};
use crate::bvh::{BuildSettings, Bvh, Child};
use crate::geom::{morton_code, Aabb};
use crate::mesh::TriMesh;
use crate::trace::Triangle;
use glam::{UVec3, Vec3};

/// Settings of Strip-RT.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StripSettings {
    /// Most triangles in one strip (the published reason for a limit: strips of uneven
    /// length trace worse). The default, 34, is the shortest that keeps the five scans
    /// at or under 1.10 indices per triangle; it traces 1–2.5% slower than 32
    /// (`docs/measurements/strips.md`).
    pub max_length: usize,
    /// Most cuts a tunnelling move may make after the ordering ([`super::tunnel`]; at
    /// most [`super::tunnel::MAX_CUTS`]); 0 keeps the published ordering's strips.
    pub tunnel_cuts: usize,
    /// The object hierarchy whose tree distances the ordering ranks merges by.
    pub partition: PartitionMethod,
}

/// The hierarchy Strip-RT's ordering measures tree distances in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PartitionMethod {
    /// A binned-SAH BVH down to single triangles, as published.
    #[default]
    Sah,
    /// An octree by the Morton codes of the triangles' centroids (not published): a
    /// sort instead of a build, about a twentieth of the SAH partition's time, for strips
    /// that trace 2–7% slower (`docs/measurements/strips.md`).
    Morton,
}

impl PartitionMethod {
    /// The name `--partition` takes and the JSON reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Sah => "sah",
            Self::Morton => "morton",
        }
    }
}

impl std::str::FromStr for PartitionMethod {
    type Err = String;

    fn from_str(name: &str) -> Result<Self, String> {
        [Self::Sah, Self::Morton]
            .into_iter()
            .find(|p| p.name() == name)
            .ok_or_else(|| format!("the partition is sah or morton, not `{name}`"))
    }
}

impl Default for StripSettings {
    fn default() -> Self {
        Self {
            max_length: 34,
            tunnel_cuts: 3,
            partition: PartitionMethod::Sah,
        }
    }
}

/// Levels below the root that a [`Node`]'s path holds.
const PATH_LEVELS: u32 = 21;

/// A node of the partition, named by its path from the root: the child slot (0..8) it
/// takes at each level, three bits a level from the top bit down, and its depth (the
/// root's is 1). The partition's nodes are 8-wide, so the lowest common ancestor of
/// two nodes is their paths' common prefix, found without walking the tree (walking
/// parent links took a third of the ordering's time). Nodes deeper than
/// [`PATH_LEVELS`] (the median splits past binary depth 64 could make them; the
/// partitions of the scans, Sponza and the Conference room are 7–16 deep) count as
/// their ancestor at that depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Node {
    path: u64,
    depth: u32,
}

impl Node {
    const ROOT: Node = Node { path: 0, depth: 1 };

    /// Its child in `slot` (0..8).
    fn child(self, slot: usize) -> Node {
        let level = self.depth - 1;
        if level >= PATH_LEVELS {
            return self;
        }
        Node {
            path: self.path | (slot as u64) << (61 - 3 * level),
            depth: self.depth + 1,
        }
    }

    /// The lowest common ancestor of `self` and `other`, and the path length between
    /// them.
    #[inline(always)]
    fn meet(self, other: Node) -> (Node, u32) {
        let shared =
            ((self.path ^ other.path).leading_zeros() / 3).min(self.depth.min(other.depth) - 1);
        let ancestor = Node {
            path: self.path & !(u64::MAX >> (3 * shared)),
            depth: shared + 1,
        };
        (ancestor, self.depth + other.depth - 2 * ancestor.depth)
    }
}

/// The partition: the node each triangle hangs from.
struct Partition {
    node_of: Vec<Node>,
    /// Input triangle ids in the BVH's leaf order (those it left out, with non-finite
    /// corners, missing).
    leaf_order: Vec<u32>,
}

impl Partition {
    /// The published partition: rtmesh's binned-SAH builder with leaves of one.
    fn sah(mesh: &TriMesh) -> Self {
        let triangles: Vec<Triangle> = (0..mesh.triangle_count())
            .map(|t| Triangle::new(mesh.corners(t), t as u32))
            .collect();
        let settings = BuildSettings {
            max_leaf_size: 1,
            ..BuildSettings::quality()
        };
        let bvh = Bvh::build(triangles, &settings);
        // The root stands for itself when it is a leaf; triangles the BVH left out
        // (non-finite) hang from it.
        let mut node_of = vec![Node::ROOT; mesh.triangle_count()];
        let mut nodes = vec![Node::ROOT; bvh.nodes.len()];
        // Parents come before children in `nodes`.
        for (i, node) in bvh.nodes.iter().enumerate() {
            for (slot, &child) in node.children.iter().enumerate() {
                match Child::decode(child) {
                    Child::Inner(j) => nodes[j as usize] = nodes[i].child(slot),
                    Child::Leaf { first, count } => {
                        for p in first..first + count {
                            node_of[bvh.primitives[p as usize].id as usize] = nodes[i];
                        }
                    }
                    Child::Empty => {}
                }
            }
        }
        Self {
            node_of,
            leaf_order: bvh.primitives.iter().map(|t| t.id).collect(),
        }
    }

    /// The octree of the centroids' Morton codes (21 bits an axis in the centroids'
    /// bounding cube), read from the sorted codes without building it: a cell at level
    /// l is a common prefix of 3·l bits, which is what [`Node`]'s path holds. Each
    /// triangle hangs from the smallest cell it shares with another triangle (its
    /// longer common prefix with the codes before and after it), as leaves of one under
    /// one 8-wide node share that node in the SAH partition. Cost: one sort of T codes.
    fn morton(mesh: &TriMesh) -> Self {
        let n = mesh.triangle_count();
        let centroids: Vec<Vec3> = (0..n).map(|t| mesh.centroid(t)).collect();
        let bounds = Aabb::from_points(centroids.iter().filter(|c| c.is_finite()));
        let last = (1u32 << PATH_LEVELS) - 1;
        let scale = last as f32 / bounds.extent().max_element().max(f32::MIN_POSITIVE);
        // Codes shifted to the top of the word, where paths keep their levels.
        let mut coded: Vec<(u64, u32)> = (0..n as u32)
            .filter(|&t| centroids[t as usize].is_finite())
            .map(|t| {
                let q = ((centroids[t as usize] - bounds.min) * scale).as_uvec3();
                (morton_code(q.min(UVec3::splat(last))) << 1, t)
            })
            .collect();
        coded.sort_unstable();
        let shared_levels = |a: u64, b: u64| ((a ^ b).leading_zeros() / 3).min(PATH_LEVELS);
        // Triangles with non-finite centroids are left out, and hang from the root.
        let mut node_of = vec![Node::ROOT; n];
        for (i, &(code, t)) in coded.iter().enumerate() {
            let before = i
                .checked_sub(1)
                .map_or(0, |j| shared_levels(code, coded[j].0));
            let after = coded
                .get(i + 1)
                .map_or(0, |&(next, _)| shared_levels(code, next));
            let levels = before.max(after);
            node_of[t as usize] = Node {
                path: code & !(u64::MAX >> (3 * levels)),
                depth: levels + 1,
            };
        }
        Self {
            node_of,
            leaf_order: coded.into_iter().map(|(_, t)| t).collect(),
        }
    }
}

/// A sequence of triangles being grown.
#[derive(Clone, Copy)]
struct Sequence {
    ends: [u32; 2],
    length: u32,
    node: Node,
}

/// A possible merge: end `x` of sequence `a` with end `y` of sequence `b` across side
/// `side_x` of `x` (side `side_y` of `y`).
#[derive(Clone, Copy)]
struct Merge {
    score: f32,
    a: u32,
    b: u32,
    x: u32,
    y: u32,
    side_x: u8,
    side_y: u8,
}

/// Strip-RT over `mesh`'s triangles (by vertex index: weld first to share vertices).
pub fn stripify(mesh: &TriMesh, settings: &StripSettings) -> Strips {
    let n = mesh.triangle_count();
    let input_neighbours = strip_neighbours(mesh);
    let Partition {
        node_of,
        leaf_order: mut order,
    } = match settings.partition {
        PartitionMethod::Sah => Partition::sah(mesh),
        PartitionMethod::Morton => Partition::morton(mesh),
    };
    let max_length = settings.max_length.max(1) as u32;

    // The ordering works on triangles renumbered in the hierarchy's leaf order (those
    // left out of it last), so that neighbours are near in every array it reads.
    let mut local = vec![NONE; n];
    for (i, &t) in order.iter().enumerate() {
        local[t as usize] = i as u32;
    }
    for (t, place) in local.iter_mut().enumerate() {
        if *place == NONE {
            *place = order.len() as u32;
            order.push(t as u32);
        }
    }
    // Each side's neighbour and the side it is on there, packed as `4·y + side` (the
    // partition's BVH holds fewer than 2^27 triangles).
    let neighbours: Vec<[u32; 3]> = order
        .iter()
        .map(|&t| {
            input_neighbours[t as usize].map(|(o, side)| match o {
                NONE => NONE,
                o => local[o as usize] << 2 | side as u32,
            })
        })
        .collect();
    drop(input_neighbours);

    // Per triangle: up to two links (neighbour, own side), and the sequence it is an
    // end of while that sequence can still merge (NONE otherwise). A sequence's id is
    // one of its triangles'; a merge keeps the first sequence's.
    let mut links = vec![[(NONE, 0u8); 2]; n];
    let mut end_of: Vec<u32> = (0..n as u32).collect();
    let mut sequences: Vec<Sequence> = (0..n)
        .map(|t| Sequence {
            ends: [t as u32; 2],
            length: 1,
            node: node_of[order[t] as usize],
        })
        .collect();
    let mut active: Vec<u32> = (0..n as u32)
        .filter(|&t| neighbours[t as usize].iter().any(|&o| o != NONE))
        .collect();
    let mut merges: Vec<Merge> = Vec::with_capacity(active.len());
    let mut merged_this_round = vec![false; n];

    while !active.is_empty() {
        merges.clear();
        active.retain(|&a| {
            let sa = sequences[a as usize];
            let mut best: Option<Merge> = None;
            let ends: &[u32] = if sa.length == 1 {
                &sa.ends[..1]
            } else {
                &sa.ends
            };
            for &x in ends {
                for (side_x, &packed) in neighbours[x as usize].iter().enumerate() {
                    // Across an edge there is one neighbour, so a side of an end that
                    // is linked is linked within its own sequence: `b == a` covers it.
                    if packed == NONE {
                        continue;
                    }
                    let y = packed >> 2;
                    let b = end_of[y as usize];
                    if b == NONE || b == a {
                        continue;
                    }
                    let sb = sequences[b as usize];
                    if sa.length + sb.length > max_length {
                        continue;
                    }
                    let distance = sa.node.meet(sb.node).1;
                    let (la, lb) = (sa.length as f32, sb.length as f32);
                    let score = 1.0 - distance as f32 / (sa.node.depth + sb.node.depth) as f32
                        + 4.0 * la * lb / ((la + lb) * (la + lb));
                    if best.is_none_or(|m| score > m.score) {
                        best = Some(Merge {
                            score,
                            a,
                            b,
                            x,
                            y,
                            side_x: side_x as u8,
                            side_y: (packed & 3) as u8,
                        });
                    }
                }
            }
            match best {
                Some(m) => {
                    merges.push(m);
                    true
                }
                None => {
                    // Its neighbours only grow, so it never can again.
                    end_of[sa.ends[0] as usize] = NONE;
                    end_of[sa.ends[1] as usize] = NONE;
                    false
                }
            }
        });
        merges.sort_unstable_by(|p, q| q.score.total_cmp(&p.score));
        for m in &merges {
            if merged_this_round[m.a as usize] || merged_this_round[m.b as usize] {
                continue;
            }
            let (sa, sb) = (sequences[m.a as usize], sequences[m.b as usize]);
            link(&mut links, m.x, m.y, m.side_x);
            link(&mut links, m.y, m.x, m.side_y);
            let other_end = |s: Sequence, end: u32| {
                if s.ends[0] == end {
                    s.ends[1]
                } else {
                    s.ends[0]
                }
            };
            let ends = [other_end(sa, m.x), other_end(sb, m.y)];
            end_of[m.x as usize] = NONE;
            end_of[m.y as usize] = NONE;
            end_of[ends[0] as usize] = m.a;
            end_of[ends[1] as usize] = m.a;
            sequences[m.a as usize] = Sequence {
                ends,
                length: sa.length + sb.length,
                node: sa.node.meet(sb.node).0,
            };
            merged_this_round[m.a as usize] = true;
            merged_this_round[m.b as usize] = true;
        }
        // Merged-away sequences no longer own their ends.
        active.retain(|&a| end_of[sequences[a as usize].ends[0] as usize] == a);
        for m in &merges {
            merged_this_round[m.a as usize] = false;
            merged_this_round[m.b as usize] = false;
        }
    }

    super::tunnel::tunnel(&mut links, &neighbours, max_length, settings.tunnel_cuts);

    // Output in leaf order, each sequence walked from one end.
    let mut encoder = Encoder::new(&mesh.triangles);
    let mut emitted = vec![false; n];
    let mut sequence = Vec::with_capacity(max_length as usize);
    let mut exits = Vec::with_capacity(max_length as usize);
    for t in 0..n as u32 {
        if emitted[t as usize] {
            continue;
        }
        sequence.clear();
        exits.clear();
        let end = walk(&links, t).last().map_or(t, |(end, _)| end);
        for (t, exit) in walk(&links, end) {
            emitted[t as usize] = true;
            sequence.push(order[t as usize]);
            exits.extend(exit);
        }
        encoder.push(&sequence, &exits);
    }
    encoder.finish()
}

/// Record that `from`'s side `side` links to `to`.
pub(super) fn link(links: &mut [[(u32, u8); 2]], from: u32, to: u32, side: u8) {
    let slots = &mut links[from as usize];
    let free = if slots[0].0 == NONE { 0 } else { 1 };
    slots[free] = (to, side);
}

/// The triangles of the sequence that has `end` as an end, from that end, each with the
/// side it leaves by to the next (none for the last).
pub(super) fn walk(
    links: &[[(u32, u8); 2]],
    end: u32,
) -> impl Iterator<Item = (u32, Option<u8>)> + '_ {
    let mut previous = NONE;
    let mut current = end;
    std::iter::from_fn(move || {
        if current == NONE {
            return None;
        }
        let here = current;
        let next = links[here as usize]
            .iter()
            .find(|l| l.0 != NONE && l.0 != previous)
            .copied();
        previous = here;
        current = next.map_or(NONE, |l| l.0);
        Some((here, next.map(|l| l.1)))
    })
}

#[cfg(test)]
mod tests {
    use super::{Node, Partition};
    use crate::mesh::TriMesh;
    use glam::Vec3;

    #[test]
    fn a_morton_partition_hangs_near_triangles_from_one_cell() {
        // Two pairs of small triangles at opposite corners of the unit cube, and one
        // with a NaN corner.
        let corners = [
            Vec3::ZERO,
            Vec3::splat(0.001),
            Vec3::ONE,
            Vec3::splat(0.999),
        ];
        let mut positions = Vec::new();
        for c in corners {
            positions.extend([c, c + Vec3::X * 1e-4, c + Vec3::Y * 1e-4]);
        }
        positions.push(Vec3::NAN);
        let triangles = vec![[0, 1, 2], [3, 4, 5], [6, 7, 8], [9, 10, 11], [0, 1, 12]];
        let partition = Partition::morton(&TriMesh::new(positions, triangles));
        let node = &partition.node_of;
        assert_eq!(node[0], node[1]);
        assert_eq!(node[2], node[3]);
        assert!(node[0].depth > 5 && node[2].depth > 5, "{node:?}");
        // The pairs part at the first octant.
        assert_eq!(node[0].meet(node[2]).0, Node::ROOT);
        assert_eq!(node[4], Node::ROOT);
        assert_eq!(partition.leaf_order, [0, 1, 3, 2]);
    }

    #[test]
    fn nodes_meet_at_their_common_prefix() {
        let root = Node::ROOT;
        let (a, b) = (root.child(3), root.child(5));
        let (a1, a2) = (a.child(0), a.child(7));
        let a1x = a1.child(2).child(6);
        assert_eq!(a1.meet(a2), (a, 2));
        assert_eq!(a1x.meet(a2), (a, 4));
        assert_eq!(a1x.meet(b), (root, 5));
        assert_eq!(a1x.meet(a1), (a1, 2));
        assert_eq!(a1.meet(a1), (a1, 0));
        assert_eq!(root.meet(a1x), (root, 4));
        // Slot 0 children differ from their parent by depth alone.
        assert_eq!(a.child(0).child(0).meet(a), (a, 2));
    }

    #[test]
    fn nodes_past_the_path_length_count_as_their_ancestor() {
        let mut deep = Node::ROOT;
        for level in 0..30 {
            deep = deep.child(level % 8);
        }
        assert_eq!(deep.depth, super::PATH_LEVELS + 1);
        assert_eq!(deep.child(4), deep);
        assert_eq!(deep.meet(deep.child(1)), (deep, 0));
    }
}

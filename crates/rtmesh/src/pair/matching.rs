//! Beyond the paper: raise a pairing towards a maximum matching of the dual graph with
//! augmenting paths (Edmonds' blossom algorithm: J. Edmonds, "Paths, trees, and
//! flowers", Canad. J. Math. 17, 1965).
//!
//! The greedy scan stops at a maximal matching: about 11% of a scanned mesh's triangles
//! stay single although the dual graph of a closed manifold mesh is cubic and, by
//! Petersen's theorem, has a perfect matching when bridgeless. An augmenting path
//! (free triangle, unpaired edge, paired edge, …, unpaired edge, free triangle) flips
//! along its length and adds one pair; the greedy pairs stay the starting point, so
//! the SAH priority of the published scan decides every pair no path touches.
//!
//! The dual graph's edges join pairable triangles ([`super`]). With a pair box limit
//! λ (`sah-max`), an edge joins only triangles whose pair box has surface area at most
//! λ times the sum of their own boxes' areas (the greedy pairs stay in the graph
//! whatever their box), and each search gives up after [`SEARCH_LIMIT`] vertices, so
//! that a triangle with no short path costs little. Without a limit (`max`) the result
//! is a maximum-cardinality matching.
//!
//! Each free triangle is searched once, by breadth-first search that shrinks odd
//! cycles into blossoms through a union-find over the blossoms' bases, at the cost of
//! the cycle (relabelling every vertex the search had touched made long searches
//! quadratic). The per-search state lives in
//! arrays stamped by search, so a search costs what it touches, not O(T). A free
//! vertex with no augmenting path never gains one later (Edmonds), so one pass over the
//! free triangles reaches the maximum; nor does any vertex of the failed search's
//! (Hungarian) tree lie on a later path, so later searches pass those by. Cost:
//! O(T · touched) worst case, where a failed search's touch is paid once; on scanned
//! meshes paths are short and the pass takes about as long as the greedy pairing.
//! Edges of many half-edges link O(k) pairs, not all ([`EDGE_ALL_PAIRS`]).

use super::{triangle_box, ActiveTriangles, Pairing, UNPAIRED};
use crate::mesh::{HalfEdgeRuns, TriMesh};
use std::collections::VecDeque;

/// Vertices a `sah-max` search may touch before it gives up.
pub const SEARCH_LIMIT: usize = 4096;

/// Edges of up to this many half-edges link every two that run opposite ways. On an
/// edge of more (a fin, or a book of pages around one edge), all pairs would be O(k²)
/// links: instead the half-edges of the direction with more, in id order, link each to
/// a band of [`EDGE_BAND`] of the other direction's at the same relative place, so
/// that every half-edge has a link, the edge alone can still pair as many as the
/// smaller direction has, and the links are O(k). There the result can fall short of
/// the true maximum.
pub const EDGE_ALL_PAIRS: usize = 16;

/// The band of [`EDGE_ALL_PAIRS`]: how many half-edges of the other direction each
/// half-edge of an edge's larger direction links to.
pub const EDGE_BAND: usize = 9;

const NONE: u32 = u32::MAX;

/// The dual graph in CSR form: `neighbours[start[t]..start[t + 1]]`.
struct DualGraph {
    start: Vec<u32>,
    neighbours: Vec<u32>,
}

impl DualGraph {
    /// Pairable neighbours of every triangle; with `limit`, only those whose pair box
    /// passes it, plus each triangle's current partner.
    fn build(mesh: &TriMesh, partner: &[u32], limit: Option<f32>) -> Self {
        let n = mesh.triangle_count();
        let active = ActiveTriangles::new(mesh);
        let runs = HalfEdgeRuns::build(mesh);
        let mut links: Vec<[u32; 2]> = Vec::with_capacity(runs.half_edge_count());
        // Link half-edges `ha` and `hb` of one edge, running opposite ways, if their
        // triangles may pair.
        let mut link = |ha: u32, hb: u32| {
            let (a, b) = (ha / 3, hb / 3);
            if a == b || !active.get(a as usize) || !active.get(b as usize) {
                return;
            }
            let admissible = partner[a as usize] == b
                || limit.is_none_or(|lambda| {
                    let (box_a, box_b) = (
                        triangle_box(mesh, a as usize),
                        triangle_box(mesh, b as usize),
                    );
                    box_a.union(box_b).half_area()
                        <= lambda * (box_a.half_area() + box_b.half_area())
                });
            if admissible {
                links.push([a, b]);
            }
        };
        runs.for_each_edge(|first, _, half_edges| {
            // Whether half-edge h starts at the edge's smaller vertex.
            let forward = |h: u32| mesh.triangles[(h / 3) as usize][(h % 3) as usize] == first;
            if half_edges.len() <= EDGE_ALL_PAIRS {
                for (i, &(_, ha)) in half_edges.iter().enumerate() {
                    let ahead = forward(ha);
                    for &(_, hb) in &half_edges[i + 1..] {
                        if forward(hb) != ahead {
                            link(ha, hb);
                        }
                    }
                }
                return;
            }
            let (ahead, back): (Vec<u32>, Vec<u32>) = half_edges
                .iter()
                .map(|&(_, h)| h)
                .partition(|&h| forward(h));
            let (more, fewer) = if ahead.len() >= back.len() {
                (ahead, back)
            } else {
                (back, ahead)
            };
            for (i, &ha) in more.iter().enumerate() {
                let centre = i * fewer.len() / more.len();
                let from = centre.saturating_sub(EDGE_BAND / 2);
                for &hb in fewer.iter().skip(from).take(EDGE_BAND) {
                    link(ha, hb);
                }
            }
        });
        let mut start = vec![0u32; n + 1];
        for &[a, b] in &links {
            start[a as usize + 1] += 1;
            start[b as usize + 1] += 1;
        }
        for t in 0..n {
            start[t + 1] += start[t];
        }
        let mut cursor = start[..n].to_vec();
        let mut neighbours = vec![0u32; start[n] as usize];
        for &[a, b] in &links {
            neighbours[cursor[a as usize] as usize] = b;
            cursor[a as usize] += 1;
            neighbours[cursor[b as usize] as usize] = a;
            cursor[b as usize] += 1;
        }
        Self { start, neighbours }
    }

    #[inline]
    fn of(&self, t: u32) -> &[u32] {
        &self.neighbours[self.start[t as usize] as usize..self.start[t as usize + 1] as usize]
    }
}

/// How a search for an augmenting path ended.
enum Found {
    /// A path, ending at this free vertex.
    Path(u32),
    /// No path: the vertices touched (the Hungarian tree) are never on one later.
    None,
    /// The search gave up at its limit.
    GaveUp,
}

/// Edmonds' search state; entries are valid for the current search when stamped.
struct Search<'g> {
    graph: &'g DualGraph,
    mate: Vec<u32>,
    /// Vertices of the Hungarian tree of a search that found no path. Edmonds: such a
    /// tree's vertices are on no augmenting path of this or any later matching, so
    /// later searches pass them by, and each vertex is in at most one failed search.
    dead: Vec<bool>,
    stamp: Vec<u32>,
    epoch: u32,
    parent: Vec<u32>,
    /// Union-find over blossoms: follow `base` to the base of a vertex's blossom
    /// ([`Search::base_of`]).
    base: Vec<u32>,
    in_queue: Vec<bool>,
    path_mark: Vec<u32>,
    path_epoch: u32,
    touched: Vec<u32>,
    /// The bases and mates that [`Search::mark_path`] met, for [`Search::shrink`].
    shrunk: Vec<u32>,
    queue: VecDeque<u32>,
}

impl<'g> Search<'g> {
    fn new(graph: &'g DualGraph, mate: Vec<u32>) -> Self {
        let n = mate.len();
        Self {
            graph,
            mate,
            dead: vec![false; n],
            stamp: vec![0; n],
            epoch: 0,
            parent: vec![NONE; n],
            base: vec![0; n],
            in_queue: vec![false; n],
            path_mark: vec![0; n],
            path_epoch: 0,
            touched: Vec::new(),
            shrunk: Vec::new(),
            queue: VecDeque::new(),
        }
    }

    /// Make `v`'s state valid for this search.
    #[inline]
    fn touch(&mut self, v: u32) {
        let i = v as usize;
        if self.stamp[i] != self.epoch {
            self.stamp[i] = self.epoch;
            self.parent[i] = NONE;
            self.base[i] = v;
            self.in_queue[i] = false;
            self.touched.push(v);
        }
    }

    /// The base of `v`'s blossom (halving the union-find path on the way).
    #[inline]
    fn base_of(&mut self, mut v: u32) -> u32 {
        loop {
            let up = self.base[v as usize];
            if up == v {
                return v;
            }
            let skip = self.base[up as usize];
            self.base[v as usize] = skip;
            v = skip;
        }
    }

    /// Lowest common ancestor of `a` and `b` in the alternating tree (by bases).
    fn common_base(&mut self, mut a: u32, mut b: u32) -> u32 {
        self.path_epoch += 1;
        loop {
            a = self.base_of(a);
            self.path_mark[a as usize] = self.path_epoch;
            let m = self.mate[a as usize];
            if m == NONE {
                break;
            }
            a = self.parent[m as usize];
        }
        loop {
            b = self.base_of(b);
            if self.path_mark[b as usize] == self.path_epoch {
                return b;
            }
            b = self.parent[self.mate[b as usize] as usize];
        }
    }

    /// Walk the cycle from `v` down to base `b`, pointing parents at `child`, and
    /// note the bases met on the way and their mates in [`Search::shrunk`].
    fn mark_path(&mut self, mut v: u32, b: u32, mut child: u32) {
        loop {
            let v_base = self.base_of(v);
            if v_base == b {
                break;
            }
            let m = self.mate[v as usize];
            self.shrunk.extend([v_base, m]);
            self.parent[v as usize] = child;
            child = m;
            v = self.parent[m as usize];
        }
    }

    /// Breadth-first search for an augmenting path from free `root`. Gives up after
    /// touching `limit` vertices.
    fn find_path(&mut self, root: u32, limit: usize) -> Found {
        self.epoch += 1;
        self.touched.clear();
        self.queue.clear();
        self.touch(root);
        self.in_queue[root as usize] = true;
        self.queue.push_back(root);
        while let Some(v) = self.queue.pop_front() {
            if self.touched.len() > limit {
                return Found::GaveUp;
            }
            for &to in self.graph.of(v) {
                if self.dead[to as usize] {
                    continue;
                }
                self.touch(to);
                if self.base_of(v) == self.base_of(to) || self.mate[v as usize] == to {
                    continue;
                }
                let to_mate = self.mate[to as usize];
                if to_mate != NONE {
                    self.touch(to_mate);
                }
                if to == root || (to_mate != NONE && self.parent[to_mate as usize] != NONE) {
                    // An odd cycle: shrink it into a blossom with base `b`.
                    let b = self.common_base(v, to);
                    self.mark_path(v, b, to);
                    self.mark_path(to, b, v);
                    self.shrink(b);
                } else if self.parent[to as usize] == NONE {
                    self.parent[to as usize] = v;
                    if to_mate == NONE {
                        return Found::Path(to);
                    }
                    self.in_queue[to_mate as usize] = true;
                    self.queue.push_back(to_mate);
                }
            }
        }
        for &v in &self.touched {
            self.dead[v as usize] = true;
        }
        Found::None
    }

    /// Shrink the blossom of base `b` whose cycle [`Search::mark_path`] walked: the
    /// blossoms it met join `b`'s, and the odd (inner) vertices among them, the mates
    /// not in the queue yet, turn even and join it. Costs the cycle's length, where
    /// relabelling every touched vertex would cost the search's size per blossom.
    fn shrink(&mut self, b: u32) {
        for i in 0..self.shrunk.len() {
            let v = self.shrunk[i];
            let v_base = self.base_of(v);
            self.base[v_base as usize] = b;
            if !self.in_queue[v as usize] {
                self.in_queue[v as usize] = true;
                self.queue.push_back(v);
            }
        }
        self.shrunk.clear();
    }

    /// Flip the path ending at free `end`.
    fn augment(&mut self, mut end: u32) {
        while end != NONE {
            let via = self.parent[end as usize];
            let next = self.mate[via as usize];
            self.mate[end as usize] = via;
            self.mate[via as usize] = end;
            end = next;
        }
    }
}

/// Raise `start` by augmenting paths: with `pair_box_limit` (`sah-max`) over pairs
/// whose box passes the limit and with bounded searches; without (`max`) to a
/// maximum-cardinality matching.
pub fn raise(mesh: &TriMesh, start: &Pairing, pair_box_limit: Option<f32>) -> Pairing {
    let n = mesh.triangle_count();
    let partner = start.partners(n);
    let graph = DualGraph::build(mesh, &partner, pair_box_limit);
    let limit = if pair_box_limit.is_some() {
        SEARCH_LIMIT
    } else {
        usize::MAX
    };
    let mut search = Search::new(&graph, partner);
    for root in 0..n as u32 {
        let free = search.mate[root as usize] == UNPAIRED && !search.dead[root as usize];
        if free && !graph.of(root).is_empty() {
            if let Found::Path(end) = search.find_path(root, limit) {
                search.augment(end);
            }
        }
    }
    Pairing::from_partners(&search.mate)
}

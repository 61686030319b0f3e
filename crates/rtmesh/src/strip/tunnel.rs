//! Tunnelling: fewer strips by rerouting them through cuts (after A. J. Stewart,
//! "Tunneling for triangle strips in continuous level-of-detail meshes", Graphics
//! Interface 2001, which joins two strips along an alternating path of strip and
//! non-strip edges of the dual graph). It runs after Strip-RT's ordering, which is as
//! published; `StripSettings::tunnel_cuts` 0 leaves it out.
//!
//! Strip-RT's ordering stops when no two sequence ends face each other across an edge.
//! What is left is mostly an end `x` of a strip A facing the inside of another strip B,
//! at a triangle `y`. Cutting B next to `y`, on the side of its neighbour `c`, and
//! linking `x` to `y` leaves as many strips: A grows by the part of B that holds `y`,
//! and the rest of B now ends at `c`. It pays when `c` faces an end `z` of a third
//! strip, which the rest then joins: one strip fewer. The path may go through up to
//! `cuts` such cuts (`c` facing the inside of a fourth strip, and so on) before it
//! reaches an end; a direct join (`y` an end of B, which earlier moves can make) is one
//! with no cut. Every strip on a path is distinct, every link is across an edge of the
//! strip neighbours (so within one group and material, with the winding kept), and no
//! strip passes `max_length`.
//!
//! The search is depth-first, fewest cuts first: rounds with at most one cut until a
//! round joins under 1% of the strips, then two, then up to `cuts`. On the dragon at
//! the default length it takes Strip-RT's 75,724 strips to about 44,800 (1.174 → 1.103
//! indices per triangle, docs/measurements/strips.md).
//!
//! Cost: each strip end tries its three sides, each inner `y` its two cuts, to depth
//! `cuts`; a move relabels the strips it touches, O(max_length). A round is
//! O(T · 6^cuts · max_length) at worst, about O(T) on the scans, where most ends stop at
//! the first step.

use super::sah::{link, walk};
use super::NONE;

/// Most cuts one move may make.
pub const MAX_CUTS: usize = 4;

/// A set of strips as links (per triangle, up to two `(neighbour, own side)` pairs, as
/// [`super::sah`] makes them), with each triangle's strip and each strip's length.
struct Cover<'a> {
    links: &'a mut [[(u32, u8); 2]],
    /// A strip is named by one of its triangles.
    strip_of: Vec<u32>,
    /// Each triangle's place in its strip, counted from the end [`Cover::relabel`]
    /// walked it from, so that the length on either side of a link is two subtractions
    /// (a walk along the strip took a fifth of the whole stripification).
    place: Vec<u32>,
    /// Indexed by a strip's name.
    length: Vec<u32>,
}

impl Cover<'_> {
    fn is_end(&self, t: u32) -> bool {
        self.links[t as usize].iter().any(|l| l.0 == NONE)
    }

    /// Name the strip through `t` by `t` and count it.
    fn relabel(&mut self, t: u32) {
        let end = walk(self.links, t).last().map_or(t, |(end, _)| end);
        let mut length = 0;
        for (u, _) in walk(self.links, end) {
            self.strip_of[u as usize] = t;
            self.place[u as usize] = length;
            length += 1;
        }
        self.length[t as usize] = length;
    }

    /// Triangles from `from` onward, away from its neighbour `away` in the same strip.
    fn length_beyond(&self, from: u32, away: u32) -> u32 {
        let (from_place, away_place) = (self.place[from as usize], self.place[away as usize]);
        if from_place > away_place {
            self.length[self.strip_of[from as usize] as usize] - from_place
        } else {
            from_place + 1
        }
    }

    fn unlink(&mut self, a: u32, b: u32) {
        for (from, to) in [(a, b), (b, a)] {
            if let Some(l) = self.links[from as usize].iter_mut().find(|l| l.0 == to) {
                *l = (NONE, 0);
            }
        }
    }
}

/// A path being searched: the strips it passes through (the first is the start's) and
/// its cuts `(y, c)`: `y` is linked to the previous free end, its link to `c` is cut,
/// and `c` is the next free end.
struct Path {
    strips: [u32; MAX_CUTS + 1],
    cuts: [(u32, u32); MAX_CUTS],
    len: usize,
}

impl Path {
    fn uses(&self, strip: u32) -> bool {
        self.strips[..=self.len].contains(&strip)
    }
}

/// Join the strips `links` describes through moves of up to `cuts` cuts (at most
/// [`MAX_CUTS`]), keeping each strip within `max_length` triangles;
/// `neighbours[t][side]` is `4·u + (u's side)` for the triangle `u` across `t`'s
/// `side`, or [`NONE`]. Returns the strips joined away.
pub(super) fn tunnel(
    links: &mut [[(u32, u8); 2]],
    neighbours: &[[u32; 3]],
    max_length: u32,
    cuts: usize,
) -> usize {
    let n = links.len();
    let mut cover = Cover {
        links,
        strip_of: vec![NONE; n],
        place: vec![0; n],
        length: vec![0; n],
    };
    let mut strips = 0usize;
    for t in 0..n as u32 {
        if cover.strip_of[t as usize] == NONE {
            cover.relabel(t);
            strips += 1;
        }
    }
    let mut joined = 0;
    for depth in 1..=cuts.min(MAX_CUTS) {
        loop {
            let mut round = 0usize;
            for x in 0..n as u32 {
                if cover.is_end(x) && join_from(&mut cover, neighbours, max_length, x, depth) {
                    round += 1;
                }
            }
            joined += round;
            // Another round while it still joins 1% of the strips; none left to join
            // (an empty mesh) ends it too.
            if round == 0 || round * 100 < strips - joined {
                break;
            }
        }
    }
    joined
}

/// Make one move from the strip end `x` that leaves one strip fewer, with at most
/// `cuts` cuts; returns whether one was found.
fn join_from(
    cover: &mut Cover,
    neighbours: &[[u32; 3]],
    max_length: u32,
    x: u32,
    cuts: usize,
) -> bool {
    let start = cover.strip_of[x as usize];
    let mut path = Path {
        strips: [start; MAX_CUTS + 1],
        cuts: [(NONE, NONE); MAX_CUTS],
        len: 0,
    };
    let carried = cover.length[start as usize];
    let Some(z) = search(cover, neighbours, max_length, x, carried, &mut path, cuts) else {
        return false;
    };
    let mut from = x;
    for &(y, c) in &path.cuts[..path.len] {
        cover.unlink(y, c);
        join(cover, neighbours, from, y);
        from = c;
    }
    join(cover, neighbours, from, z);
    cover.relabel(x);
    for &(_, c) in &path.cuts[..path.len] {
        cover.relabel(c);
    }
    true
}

/// Where the free end `from` of a piece of `carried` triangles can go: the end `z` of
/// a strip not on `path` that it joins, after the cuts this pushes on `path` (at most
/// `cuts` more).
fn search(
    cover: &Cover,
    neighbours: &[[u32; 3]],
    max_length: u32,
    from: u32,
    carried: u32,
    path: &mut Path,
    cuts: usize,
) -> Option<u32> {
    let across = neighbours[from as usize]
        .map(|p| (p != NONE).then(|| (p >> 2, cover.strip_of[(p >> 2) as usize])));
    for &(y, strip) in across.iter().flatten() {
        if !path.uses(strip)
            && cover.is_end(y)
            && carried + cover.length[strip as usize] <= max_length
        {
            return Some(y);
        }
    }
    if cuts == 0 {
        return None;
    }
    for &(y, strip) in across.iter().flatten() {
        if path.uses(strip) || cover.is_end(y) {
            continue;
        }
        for c in cover.links[y as usize].map(|l| l.0) {
            let rest = cover.length_beyond(c, y);
            if carried + cover.length[strip as usize] - rest > max_length {
                continue;
            }
            path.cuts[path.len] = (y, c);
            path.len += 1;
            path.strips[path.len] = strip;
            if let Some(z) = search(cover, neighbours, max_length, c, rest, path, cuts - 1) {
                return Some(z);
            }
            path.len -= 1;
        }
    }
    None
}

/// Link `t` and its neighbour `u`.
fn join(cover: &mut Cover, neighbours: &[[u32; 3]], t: u32, u: u32) {
    link(cover.links, t, u, side_of(neighbours, t, u));
    link(cover.links, u, t, side_of(neighbours, u, t));
}

/// The side of `t` across which `u` lies.
fn side_of(neighbours: &[[u32; 3]], t: u32, u: u32) -> u8 {
    neighbours[t as usize]
        .iter()
        .position(|&p| p != NONE && p >> 2 == u)
        .expect("u is a neighbour of t") as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Per triangle, its links as [`tunnel`] takes them.
    type Links = Vec<[(u32, u8); 2]>;

    /// A strip b0–b1–b2–b3 with a lone triangle `x` beside b1 and a lone `z` beside b2
    /// (triangles 0..6 = b0, b1, b2, b3, x, z). No two ends face each other, so the
    /// ordering leaves three strips; cutting b1 from b2 makes x–b1–b0 and b3–b2–z.
    fn strip_with_two_lone_triangles() -> (Links, Vec<[u32; 3]>) {
        let across = |u: u32, side: u32| u << 2 | side;
        let neighbours = vec![
            [across(1, 0), NONE, NONE],
            [across(0, 0), across(2, 0), across(4, 0)],
            [across(1, 1), across(3, 0), across(5, 0)],
            [across(2, 1), NONE, NONE],
            [across(1, 2), NONE, NONE],
            [across(2, 2), NONE, NONE],
        ];
        let mut links = vec![[(NONE, 0u8); 2]; 6];
        links[0][0] = (1, 0);
        links[1] = [(0, 0), (2, 1)];
        links[2] = [(1, 0), (3, 1)];
        links[3][0] = (2, 0);
        (links, neighbours)
    }

    fn sorted(mut l: [(u32, u8); 2]) -> [(u32, u8); 2] {
        l.sort();
        l
    }

    #[test]
    fn one_cut_reroutes_a_strip_to_take_in_two_lone_triangles() {
        let (mut links, neighbours) = strip_with_two_lone_triangles();
        assert_eq!(tunnel(&mut links, &neighbours, 32, 1), 1);
        let expected = [
            [(1, 0), (NONE, 0)],
            [(0, 0), (4, 2)],
            [(3, 1), (5, 2)],
            [(2, 0), (NONE, 0)],
            [(1, 0), (NONE, 0)],
            [(2, 0), (NONE, 0)],
        ];
        for (t, l) in expected.iter().enumerate() {
            assert_eq!(sorted(links[t]), sorted(*l), "triangle {t}");
        }
    }

    /// Without cuts nothing joins (no two ends face each other); with a maximum length
    /// of 2 no move could keep its strips that short.
    #[test]
    fn no_move_without_cuts_or_past_the_maximum_length() {
        for (max_length, cuts) in [(32, 0), (2, 1), (2, MAX_CUTS)] {
            let (mut links, neighbours) = strip_with_two_lone_triangles();
            let before = links.clone();
            assert_eq!(tunnel(&mut links, &neighbours, max_length, cuts), 0);
            assert_eq!(links, before);
        }
    }

    /// No triangles: nothing to join, and the rounds end (they once spun forever).
    #[test]
    fn an_empty_cover_ends_at_once() {
        assert_eq!(tunnel(&mut [], &[], 32, MAX_CUTS), 0);
    }
}

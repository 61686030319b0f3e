//! The connected pieces of a geometry, by edges after welding identical positions, and
//! whether they leave its box mostly empty (a *scattered* geometry, better split into
//! instances). Cost: a weld, the edge adjacency and a union of boxes, O(T).

use crate::geom::Aabb;
use crate::mesh::{connected_components, EdgeAdjacency, TriMesh};

/// The connected pieces of a geometry (by edges, after welding identical positions):
/// the piece of every triangle, each piece's box, and the pieces' summed box area over
/// the geometry's box area (`coverage`: below ½ the pieces are far apart).
#[derive(Clone, Debug)]
pub struct Pieces {
    /// Piece id per triangle (`u32::MAX` for triangles without an edge).
    pub of_triangle: Vec<u32>,
    /// Box per piece.
    pub boxes: Vec<Aabb>,
    /// Σ piece box half-areas / geometry box half-area.
    pub coverage: f32,
}

impl Pieces {
    /// The pieces of `mesh`.
    pub fn of(mesh: &TriMesh) -> Self {
        let welded = mesh.topology();
        let (of_triangle, count) = connected_components(&EdgeAdjacency::build(&welded));
        let mut boxes = vec![Aabb::EMPTY; count];
        for (t, &c) in of_triangle.iter().enumerate() {
            if let (true, Some(corners)) = ((c as usize) < count, welded.finite_corners(t)) {
                boxes[c as usize] = boxes[c as usize].union(Aabb::from_points(&corners));
            }
        }
        let whole = boxes.iter().fold(Aabb::EMPTY, |b, &p| b.union(p));
        let covered: f32 = boxes.iter().map(Aabb::half_area).sum();
        Self {
            of_triangle,
            coverage: covered / whole.half_area().max(f32::MIN_POSITIVE),
            boxes,
        }
    }

    /// More than one piece, covering under half the geometry's box area.
    pub fn scattered(&self) -> bool {
        self.boxes.len() > 1 && self.coverage < 0.5
    }
}

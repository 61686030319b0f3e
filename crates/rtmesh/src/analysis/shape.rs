//! The shape of a triangle as a BVH sees it: its area, the empty space of its box and
//! its aspect (longest edge over shortest altitude). O(1) per triangle.

use crate::geom::{triangle_area, Aabb};

/// The shape of one triangle as a BVH sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleShape {
    /// Area.
    pub area: f32,
    /// `1 − min(1, 2·area / largest box face)`.
    pub empty_space: f32,
    /// Longest edge² / (2·area).
    pub aspect: f32,
    /// Half the surface area of the triangle's box (its SAH weight).
    pub box_half_area: f32,
}

impl TriangleShape {
    /// The shape of the triangle with corners `c`.
    pub fn of(c: [glam::Vec3; 3]) -> Self {
        let area = triangle_area(c[0], c[1], c[2]);
        let extent = Aabb::from_points(&c).extent();
        let largest_face = (extent.x * extent.y)
            .max(extent.y * extent.z)
            .max(extent.z * extent.x);
        let longest = (0..3)
            .map(|k| (c[(k + 1) % 3] - c[k]).length_squared())
            .fold(0.0f32, f32::max);
        let empty_space = if largest_face > 0.0 {
            1.0 - (2.0 * area / largest_face).min(1.0)
        } else {
            // A triangle in a line has a flat box: all empty unless it is a point.
            if longest > 0.0 {
                1.0
            } else {
                0.0
            }
        };
        Self {
            area,
            empty_space,
            aspect: if area > 0.0 {
                longest / (2.0 * area)
            } else {
                f32::INFINITY
            },
            box_half_area: extent.x * extent.y + extent.y * extent.z + extent.z * extent.x,
        }
    }

    /// Whether this triangle is elongated: not degenerate, and its box at least
    /// `empty_space` empty or its aspect at least `aspect`.
    pub fn is_elongated(&self, empty_space: f32, aspect: f32) -> bool {
        self.area > 0.0 && (self.empty_space >= empty_space || self.aspect >= aspect)
    }
}

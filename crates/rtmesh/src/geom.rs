//! Small geometric types shared by every module: axis-aligned boxes and rays.
//!
//! Vectors are glam's `Vec3` (f32); these types add what ray tracing needs on top.

use glam::Vec3;
use serde::Serialize;

/// Axis-aligned bounding box. The empty box has `min = +inf`, `max = -inf`, so that
/// growing it by any point gives that point's box.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The empty box: the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// Box of one point.
    pub fn from_point(p: Vec3) -> Self {
        Self { min: p, max: p }
    }

    /// Box of a set of points.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a Vec3>) -> Self {
        points
            .into_iter()
            .fold(Self::EMPTY, |b, &p| b.grown_by_point(p))
    }

    /// This box grown to contain `p`.
    #[inline]
    pub fn grown_by_point(self, p: Vec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// Smallest box containing both.
    #[inline]
    pub fn union(self, other: Aabb) -> Self {
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// Intersection of both boxes (empty when they do not overlap).
    #[inline]
    pub fn intersection(self, other: Aabb) -> Self {
        Self {
            min: self.min.max(other.min),
            max: self.max.min(other.max),
        }
    }

    /// True when no point lies inside.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// True when the box holds a point and its corners are finite: a box a BVH can
    /// be built over.
    #[inline]
    pub fn is_finite(&self) -> bool {
        !self.is_empty() && self.min.is_finite() && self.max.is_finite()
    }

    /// Edge lengths (zero for the empty box).
    #[inline]
    pub fn extent(&self) -> Vec3 {
        (self.max - self.min).max(Vec3::ZERO)
    }

    /// Centre point.
    #[inline]
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Surface area: `2 (xy + yz + zx)`; zero for the empty box.
    #[inline]
    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.extent();
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// Half the surface area: the quantity the SAH needs (the factor 2 cancels).
    #[inline]
    pub fn half_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.extent();
        d.x * d.y + d.y * d.z + d.z * d.x
    }

    /// Volume; zero for the empty box.
    pub fn volume(&self) -> f32 {
        let d = self.extent();
        d.x * d.y * d.z
    }

    /// Length of the diagonal.
    pub fn diagonal_length(&self) -> f32 {
        self.extent().length()
    }

    /// The box of the eight corners of this box under `transform`.
    pub fn transformed(&self, transform: &glam::Affine3A) -> Aabb {
        if self.is_empty() {
            return *self;
        }
        (0..8).fold(Aabb::EMPTY, |b, corner| {
            let p = Vec3::new(
                if corner & 1 == 0 {
                    self.min.x
                } else {
                    self.max.x
                },
                if corner & 2 == 0 {
                    self.min.y
                } else {
                    self.max.y
                },
                if corner & 4 == 0 {
                    self.min.z
                } else {
                    self.max.z
                },
            );
            b.grown_by_point(transform.transform_point3(p))
        })
    }
}

/// A ray `origin + t * direction` for `t` in `[t_min, t_max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start point.
    pub origin: Vec3,
    /// Direction (not necessarily unit length).
    pub direction: Vec3,
    /// Smallest accepted distance.
    pub t_min: f32,
    /// Largest accepted distance.
    pub t_max: f32,
}

impl Ray {
    /// A ray over `[0, inf)`.
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        Self {
            origin,
            direction,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    /// Point at distance `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }
}

/// Area of the triangle `(a, b, c)`.
#[inline]
pub fn triangle_area(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    0.5 * (b - a).cross(c - a).length()
}

/// Morton code of a grid cell: the bits of `q`'s coordinates interleaved, x lowest
/// (bit 3i of the code is x's bit i, 3i + 1 y's, 3i + 2 z's), from 21 bits an axis.
/// The top three bits of a code name the cell's octant, the next three its octant in
/// that, and so on, so a Morton order is an octree's depth-first order.
pub fn morton_code(q: glam::UVec3) -> u64 {
    let spread = |x: u32| {
        let mut x = u64::from(x) & 0x1f_ffff;
        x = (x | x << 32) & 0x001f_0000_0000_ffff;
        x = (x | x << 16) & 0x001f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        (x | x << 2) & 0x1249_2492_4924_9249
    };
    spread(q.x) | spread(q.y) << 1 | spread(q.z) << 2
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_codes_interleave_the_coordinates() {
        assert_eq!(morton_code(glam::UVec3::new(1, 0, 0)), 0b001);
        assert_eq!(morton_code(glam::UVec3::new(0, 1, 0)), 0b010);
        assert_eq!(morton_code(glam::UVec3::new(0, 0, 1)), 0b100);
        assert_eq!(morton_code(glam::UVec3::new(3, 0, 2)), 0b101_001);
        let top = (1 << 20) as u32;
        assert_eq!(morton_code(glam::UVec3::new(top, top, top)), 0b111 << 60);
        assert_eq!(morton_code(glam::UVec3::splat(0x1f_ffff)), (1 << 63) - 1);
    }

    #[test]
    fn empty_box_is_union_identity() {
        let b = Aabb::from_point(Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(Aabb::EMPTY.union(b), b);
        assert!(Aabb::EMPTY.is_empty());
        assert_eq!(Aabb::EMPTY.surface_area(), 0.0);
    }

    #[test]
    fn unit_cube_area_and_volume() {
        let b = Aabb::from_points(&[Vec3::ZERO, Vec3::ONE]);
        assert_eq!(b.surface_area(), 6.0);
        assert_eq!(b.half_area(), 3.0);
        assert_eq!(b.volume(), 1.0);
        assert_eq!(b.center(), Vec3::splat(0.5));
    }

    #[test]
    fn rotated_box_grows() {
        let b = Aabb::from_points(&[Vec3::ZERO, Vec3::ONE]);
        let r = glam::Affine3A::from_rotation_z(std::f32::consts::FRAC_PI_4);
        let t = b.transformed(&r);
        assert!((t.extent().x - 2f32.sqrt()).abs() < 1e-5);
        assert!((t.extent().z - 1.0).abs() < 1e-6);
    }
}

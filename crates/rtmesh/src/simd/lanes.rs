//! SIMD lanes for the intersectors and packet traversal: one trait, [`Lanes`],
//! implemented by plain `f32` (the scalar reference, one triangle at a time, with real
//! early-out branches), by `wide::f32x4` (4 triangles per test on any CPU: SSE, NEON or
//! scalar emulation), by `wide::f32x8` (8 lanes as two halves unless the whole program
//! is built for AVX) and, on x86-64, by `Avx8` (8 triangles per test in 256-bit AVX
//! registers, in `avx.rs`, only run through `super::dispatch`). The intersectors are written once over this
//! trait, so the three forms execute the same IEEE operations in the same order (no
//! fused multiply-add) and give bit-identical results.

use glam::Vec3;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Sub};
use wide::{f32x4, f32x8};

/// A vector of `WIDTH` floats, with comparisons into a lane mask.
pub trait Lanes:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// The result of a comparison, one truth value per lane.
    type Mask: Copy + BitAnd<Output = Self::Mask> + BitOr<Output = Self::Mask>;
    /// Lanes per vector.
    const WIDTH: usize;
    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// Lanes from `values[..WIDTH]`.
    fn load(values: &[f32]) -> Self;
    /// Lane `i` from `values[i % 4]`: four values repeated across a wider vector.
    fn load_repeated(values: &[f32; 4]) -> Self;
    /// The lanes as an array (first `WIDTH` entries used).
    fn to_array(self) -> [f32; 8];
    /// `self < rhs` per lane.
    fn lt(self, rhs: Self) -> Self::Mask;
    /// `self <= rhs` per lane.
    fn le(self, rhs: Self) -> Self::Mask;
    /// `self != rhs` per lane (true for NaN).
    fn ne(self, rhs: Self) -> Self::Mask;
    /// Lanes that are neither infinite nor NaN.
    fn is_finite(self) -> Self::Mask;
    /// The smaller of two lanes (either one when a lane is NaN).
    fn min(self, rhs: Self) -> Self;
    /// The larger of two lanes (either one when a lane is NaN).
    fn max(self, rhs: Self) -> Self;
    /// `|self|` per lane.
    fn abs(self) -> Self;
    /// `self` with its sign flipped in lanes where `sign` is negative (sign bit set).
    fn xor_sign(self, sign: Self) -> Self;
    /// Whether any lane of `mask` is set.
    fn any(mask: Self::Mask) -> bool;
    /// Lane `i` of `mask` as bit `i`.
    fn bitmask(mask: Self::Mask) -> u32;
}

impl Lanes for f32 {
    type Mask = bool;
    const WIDTH: usize = 1;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        x
    }
    #[inline(always)]
    fn load(values: &[f32]) -> Self {
        values[0]
    }
    #[inline(always)]
    fn load_repeated(values: &[f32; 4]) -> Self {
        values[0]
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 8] {
        [self, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    }
    #[inline(always)]
    fn lt(self, rhs: Self) -> bool {
        self < rhs
    }
    #[inline(always)]
    fn le(self, rhs: Self) -> bool {
        self <= rhs
    }
    #[inline(always)]
    fn ne(self, rhs: Self) -> bool {
        self != rhs
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline(always)]
    fn min(self, rhs: Self) -> Self {
        f32::min(self, rhs)
    }
    #[inline(always)]
    fn max(self, rhs: Self) -> Self {
        f32::max(self, rhs)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn xor_sign(self, sign: Self) -> Self {
        f32::from_bits(self.to_bits() ^ (sign.to_bits() & 0x8000_0000))
    }
    #[inline(always)]
    fn any(mask: bool) -> bool {
        mask
    }
    #[inline(always)]
    fn bitmask(mask: bool) -> u32 {
        mask as u32
    }
}

/// [`Lanes`] for a `wide` vector type of `$width` floats.
macro_rules! wide_lanes {
    ($type:ident, $width:literal) => {
        impl Lanes for $type {
            type Mask = $type;
            const WIDTH: usize = $width;
            #[inline(always)]
            fn splat(x: f32) -> Self {
                $type::splat(x)
            }
            #[inline(always)]
            fn load(values: &[f32]) -> Self {
                $type::new(values[..$width].try_into().expect("one float per lane"))
            }
            #[inline(always)]
            fn load_repeated(values: &[f32; 4]) -> Self {
                $type::new(std::array::from_fn(|i| values[i % 4]))
            }
            #[inline(always)]
            fn to_array(self) -> [f32; 8] {
                let mut out = [0.0; 8];
                out[..$width].copy_from_slice(&$type::to_array(self));
                out
            }
            #[inline(always)]
            fn lt(self, rhs: Self) -> Self {
                self.simd_lt(rhs)
            }
            #[inline(always)]
            fn le(self, rhs: Self) -> Self {
                self.simd_le(rhs)
            }
            #[inline(always)]
            fn ne(self, rhs: Self) -> Self {
                self.simd_ne(rhs)
            }
            #[inline(always)]
            fn is_finite(self) -> Self {
                $type::is_finite(self)
            }
            #[inline(always)]
            fn min(self, rhs: Self) -> Self {
                self.fast_min(rhs)
            }
            #[inline(always)]
            fn max(self, rhs: Self) -> Self {
                self.fast_max(rhs)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                $type::abs(self)
            }
            #[inline(always)]
            fn xor_sign(self, sign: Self) -> Self {
                self ^ (sign & $type::splat(-0.0))
            }
            #[inline(always)]
            fn any(mask: Self) -> bool {
                mask.any()
            }
            #[inline(always)]
            fn bitmask(mask: Self) -> u32 {
                mask.to_bitmask()
            }
        }
    };
}

wide_lanes!(f32x4, 4);
wide_lanes!(f32x8, 8);

/// A 3D vector of lanes: `WIDTH` vectors, structure of arrays.
#[derive(Clone, Copy)]
pub struct V3<L> {
    /// x components.
    pub x: L,
    /// y components.
    pub y: L,
    /// z components.
    pub z: L,
}

impl<L: Lanes> V3<L> {
    /// Every lane `v`.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Self {
        Self {
            x: L::splat(v.x),
            y: L::splat(v.y),
            z: L::splat(v.z),
        }
    }

    /// Lanes from three component arrays, starting at `index`.
    #[inline(always)]
    pub fn load(components: &[Vec<f32>; 3], index: usize) -> Self {
        Self {
            x: L::load(&components[0][index..]),
            y: L::load(&components[1][index..]),
            z: L::load(&components[2][index..]),
        }
    }

    /// Lanes from rows `[x, y, z]` of at least `WIDTH` floats each (a leaf block's
    /// structure-of-arrays layout).
    #[inline(always)]
    pub fn from_rows<const N: usize>(rows: &[[f32; N]; 3]) -> Self {
        Self {
            x: L::load(&rows[0]),
            y: L::load(&rows[1]),
            z: L::load(&rows[2]),
        }
    }

    /// Component `axis` (0, 1, 2).
    #[inline(always)]
    pub fn axis(&self, axis: usize) -> L {
        match axis {
            0 => self.x,
            1 => self.y,
            _ => self.z,
        }
    }

    /// `self × rhs`, in the operation order of glam's `Vec3::cross`.
    #[inline(always)]
    pub fn cross(self, rhs: Self) -> Self {
        Self {
            x: self.y * rhs.z - rhs.y * self.z,
            y: self.z * rhs.x - rhs.z * self.x,
            z: self.x * rhs.y - rhs.x * self.y,
        }
    }

    /// `self · rhs`, in the operation order of glam's `Vec3::dot`.
    #[inline(always)]
    pub fn dot(self, rhs: Self) -> L {
        (self.x * rhs.x) + (self.y * rhs.y) + (self.z * rhs.z)
    }
}

impl<L: Lanes> Add for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn add(self, rhs: Self) -> Self {
        Self {
            x: self.x + rhs.x,
            y: self.y + rhs.y,
            z: self.z + rhs.z,
        }
    }
}

impl<L: Lanes> Sub for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, rhs: Self) -> Self {
        Self {
            x: self.x - rhs.x,
            y: self.y - rhs.y,
            z: self.z - rhs.z,
        }
    }
}

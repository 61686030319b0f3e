//! [`Lanes`] in AVX registers: the 8-wide kernel of the intersectors and packet
//! traversal, compiled into the callers that [`super::dispatch`] runs with AVX.

use super::lanes::Lanes;
use std::arch::x86_64::*;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Sub};

macro_rules! binary {
    ($trait:ident, $method:ident, $intrinsic:ident) => {
        impl $trait for Avx8 {
            type Output = Avx8;
            #[inline(always)]
            fn $method(self, rhs: Avx8) -> Avx8 {
                // SAFETY: `Avx8` values only exist on CPUs with AVX (see its docs).
                Avx8(unsafe { $intrinsic(self.0, rhs.0) })
            }
        }
    };
}
binary!(Add, add, _mm256_add_ps);
binary!(Sub, sub, _mm256_sub_ps);
binary!(Mul, mul, _mm256_mul_ps);
binary!(Div, div, _mm256_div_ps);
binary!(BitAnd, bitand, _mm256_and_ps);
binary!(BitOr, bitor, _mm256_or_ps);

impl Neg for Avx8 {
    type Output = Avx8;
    #[inline(always)]
    fn neg(self) -> Avx8 {
        // SAFETY: as above; flips the sign bit, exactly like scalar negation.
        Avx8(unsafe { _mm256_xor_ps(self.0, _mm256_set1_ps(-0.0)) })
    }
}

impl Lanes for Avx8 {
    type Mask = Avx8;
    const WIDTH: usize = 8;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: as above.
        Avx8(unsafe { _mm256_set1_ps(x) })
    }
    #[inline(always)]
    fn load(values: &[f32]) -> Self {
        assert!(values.len() >= 8);
        // SAFETY: as above; 8 floats are readable.
        Avx8(unsafe { _mm256_loadu_ps(values.as_ptr()) })
    }
    #[inline(always)]
    fn load_repeated(values: &[f32; 4]) -> Self {
        // SAFETY: as above; 4 floats are readable.
        Avx8(unsafe {
            let half = _mm_loadu_ps(values.as_ptr());
            _mm256_set_m128(half, half)
        })
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 8] {
        let mut out = [0.0; 8];
        // SAFETY: as above; `out` holds 8 floats.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) };
        out
    }
    #[inline(always)]
    fn lt(self, rhs: Self) -> Avx8 {
        // SAFETY: as above.
        Avx8(unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, rhs.0) })
    }
    #[inline(always)]
    fn le(self, rhs: Self) -> Avx8 {
        // SAFETY: as above.
        Avx8(unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, rhs.0) })
    }
    #[inline(always)]
    fn ne(self, rhs: Self) -> Avx8 {
        // SAFETY: as above.
        Avx8(unsafe { _mm256_cmp_ps::<_CMP_NEQ_UQ>(self.0, rhs.0) })
    }
    #[inline(always)]
    fn is_finite(self) -> Avx8 {
        // SAFETY: as above. |x| < ∞ is false for ±∞ and NaN.
        Avx8(unsafe {
            let magnitude = _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0);
            _mm256_cmp_ps::<_CMP_LT_OQ>(magnitude, _mm256_set1_ps(f32::INFINITY))
        })
    }
    #[inline(always)]
    fn min(self, rhs: Self) -> Self {
        // SAFETY: as above.
        Avx8(unsafe { _mm256_min_ps(self.0, rhs.0) })
    }
    #[inline(always)]
    fn max(self, rhs: Self) -> Self {
        // SAFETY: as above.
        Avx8(unsafe { _mm256_max_ps(self.0, rhs.0) })
    }
    #[inline(always)]
    fn abs(self) -> Self {
        // SAFETY: as above.
        Avx8(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0) })
    }
    #[inline(always)]
    fn xor_sign(self, sign: Self) -> Self {
        // SAFETY: as above.
        Avx8(unsafe { _mm256_xor_ps(self.0, _mm256_and_ps(sign.0, _mm256_set1_ps(-0.0))) })
    }
    #[inline(always)]
    fn any(mask: Avx8) -> bool {
        // SAFETY: as above.
        unsafe { _mm256_movemask_ps(mask.0) != 0 }
    }
    #[inline(always)]
    fn bitmask(mask: Avx8) -> u32 {
        // SAFETY: as above.
        unsafe { _mm256_movemask_ps(mask.0) as u32 }
    }
}

/// Eight floats in one AVX register. Every method runs AVX instructions, so values of
/// this type must only be made inside functions compiled with
/// `#[target_feature(enable = "avx")]` that are called after detecting AVX; it is private
/// to the crate for that reason.
#[derive(Clone, Copy)]
pub(crate) struct Avx8(std::arch::x86_64::__m256);

//! The node test in AVX registers: [`super::portable_children`]'s operations in single
//! 256-bit instructions, the same results bit for bit.

use super::{RayQuery, WIDTH};

/// The node test with AVX: the same operations as [`super::portable_children`] in single
/// 256-bit instructions.
///
/// No `#[target_feature]` of its own, so that it inlines into its AVX-compiled callers
/// (a function with the attribute cannot be inlined into `children`, which has none,
/// and stayed an out-of-line call per node visit); the intrinsics inline there.
///
/// # Safety
/// Only call it from code compiled with AVX, on a CPU that has it.
#[inline(always)]
pub(super) unsafe fn avx_children(
    p: &[[f32; WIDTH]; 6],
    ray: &RayQuery,
    t_max: f32,
) -> ([f32; WIDTH], u32) {
    use std::arch::x86_64::*;
    let ([nx, ny, nz], [fx, fy, fz]) = (ray.near_plane, ray.far_plane);
    let o = ray.origin;
    let (i, f) = (ray.inverse_direction, ray.inverse_direction_far);
    let slab = |plane: usize, origin: f32, inverse: f32| {
        // SAFETY: `p[plane]` is 8 floats.
        let planes = unsafe { _mm256_loadu_ps(p[plane].as_ptr()) };
        _mm256_mul_ps(
            _mm256_sub_ps(planes, _mm256_set1_ps(origin)),
            _mm256_set1_ps(inverse),
        )
    };
    let near = _mm256_max_ps(
        _mm256_max_ps(slab(nx, o.x, i.x), slab(ny, o.y, i.y)),
        _mm256_max_ps(slab(nz, o.z, i.z), _mm256_set1_ps(ray.t_min)),
    );
    let far = _mm256_min_ps(
        _mm256_min_ps(slab(fx, o.x, f.x), slab(fy, o.y, f.y)),
        _mm256_min_ps(slab(fz, o.z, f.z), _mm256_set1_ps(t_max)),
    );
    let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32;
    let mut distances = [0.0f32; WIDTH];
    // SAFETY: `distances` is 8 floats.
    unsafe { _mm256_storeu_ps(distances.as_mut_ptr(), near) };
    (distances, mask)
}

//! SIMD on stable Rust: the CPU's features, detected here and nowhere else; the lanes
//! that the intersectors and packet traversal are written over; and the one dispatch
//! from the CPU to code compiled for its features.
//!
//! A kernel is written once, generic over an instruction set `Isa`: `Portable`
//! (any CPU) or, on x86-64, `Avx`. `dispatch` runs it with `Avx` inside a function
//! compiled with `#[target_feature(enable = "avx")]` when the CPU has AVX, so that the
//! kernel's `#[inline(always)]` callees are compiled with AVX too; the only `unsafe` is
//! that call and the intrinsics' loads and stores. Pairing's AVX-512 kernels take
//! [`has_avx512`] as a flag and sit in `avx512.rs` files beside the scalar code
//! they mirror (`pair/suitor/`, `pair/greedy/`, `pair/compressed/`).

#[cfg(target_arch = "x86_64")]
mod avx;
pub mod lanes;

#[cfg(target_arch = "x86_64")]
pub(crate) use avx::Avx8;
pub use lanes::{Lanes, V3};

/// Whether this CPU has AVX (detected once, then a cached flag).
#[inline(always)]
pub fn has_avx() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether this CPU has AVX-512 F, and POPCNT and BMI2 (as every such CPU does), for
/// pairing's AVX-512 kernels (detected once, then a cached flag).
pub fn has_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("popcnt")
            && std::arch::is_x86_feature_detected!("bmi2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// An instruction set that kernels are compiled for.
///
/// # Safety
/// A set with `AVX` may run AVX instructions: code generic over it must only run with
/// it inside [`dispatch`], which checks the CPU first.
pub(crate) unsafe trait Isa: Copy + 'static {
    /// Whether code for this set runs AVX instructions.
    const AVX: bool;
    /// Eight floats, as this set computes them.
    type Lanes8: Lanes;
}

/// Any CPU: `wide`'s portable lanes (SSE or NEON halves, or scalar emulation).
#[derive(Clone, Copy)]
pub(crate) struct Portable;

// SAFETY: runs no AVX instruction unless the whole program is compiled for AVX.
unsafe impl Isa for Portable {
    const AVX: bool = false;
    type Lanes8 = wide::f32x8;
}

/// x86-64 with AVX: 256-bit registers.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct Avx;

// SAFETY: only `dispatch` runs kernels with `Avx`, after detecting AVX.
#[cfg(target_arch = "x86_64")]
unsafe impl Isa for Avx {
    const AVX: bool = true;
    type Lanes8 = Avx8;
}

/// Code to run with the best instruction set of this CPU. `run` must be
/// `#[inline(always)]`, so that its body is compiled with that set's features.
pub(crate) trait Kernel {
    /// What the kernel returns.
    type Output;
    /// The kernel, compiled for `S`.
    fn run<S: Isa>(self) -> Self::Output;
}

/// Run `kernel` with [`Avx`] where the CPU has AVX, else with [`Portable`].
#[inline(always)]
pub(crate) fn dispatch<K: Kernel>(kernel: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    if has_avx() {
        // SAFETY: the CPU has AVX.
        return unsafe { run_avx(kernel) };
    }
    kernel.run::<Portable>()
}

/// `kernel` compiled with AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn run_avx<K: Kernel>(kernel: K) -> K::Output {
    kernel.run::<Avx>()
}

//! Hot loops compiled for the best instruction set of the CPU they run on.
//!
//! The crate is built for the baseline x86-64 (SSE2, no FMA) so that the binary runs anywhere; a
//! [`Kernel`] run through [`avx2`] is compiled a second time for AVX2 + FMA and the version the CPU
//! supports is chosen at run time by [`pulp`]; loops dispatched by `pulp::Arch` directly get AVX-512
//! where the CPU has it. Only code inlined into the kernel gets the wider instructions, so
//! [`Kernel::run`] and the functions it calls are marked `#[inline(always)]` (a closure would not be
//! inlined into the dispatched function). Results are unchanged: Rust never fuses or reorders
//! floating-point operations on its own.

/// A hot loop with its arguments.
pub trait Kernel {
    /// What the loop returns.
    type Output;
    /// Run the loop (mark the implementation `#[inline(always)]`).
    fn run(self) -> Self::Output;
}

/// Run `kernel` compiled for AVX2 + FMA where the CPU has them, else for the baseline. Not for
/// AVX-512 even where the CPU has it: these kernels work on [`super::padded::Padded`] 3-vectors in
/// four lanes, which gain nothing from wider registers: the creature's reconstruction solve measured
/// 7% slower compiled for AVX-512 (0.83 against 0.78 ms), and since its gathers lost their bounds
/// checks the same on both (0.52 ms).
pub fn avx2<K: Kernel>(kernel: K) -> K::Output {
    struct Run<K>(K);
    impl<K: Kernel> pulp::WithSimd for Run<K> {
        type Output = K::Output;
        #[inline(always)]
        fn with_simd<S: pulp::Simd>(self, _: S) -> K::Output {
            self.0.run()
        }
    }
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = pulp::x86::V3::try_new() {
        return pulp::Simd::vectorize(simd, Run(kernel));
    }
    pulp::Arch::new().dispatch(Run(kernel))
}

/// A hot loop written in AVX2 + FMA instructions (a [`pulp::x86::V3`]), with its arguments.
#[cfg(target_arch = "x86_64")]
pub trait Eight {
    /// What the loop returns.
    type Output;
    /// Run the loop with these instructions (mark the implementation `#[inline(always)]`).
    fn run(self, simd: pulp::x86::V3) -> Self::Output;
}

/// Run `kernel` where the CPU has AVX2 + FMA (else give it back), compiled with AVX-512 enabled
/// where the CPU has that too: the same instructions, but 32 vector registers instead of 16 to keep
/// a kernel's lanes in, so the compiler spills far fewer of them (the position-based sweeps measured
/// 2–5% faster).
#[cfg(target_arch = "x86_64")]
pub fn eight<K: Eight>(kernel: K) -> Result<K::Output, K> {
    struct Run<K>(K, pulp::x86::V3);
    impl<K: Eight> pulp::WithSimd for Run<K> {
        type Output = K::Output;
        #[inline(always)]
        fn with_simd<S: pulp::Simd>(self, _: S) -> K::Output {
            self.0.run(self.1)
        }
    }
    if let Some(wide) = pulp::x86::V4::try_new() {
        return Ok(pulp::Simd::vectorize(wide, Run(kernel, *wide)));
    }
    match pulp::x86::V3::try_new() {
        Some(simd) => Ok(pulp::Simd::vectorize(simd, Run(kernel, simd))),
        None => Err(kernel),
    }
}

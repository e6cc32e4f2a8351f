//! Hot loops compiled for the best instruction set of the CPU they run on.
//!
//! The crate is built for the baseline x86-64 (SSE2, no FMA) so that the binary runs anywhere; a
//! [`Kernel`] run through [`best`] is compiled a second time for AVX2 + FMA (or AVX-512) and the
//! version the CPU supports is chosen at run time by [`pulp`]. Only code inlined into the kernel gets
//! the wider instructions, so [`Kernel::run`] and the functions it calls are marked
//! `#[inline(always)]` (a closure would not be inlined into the dispatched function). Results are
//! unchanged: Rust never fuses or reorders floating-point operations on its own.

/// A hot loop with its arguments.
pub trait Kernel {
    /// What the loop returns.
    type Output;
    /// Run the loop (mark the implementation `#[inline(always)]`).
    fn run(self) -> Self::Output;
}

/// Run `kernel`, compiled for the best instruction set this CPU has.
pub fn best<K: Kernel>(kernel: K) -> K::Output {
    struct Run<K>(K);
    impl<K: Kernel> pulp::WithSimd for Run<K> {
        type Output = K::Output;
        #[inline(always)]
        fn with_simd<S: pulp::Simd>(self, _: S) -> K::Output {
            self.0.run()
        }
    }
    pulp::Arch::new().dispatch(Run(kernel))
}

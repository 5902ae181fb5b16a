//! `F4`: four f32 lanes in the target's baseline 128-bit vector register, for the portable
//! tiles ([`super`]): SSE2 on x86-64 (part of the base instruction set),
//! SIMD128 on WebAssembly built with `+simd128`, NEON on aarch64, and a plain array anywhere
//! else. No runtime feature detection: every operation is one the target always has.
//!
//! Left to itself the compiler's auto-vectorizer turns the kernels' 4 x 2 tiles of lane-wise
//! multiply-adds into shuffles across weight rows (measured: no faster than the scalar loop);
//! spelling the vectors out keeps one vector operation per line of the kernel.

#[cfg(target_arch = "x86_64")]
mod imp {
    use std::arch::x86_64::*;

    /// Four f32 lanes in an SSE register.
    #[derive(Clone, Copy)]
    pub(crate) struct F4(__m128);

    impl F4 {
        #[inline(always)]
        pub(crate) fn zero() -> Self {
            // SAFETY: SSE2 is part of x86-64.
            Self(unsafe { _mm_setzero_ps() })
        }
        /// Loads `p[0..4]` (any alignment).
        ///
        /// # Safety
        /// `p[0..4]` must be readable.
        #[inline(always)]
        pub(crate) unsafe fn load(p: *const f32) -> Self {
            // SAFETY: the caller's contract; SSE2 is part of x86-64.
            Self(unsafe { _mm_loadu_ps(p) })
        }
        #[inline(always)]
        pub(crate) fn add(self, o: Self) -> Self {
            // SAFETY: SSE2 is part of x86-64.
            Self(unsafe { _mm_add_ps(self.0, o.0) })
        }
        #[inline(always)]
        pub(crate) fn mul(self, o: Self) -> Self {
            // SAFETY: SSE2 is part of x86-64.
            Self(unsafe { _mm_mul_ps(self.0, o.0) })
        }
        #[inline(always)]
        pub(crate) fn array(self) -> [f32; 4] {
            // SAFETY: `__m128` and `[f32; 4]` have the same size and any bits are valid f32s.
            unsafe { std::mem::transmute::<__m128, [f32; 4]>(self.0) }
        }
    }
}

#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
mod imp {
    use std::arch::wasm32::*;

    /// Four f32 lanes in a WebAssembly `v128`.
    #[derive(Clone, Copy)]
    pub(crate) struct F4(v128);

    impl F4 {
        #[inline(always)]
        pub(crate) fn zero() -> Self {
            Self(f32x4_splat(0.0))
        }
        /// Loads `p[0..4]` (any alignment).
        ///
        /// # Safety
        /// `p[0..4]` must be readable.
        #[inline(always)]
        pub(crate) unsafe fn load(p: *const f32) -> Self {
            // SAFETY: the caller's contract (`v128_load` allows any alignment).
            Self(unsafe { v128_load(p.cast()) })
        }
        #[inline(always)]
        pub(crate) fn add(self, o: Self) -> Self {
            Self(f32x4_add(self.0, o.0))
        }
        #[inline(always)]
        pub(crate) fn mul(self, o: Self) -> Self {
            Self(f32x4_mul(self.0, o.0))
        }
        #[inline(always)]
        pub(crate) fn array(self) -> [f32; 4] {
            [
                f32x4_extract_lane::<0>(self.0),
                f32x4_extract_lane::<1>(self.0),
                f32x4_extract_lane::<2>(self.0),
                f32x4_extract_lane::<3>(self.0),
            ]
        }
    }
}

#[cfg(target_arch = "aarch64")]
mod imp {
    use std::arch::aarch64::*;

    /// Four f32 lanes in a NEON register.
    #[derive(Clone, Copy)]
    pub(crate) struct F4(float32x4_t);

    impl F4 {
        #[inline(always)]
        pub(crate) fn zero() -> Self {
            // SAFETY: NEON is part of aarch64.
            Self(unsafe { vdupq_n_f32(0.0) })
        }
        /// Loads `p[0..4]` (any alignment).
        ///
        /// # Safety
        /// `p[0..4]` must be readable.
        #[inline(always)]
        pub(crate) unsafe fn load(p: *const f32) -> Self {
            // SAFETY: the caller's contract; NEON is part of aarch64.
            Self(unsafe { vld1q_f32(p) })
        }
        #[inline(always)]
        pub(crate) fn add(self, o: Self) -> Self {
            // SAFETY: NEON is part of aarch64.
            Self(unsafe { vaddq_f32(self.0, o.0) })
        }
        #[inline(always)]
        pub(crate) fn mul(self, o: Self) -> Self {
            // SAFETY: NEON is part of aarch64.
            Self(unsafe { vmulq_f32(self.0, o.0) })
        }
        #[inline(always)]
        pub(crate) fn array(self) -> [f32; 4] {
            let mut a = [0.0f32; 4];
            // SAFETY: `a` holds four f32s.
            unsafe { vst1q_f32(a.as_mut_ptr(), self.0) };
            a
        }
    }
}

#[cfg(not(any(
    target_arch = "x86_64",
    target_arch = "aarch64",
    all(target_arch = "wasm32", target_feature = "simd128")
)))]
mod imp {
    /// Four f32 lanes as a plain array (targets without a baseline 128-bit vector unit).
    #[derive(Clone, Copy)]
    pub(crate) struct F4([f32; 4]);

    impl F4 {
        #[inline(always)]
        pub(crate) fn zero() -> Self {
            Self([0.0; 4])
        }
        /// Loads `p[0..4]` (any alignment).
        ///
        /// # Safety
        /// `p[0..4]` must be readable.
        #[inline(always)]
        pub(crate) unsafe fn load(p: *const f32) -> Self {
            // SAFETY: the caller's contract.
            Self(unsafe { std::ptr::read_unaligned(p.cast::<[f32; 4]>()) })
        }
        #[inline(always)]
        pub(crate) fn add(self, o: Self) -> Self {
            Self(std::array::from_fn(|l| self.0[l] + o.0[l]))
        }
        #[inline(always)]
        pub(crate) fn mul(self, o: Self) -> Self {
            Self(std::array::from_fn(|l| self.0[l] * o.0[l]))
        }
        #[inline(always)]
        pub(crate) fn array(self) -> [f32; 4] {
            self.0
        }
    }
}

pub(crate) use imp::F4;

/// Asks for the cache line holding `p` in L1 (a hint: never faults, any address). SSE's
/// `prefetcht0` on x86-64; nothing elsewhere (stable Rust has no prefetch for the other targets).
#[inline(always)]
pub(crate) fn prefetch(p: *const f32) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE is part of x86-64; a prefetch reads nothing and may name any address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast())
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

//! Lanes of f32 that the fused step (`fused.rs`) computes with, one mass per lane: AVX (8 lanes),
//! SSE2 (4), a portable array (4) for other targets, and plain `f32` (1) for masses that share
//! no stencil with their neighbours. Every operation is one IEEE-754 operation per lane (no fused
//! multiply-add, no approximate reciprocal), so each lane computes exactly what the scalar code
//! and the WGSL compute for its mass, whatever the width.

use std::ops::{Add, Mul, Neg, Sub};

/// A vector of `WIDTH` f32 lanes. The operators act lane by lane.
pub(super) trait Lanes:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    const WIDTH: usize;
    /// One boolean per lane.
    type Mask: Copy;
    fn splat(v: f32) -> Self;
    /// `s[at..at + WIDTH]`.
    fn load(s: &[f32], at: usize) -> Self;
    /// Into `s[at..at + WIDTH]`.
    fn store(self, s: &mut [f32], at: usize);
    fn div(self, o: Self) -> Self;
    fn sqrt(self) -> Self;
    /// `self <= o`, false where either is NaN.
    fn le(self, o: Self) -> Self::Mask;
    /// `self == o`, false where either is NaN.
    fn eq(self, o: Self) -> Self::Mask;
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    fn no(m: Self::Mask) -> bool;
    fn all(m: Self::Mask) -> bool;
    /// `m ? a : b`, lane by lane.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
}

/// Width 1: the masses outside any stencil run, with the same code as the lanes.
impl Lanes for f32 {
    const WIDTH: usize = 1;
    type Mask = bool;
    #[inline(always)]
    fn splat(v: f32) -> Self {
        v
    }
    #[inline(always)]
    fn load(s: &[f32], at: usize) -> Self {
        s[at]
    }
    #[inline(always)]
    fn store(self, s: &mut [f32], at: usize) {
        s[at] = self;
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        self / o
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn le(self, o: Self) -> bool {
        self <= o
    }
    #[inline(always)]
    fn eq(self, o: Self) -> bool {
        self == o
    }
    #[inline(always)]
    fn and(a: bool, b: bool) -> bool {
        a && b
    }
    #[inline(always)]
    fn no(m: bool) -> bool {
        !m
    }
    #[inline(always)]
    fn all(m: bool) -> bool {
        m
    }
    #[inline(always)]
    fn select(m: bool, a: Self, b: Self) -> Self {
        if m { a } else { b }
    }
}

/// Four lanes in a plain array, for targets without the x86 kernels; the compiler vectorises
/// what it can.
#[derive(Clone, Copy)]
pub(super) struct Portable([f32; 4]);

macro_rules! portable_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for Portable {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: Self) -> Self {
                Portable(std::array::from_fn(|k| self.0[k] $op o.0[k]))
            }
        }
    };
}
portable_op!(Add, add, +);
portable_op!(Sub, sub, -);
portable_op!(Mul, mul, *);

impl Neg for Portable {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Portable(self.0.map(|a| -a))
    }
}

impl Lanes for Portable {
    const WIDTH: usize = 4;
    type Mask = [bool; 4];
    #[inline(always)]
    fn splat(v: f32) -> Self {
        Portable([v; 4])
    }
    #[inline(always)]
    fn load(s: &[f32], at: usize) -> Self {
        let mut a = [0.0; 4];
        a.copy_from_slice(&s[at..at + 4]);
        Portable(a)
    }
    #[inline(always)]
    fn store(self, s: &mut [f32], at: usize) {
        s[at..at + 4].copy_from_slice(&self.0);
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        Portable(std::array::from_fn(|k| self.0[k] / o.0[k]))
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Portable(self.0.map(f32::sqrt))
    }
    #[inline(always)]
    fn le(self, o: Self) -> [bool; 4] {
        std::array::from_fn(|k| self.0[k] <= o.0[k])
    }
    #[inline(always)]
    fn eq(self, o: Self) -> [bool; 4] {
        std::array::from_fn(|k| self.0[k] == o.0[k])
    }
    #[inline(always)]
    fn and(a: [bool; 4], b: [bool; 4]) -> [bool; 4] {
        std::array::from_fn(|k| a[k] && b[k])
    }
    #[inline(always)]
    fn no(m: [bool; 4]) -> bool {
        !m.iter().any(|&b| b)
    }
    #[inline(always)]
    fn all(m: [bool; 4]) -> bool {
        m.iter().all(|&b| b)
    }
    #[inline(always)]
    fn select(m: [bool; 4], a: Self, b: Self) -> Self {
        Portable(std::array::from_fn(|k| if m[k] { a.0[k] } else { b.0[k] }))
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use x86::{Avx, Sse2};

/// The x86-64 lanes. SSE2 is part of x86-64 itself. AVX is not: a value of [`Avx`] is only made
/// inside a function compiled with `#[target_feature(enable = "avx2")]` that `fused.rs` calls
/// after `is_x86_feature_detected!("avx2")`, which is what makes its intrinsics sound to call.
#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::Lanes;
    use std::arch::x86_64::*;
    use std::ops::{Add, Mul, Neg, Sub};

    #[derive(Clone, Copy)]
    pub(in crate::cpu) struct Sse2(__m128);

    #[derive(Clone, Copy)]
    pub(in crate::cpu) struct Avx(__m256);

    macro_rules! x86_op {
        ($ty:ident, $tr:ident, $f:ident, $intr:ident) => {
            impl $tr for $ty {
                type Output = Self;
                #[inline(always)]
                fn $f(self, o: Self) -> Self {
                    // SAFETY: see the module's comment (SSE2 is always there; Avx only on AVX2).
                    $ty(unsafe { $intr(self.0, o.0) })
                }
            }
        };
    }
    x86_op!(Sse2, Add, add, _mm_add_ps);
    x86_op!(Sse2, Sub, sub, _mm_sub_ps);
    x86_op!(Sse2, Mul, mul, _mm_mul_ps);
    x86_op!(Avx, Add, add, _mm256_add_ps);
    x86_op!(Avx, Sub, sub, _mm256_sub_ps);
    x86_op!(Avx, Mul, mul, _mm256_mul_ps);

    // Negation flips the sign bit, as `-x` does for f32 (zeros and NaNs included).
    impl Neg for Sse2 {
        type Output = Self;
        #[inline(always)]
        fn neg(self) -> Self {
            // SAFETY: see the module's comment.
            Sse2(unsafe { _mm_xor_ps(self.0, _mm_set1_ps(-0.0)) })
        }
    }

    impl Neg for Avx {
        type Output = Self;
        #[inline(always)]
        fn neg(self) -> Self {
            // SAFETY: see the module's comment.
            Avx(unsafe { _mm256_xor_ps(self.0, _mm256_set1_ps(-0.0)) })
        }
    }

    // SAFETY (every `unsafe` block below): the module's comment; loads and stores go through a
    // bounds-checked slice of exactly WIDTH elements.
    impl Lanes for Sse2 {
        const WIDTH: usize = 4;
        type Mask = __m128;
        #[inline(always)]
        fn splat(v: f32) -> Self {
            Sse2(unsafe { _mm_set1_ps(v) })
        }
        #[inline(always)]
        fn load(s: &[f32], at: usize) -> Self {
            let s = &s[at..at + 4];
            Sse2(unsafe { _mm_loadu_ps(s.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, s: &mut [f32], at: usize) {
            let s = &mut s[at..at + 4];
            unsafe { _mm_storeu_ps(s.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            Sse2(unsafe { _mm_div_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            Sse2(unsafe { _mm_sqrt_ps(self.0) })
        }
        #[inline(always)]
        fn le(self, o: Self) -> __m128 {
            unsafe { _mm_cmple_ps(self.0, o.0) }
        }
        #[inline(always)]
        fn eq(self, o: Self) -> __m128 {
            unsafe { _mm_cmpeq_ps(self.0, o.0) }
        }
        #[inline(always)]
        fn and(a: __m128, b: __m128) -> __m128 {
            unsafe { _mm_and_ps(a, b) }
        }
        #[inline(always)]
        fn no(m: __m128) -> bool {
            unsafe { _mm_movemask_ps(m) == 0 }
        }
        #[inline(always)]
        fn all(m: __m128) -> bool {
            unsafe { _mm_movemask_ps(m) == 0xf }
        }
        #[inline(always)]
        fn select(m: __m128, a: Self, b: Self) -> Self {
            // SSE2 has no blend: (m & a) | (!m & b).
            Sse2(unsafe { _mm_or_ps(_mm_and_ps(m, a.0), _mm_andnot_ps(m, b.0)) })
        }
    }

    impl Lanes for Avx {
        const WIDTH: usize = 8;
        type Mask = __m256;
        #[inline(always)]
        fn splat(v: f32) -> Self {
            Avx(unsafe { _mm256_set1_ps(v) })
        }
        #[inline(always)]
        fn load(s: &[f32], at: usize) -> Self {
            let s = &s[at..at + 8];
            Avx(unsafe { _mm256_loadu_ps(s.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, s: &mut [f32], at: usize) {
            let s = &mut s[at..at + 8];
            unsafe { _mm256_storeu_ps(s.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            Avx(unsafe { _mm256_div_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            Avx(unsafe { _mm256_sqrt_ps(self.0) })
        }
        #[inline(always)]
        fn le(self, o: Self) -> __m256 {
            unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn eq(self, o: Self) -> __m256 {
            unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn and(a: __m256, b: __m256) -> __m256 {
            unsafe { _mm256_and_ps(a, b) }
        }
        #[inline(always)]
        fn no(m: __m256) -> bool {
            unsafe { _mm256_movemask_ps(m) == 0 }
        }
        #[inline(always)]
        fn all(m: __m256) -> bool {
            unsafe { _mm256_movemask_ps(m) == 0xff }
        }
        #[inline(always)]
        fn select(m: __m256, a: Self, b: Self) -> Self {
            Avx(unsafe { _mm256_blendv_ps(b.0, a.0, m) })
        }
    }
}

//! The float types the physics is written in, once for both: the backends step in f32 (`f32`,
//! `Vec3`), the accuracy benchmark's reference solution in f64 (`f64`, `DVec3`). A formula
//! generic over [`Real`] is the same sequence of operations in either precision, the f32 one
//! matching the WGSL's. At the bottom of the layers, so that the model's geometry
//! (`model::Shape::penetration`) and the backends' force laws (`cpu::law`) can both use it.

use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub, SubAssign};

use glam::{DVec3, Vec3};

/// A float type and its 3-vector.
pub trait Real:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
{
    type V: Copy
        + PartialEq
        + Add<Output = Self::V>
        + Sub<Output = Self::V>
        + Mul<Self, Output = Self::V>
        + Div<Self, Output = Self::V>
        + AddAssign
        + SubAssign;
    const ZERO: Self;
    const ONE: Self;
    const V_ZERO: Self::V;
    /// Springs shorter than this have no direction and exert nothing.
    const MIN_SPRING_LENGTH: Self;
    fn of(x: f32) -> Self;
    fn sqrt(self) -> Self;
    fn max(self, other: Self) -> Self;
    fn min(self, other: Self) -> Self;
    fn dot(a: Self::V, b: Self::V) -> Self;
    fn length(v: Self::V) -> Self;
    fn abs(v: Self::V) -> Self::V;
    fn components(v: Self::V) -> [Self; 3];
    fn of_components(c: [Self; 3]) -> Self::V;
    /// A model's vector (always f32) in this precision.
    fn of_vec(v: Vec3) -> Self::V;
}

/// `Real` for a float type and its glam vector: the same calls on either, an f32 value or `Vec3`
/// widened losslessly (`From`; for f32 the identity).
macro_rules! real {
    ($(#[$doc:meta])* $t:ident, $v:ident) => {
        $(#[$doc])*
        impl Real for $t {
            type V = $v;
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const V_ZERO: $v = $v::ZERO;
            const MIN_SPRING_LENGTH: Self = f32::MIN_POSITIVE as $t * 1e6;
            #[inline(always)]
            fn of(x: f32) -> Self {
                <$t>::from(x)
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn max(self, other: Self) -> Self {
                <$t>::max(self, other)
            }
            #[inline(always)]
            fn min(self, other: Self) -> Self {
                <$t>::min(self, other)
            }
            #[inline(always)]
            fn dot(a: $v, b: $v) -> Self {
                a.dot(b)
            }
            #[inline(always)]
            fn length(v: $v) -> Self {
                v.length()
            }
            #[inline(always)]
            fn abs(v: $v) -> $v {
                v.abs()
            }
            #[inline(always)]
            fn components(v: $v) -> [Self; 3] {
                v.to_array()
            }
            #[inline(always)]
            fn of_components(c: [Self; 3]) -> $v {
                <$v>::from_array(c)
            }
            #[inline(always)]
            fn of_vec(v: Vec3) -> $v {
                <$v>::from(v)
            }
        }
    };
}

real!(
    /// The backends' precision. `MIN_SPRING_LENGTH` is `MIN_SPRING_LENGTH` in
    /// shaders/common.wgsl.
    f32,
    Vec3
);
real!(
    /// The reference solution's precision.
    f64,
    DVec3
);

/// A 3-vector and its float type: lets a function generic over the precision take plain vectors
/// (`Vec3` or `DVec3`) and still know its [`Real`].
pub trait Vector: Copy {
    type Real: Real<V = Self>;
}

impl Vector for Vec3 {
    type Real = f32;
}

impl Vector for DVec3 {
    type Real = f64;
}

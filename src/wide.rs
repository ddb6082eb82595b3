//! Sixteen `f32` lanes ([`F16`]), their masks ([`M16`]) and 3-vectors of them ([`V16`]):
//! the arithmetic of code that shades sixteen path vertices at once (the batched walker's
//! Lambertian vertices, [`crate::integrator::diffuse_lanes`]).
//!
//! Every operation is the scalar one lane by lane, written as a loop over the sixteen lanes
//! that LLVM turns into vector instructions (one AVX-512 instruction, or two AVX2 ones, in
//! the functions compiled for those targets by `multiversion`; four SSE2 ones otherwise).
//! IEEE arithmetic is exact per lane and Rust neither fuses nor reorders, so a lane computes
//! bit for bit what scalar code with the same operations in the same order computes. The
//! two maxima are kept apart for that reason: [`F16::max_glam`] is glam's `a > b ? a : b`
//! (its `Vec3::max`, `max_element`), [`F16::max`] is `f32::max` (the other operand where
//! one is NaN). Where scalar code returns early, a lane computes on and a mask drops its
//! result.

// Index loops over the lanes, the plainest form for the vectoriser.
#![allow(clippy::needless_range_loop)]

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

/// The number of lanes.
pub const W: usize = 16;

/// Sixteen `f32` lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct F16(pub [f32; W]);

/// A mask of sixteen lanes: all bits set where true.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C, align(64))]
pub struct M16(pub [u32; W]);

#[inline(always)]
fn map(a: F16, f: impl Fn(f32) -> f32) -> F16 {
    let mut r = [0.0; W];
    for i in 0..W {
        r[i] = f(a.0[i]);
    }
    F16(r)
}

#[inline(always)]
fn zip(a: F16, b: F16, f: impl Fn(f32, f32) -> f32) -> F16 {
    let mut r = [0.0; W];
    for i in 0..W {
        r[i] = f(a.0[i], b.0[i]);
    }
    F16(r)
}

#[inline(always)]
fn test(a: F16, b: F16, f: impl Fn(f32, f32) -> bool) -> M16 {
    let mut r = [0; W];
    for i in 0..W {
        r[i] = if f(a.0[i], b.0[i]) { u32::MAX } else { 0 };
    }
    M16(r)
}

impl F16 {
    pub const ZERO: F16 = F16([0.0; W]);

    #[inline(always)]
    pub fn splat(x: f32) -> F16 {
        F16([x; W])
    }

    #[inline(always)]
    pub fn sqrt(self) -> F16 {
        map(self, f32::sqrt)
    }

    #[inline(always)]
    pub fn abs(self) -> F16 {
        map(self, f32::abs)
    }

    /// `f32::max`: the other operand where one is NaN.
    #[inline(always)]
    pub fn max(self, o: F16) -> F16 {
        zip(self, o, f32::max)
    }

    /// glam's maximum, `self > o ? self : o`.
    #[inline(always)]
    pub fn max_glam(self, o: F16) -> F16 {
        zip(self, o, |a, b| if a > b { a } else { b })
    }

    #[inline(always)]
    pub fn gt(self, o: F16) -> M16 {
        test(self, o, |a, b| a > b)
    }

    #[inline(always)]
    pub fn ge(self, o: F16) -> M16 {
        test(self, o, |a, b| a >= b)
    }

    #[inline(always)]
    pub fn eq(self, o: F16) -> M16 {
        test(self, o, |a, b| a == b)
    }

    #[inline(always)]
    pub fn is_finite(self) -> M16 {
        test(self, self, |a, _| a.is_finite())
    }

    #[inline(always)]
    pub fn is_infinite(self) -> M16 {
        test(self, self, |a, _| a.is_infinite())
    }
}

macro_rules! binary {
    ($trait:ident, $f:ident) => {
        impl $trait for F16 {
            type Output = F16;
            #[inline(always)]
            fn $f(self, o: F16) -> F16 {
                zip(self, o, |a, b| a.$f(b))
            }
        }
        impl $trait<f32> for F16 {
            type Output = F16;
            #[inline(always)]
            fn $f(self, o: f32) -> F16 {
                zip(self, F16::splat(o), |a, b| a.$f(b))
            }
        }
        impl $trait<F16> for f32 {
            type Output = F16;
            #[inline(always)]
            fn $f(self, o: F16) -> F16 {
                zip(F16::splat(self), o, |a, b| a.$f(b))
            }
        }
    };
}
binary!(Add, add);
binary!(Sub, sub);
binary!(Mul, mul);
binary!(Div, div);

impl Neg for F16 {
    type Output = F16;
    #[inline(always)]
    fn neg(self) -> F16 {
        map(self, |a| -a)
    }
}

impl M16 {
    pub const NONE: M16 = M16([0; W]);

    /// `a` in the lanes of the mask, `b` in the others.
    #[inline(always)]
    pub fn select(self, a: F16, b: F16) -> F16 {
        let mut r = [0.0; W];
        for i in 0..W {
            r[i] = f32::from_bits((a.0[i].to_bits() & self.0[i]) | (b.0[i].to_bits() & !self.0[i]));
        }
        F16(r)
    }

    /// [`M16::select`] of each coordinate.
    #[inline(always)]
    pub fn select3(self, a: V16, b: V16) -> V16 {
        V16 { x: self.select(a.x, b.x), y: self.select(a.y, b.y), z: self.select(a.z, b.z) }
    }

    #[inline(always)]
    pub fn lane(&self, i: usize) -> bool {
        self.0[i] != 0
    }
}

macro_rules! mask_op {
    ($trait:ident, $f:ident, $op:tt) => {
        impl $trait for M16 {
            type Output = M16;
            #[inline(always)]
            fn $f(self, o: M16) -> M16 {
                let mut r = [0; W];
                for i in 0..W {
                    r[i] = self.0[i] $op o.0[i];
                }
                M16(r)
            }
        }
    };
}
mask_op!(BitAnd, bitand, &);
mask_op!(BitOr, bitor, |);

impl Not for M16 {
    type Output = M16;
    #[inline(always)]
    fn not(self) -> M16 {
        let mut r = [0; W];
        for i in 0..W {
            r[i] = !self.0[i];
        }
        M16(r)
    }
}

/// Sixteen 3-vectors, a coordinate per [`F16`]; the operations are glam's `Vec3` ones, in
/// their order of operations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V16 {
    pub x: F16,
    pub y: F16,
    pub z: F16,
}

impl V16 {
    pub const ZERO: V16 = V16 { x: F16::ZERO, y: F16::ZERO, z: F16::ZERO };

    /// Lane `i` set to `v`.
    #[inline(always)]
    pub fn set(&mut self, i: usize, v: glam::Vec3) {
        self.x.0[i] = v.x;
        self.y.0[i] = v.y;
        self.z.0[i] = v.z;
    }

    /// Lane `i`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> glam::Vec3 {
        glam::Vec3::new(self.x.0[i], self.y.0[i], self.z.0[i])
    }

    /// `Vec3::dot`: `(x·x' + y·y') + z·z'`.
    #[inline(always)]
    pub fn dot(self, o: V16) -> F16 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline(always)]
    pub fn length_squared(self) -> F16 {
        self.dot(self)
    }

    /// `Vec3::abs`.
    #[inline(always)]
    pub fn abs(self) -> V16 {
        V16 { x: self.x.abs(), y: self.y.abs(), z: self.z.abs() }
    }

    /// `Vec3::max_element`: glam's maximum of x and y, then of that and z.
    #[inline(always)]
    pub fn max_element(self) -> F16 {
        self.x.max_glam(self.y).max_glam(self.z)
    }

    /// `Vec3::max`, glam's maximum per coordinate.
    #[inline(always)]
    pub fn max_glam(self, o: V16) -> V16 {
        V16 { x: self.x.max_glam(o.x), y: self.y.max_glam(o.y), z: self.z.max_glam(o.z) }
    }

    /// `Vec3::is_finite`.
    #[inline(always)]
    pub fn is_finite(self) -> M16 {
        self.x.is_finite() & self.y.is_finite() & self.z.is_finite()
    }

    /// Coordinate by coordinate.
    #[inline(always)]
    pub fn mul_v(self, o: V16) -> V16 {
        V16 { x: self.x * o.x, y: self.y * o.y, z: self.z * o.z }
    }
}

impl Add for V16 {
    type Output = V16;
    #[inline(always)]
    fn add(self, o: V16) -> V16 {
        V16 { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

impl Sub for V16 {
    type Output = V16;
    #[inline(always)]
    fn sub(self, o: V16) -> V16 {
        V16 { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

impl Neg for V16 {
    type Output = V16;
    #[inline(always)]
    fn neg(self) -> V16 {
        V16 { x: -self.x, y: -self.y, z: -self.z }
    }
}

/// `Vec3 * f32`.
impl Mul<F16> for V16 {
    type Output = V16;
    #[inline(always)]
    fn mul(self, s: F16) -> V16 {
        V16 { x: self.x * s, y: self.y * s, z: self.z * s }
    }
}

/// `Vec3 / f32`.
impl Div<F16> for V16 {
    type Output = V16;
    #[inline(always)]
    fn div(self, s: F16) -> V16 {
        V16 { x: self.x / s, y: self.y / s, z: self.z / s }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Lane values that take every branch of the operations: signs, zeros, NaN, infinities.
    fn awkward() -> (F16, F16) {
        let a = [
            0.0,
            -0.0,
            1.0,
            -2.5,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            3.0,
            1e-40,
            -7.0,
            0.5,
            2.0,
            f32::NAN,
            1.0,
            -1.0,
            4.0,
        ];
        let b = [
            0.0,
            0.0,
            f32::NAN,
            -2.5,
            1.0,
            2.0,
            0.0,
            -3.0,
            1e-40,
            7.0,
            0.25,
            f32::INFINITY,
            f32::NAN,
            -0.0,
            1.0,
            0.0,
        ];
        (F16(a), F16(b))
    }

    #[test]
    fn lanes_are_the_scalar_operations_bit_for_bit() {
        let (a, b) = awkward();
        let same = |v: F16, f: &dyn Fn(usize) -> f32| {
            for i in 0..W {
                assert_eq!(v.0[i].to_bits(), f(i).to_bits(), "lane {i}");
            }
        };
        same(a + b, &|i| a.0[i] + b.0[i]);
        same(a - b, &|i| a.0[i] - b.0[i]);
        same(a * b, &|i| a.0[i] * b.0[i]);
        same(a / b, &|i| a.0[i] / b.0[i]);
        same(a.sqrt(), &|i| a.0[i].sqrt());
        same(a.max(b), &|i| a.0[i].max(b.0[i]));
        same(a.max_glam(b), &|i| Vec3::splat(a.0[i]).max(Vec3::splat(b.0[i])).x);
        same(a.gt(b).select(a, b), &|i| if a.0[i] > b.0[i] { a.0[i] } else { b.0[i] });
        same(a.is_finite().select(a, F16::splat(9.0)), &|i| if a.0[i].is_finite() { a.0[i] } else { 9.0 });
        let v = V16 { x: a, y: b, z: a * b };
        same(v.dot(V16 { x: b, y: a, z: b }), &|i| {
            Vec3::new(a.0[i], b.0[i], a.0[i] * b.0[i]).dot(Vec3::new(b.0[i], a.0[i], b.0[i]))
        });
        same(v.max_element(), &|i| Vec3::new(a.0[i], b.0[i], a.0[i] * b.0[i]).max_element());
        for i in 0..W {
            assert_eq!(v.is_finite().lane(i), v.get(i).is_finite(), "lane {i}");
        }
    }
}

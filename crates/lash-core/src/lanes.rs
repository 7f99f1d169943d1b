//! Numbers for physics written once and run at any width: [`Real`] is what a contact law, a
//! friction law or a joint's kinematics needs of a number; `f64` is one lane (a comparison gives
//! a `bool`), [`F64x8`] is eight lanes side by side (a comparison gives a mask), for the runs of a
//! sweep advanced in lockstep.
//!
//! Every operation of [`F64x8`] is the IEEE operation of each lane, correctly rounded, so a lane
//! gets exactly the bits the scalar code gets from the same source; the choices a scalar code
//! makes with `if` are written as [`Real::select`] (both sides computed, one kept per lane). The
//! lanes are plain loops over an array that the compiler turns into vector instructions of the
//! width the CPU offers (a caller compiled for AVX-512 gets one register per value).

use std::ops::{Add, BitAnd, BitOr, BitXor, Div, Index, IndexMut, Mul, Neg, Not, Sub};

/// Runs advanced side by side in an [`F64x8`].
pub const LANES: usize = 8;
const L: usize = LANES;

/// A per-lane truth value: `bool` for one lane, an all-bits mask for [`F64x8`].
pub trait Mask: Copy + BitAnd<Output = Self> + BitOr<Output = Self> + Not<Output = Self> {
    /// Whether every lane is set.
    fn all(self) -> bool;
    /// Whether any lane is set.
    fn any(self) -> bool;
}

impl Mask for bool {
    #[inline(always)]
    fn all(self) -> bool {
        self
    }
    #[inline(always)]
    fn any(self) -> bool {
        self
    }
}

/// A number of one lane or several, with the operations the physics needs (the spirit of
/// parry's `SimdReal`).
pub trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    /// What a comparison gives.
    type Mask: Mask;
    /// `v` in every lane.
    fn splat(v: f64) -> Self;
    /// √x.
    fn sqrt(self) -> Self;
    /// |x|.
    fn abs(self) -> Self;
    /// `f64::max` lane by lane.
    fn max(self, o: Self) -> Self;
    /// `self > o`.
    fn simd_gt(self, o: Self) -> Self::Mask;
    /// `self >= o`.
    fn simd_ge(self, o: Self) -> Self::Mask;
    /// `self < o`.
    fn simd_lt(self, o: Self) -> Self::Mask;
    /// `self <= o`.
    fn simd_le(self, o: Self) -> Self::Mask;
    /// `self != o`.
    fn simd_ne(self, o: Self) -> Self::Mask;
    /// `t` where `mask` is set, `f` elsewhere.
    fn select(mask: Self::Mask, t: Self, f: Self) -> Self;
    /// 1, −1 or 0 by the sign of x (0 for ±0).
    #[inline(always)]
    fn signum_or_zero(self) -> Self {
        let (zero, one) = (Self::splat(0.0), Self::splat(1.0));
        Self::select(self.simd_gt(zero), one, Self::select(self.simd_lt(zero), -one, zero))
    }
}

impl Real for f64 {
    type Mask = bool;
    #[inline(always)]
    fn splat(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        f64::max(self, o)
    }
    #[inline(always)]
    fn simd_gt(self, o: Self) -> bool {
        self > o
    }
    #[inline(always)]
    fn simd_ge(self, o: Self) -> bool {
        self >= o
    }
    #[inline(always)]
    fn simd_lt(self, o: Self) -> bool {
        self < o
    }
    #[inline(always)]
    fn simd_le(self, o: Self) -> bool {
        self <= o
    }
    #[inline(always)]
    fn simd_ne(self, o: Self) -> bool {
        self != o
    }
    #[inline(always)]
    fn select(mask: bool, t: Self, f: Self) -> Self {
        if mask { t } else { f }
    }
}

/// Eight numbers, one per lane; a comparison gives a mask (all bits set where true), which is
/// itself an `F64x8` (`&`, `|`, `^`, `!` act on the bits).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct F64x8(pub [f64; L]);

#[inline(always)]
fn each(f: impl Fn(usize) -> f64) -> F64x8 {
    F64x8(std::array::from_fn(f))
}

/// A lane of a mask: all bits set where `b`.
#[inline(always)]
fn flag(b: bool) -> f64 {
    f64::from_bits(if b { u64::MAX } else { 0 })
}

impl F64x8 {
    /// 0 in every lane.
    pub const ZERO: Self = Self([0.0; L]);
    /// 1 in every lane.
    pub const ONE: Self = Self([1.0; L]);

    /// `v` in every lane.
    #[inline(always)]
    pub fn splat(v: f64) -> Self {
        Self([v; L])
    }
    /// The mask of per-lane flags.
    #[inline(always)]
    pub fn mask(flags: [bool; L]) -> Self {
        Self(flags.map(flag))
    }
    /// √x lane by lane.
    #[inline(always)]
    pub fn sqrt(self) -> Self {
        each(|l| self.0[l].sqrt())
    }
    /// `f64::max` lane by lane.
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        each(|l| self.0[l].max(o.0[l]))
    }
    /// |x| lane by lane.
    #[inline(always)]
    pub fn abs(self) -> Self {
        each(|l| self.0[l].abs())
    }
    /// `self > o` as a mask.
    #[inline(always)]
    pub fn simd_gt(self, o: Self) -> Self {
        each(|l| flag(self.0[l] > o.0[l]))
    }
    /// `self >= o` as a mask.
    #[inline(always)]
    pub fn simd_ge(self, o: Self) -> Self {
        each(|l| flag(self.0[l] >= o.0[l]))
    }
    /// `self < o` as a mask.
    #[inline(always)]
    pub fn simd_lt(self, o: Self) -> Self {
        each(|l| flag(self.0[l] < o.0[l]))
    }
    /// `self <= o` as a mask.
    #[inline(always)]
    pub fn simd_le(self, o: Self) -> Self {
        each(|l| flag(self.0[l] <= o.0[l]))
    }
    /// `self != o` as a mask.
    #[inline(always)]
    pub fn simd_ne(self, o: Self) -> Self {
        each(|l| flag(self.0[l] != o.0[l]))
    }
    /// For a mask: `t` where set, `f` elsewhere.
    #[inline(always)]
    pub fn select(self, t: Self, f: Self) -> Self {
        each(|l| {
            let m = self.0[l].to_bits();
            f64::from_bits((m & t.0[l].to_bits()) | (!m & f.0[l].to_bits()))
        })
    }
    /// For a mask: whether every lane is set.
    #[inline(always)]
    pub fn all(self) -> bool {
        self.to_bitmask() == (1 << L) - 1
    }
    /// For a mask: whether any lane is set.
    #[inline(always)]
    pub fn any(self) -> bool {
        self.to_bitmask() != 0
    }
    /// For a mask: bit l set where lane l is.
    #[inline(always)]
    pub fn to_bitmask(self) -> u32 {
        self.0.iter().enumerate().fold(0, |b, (l, v)| b | (((v.to_bits() >> 63) as u32) << l))
    }
}

impl Default for F64x8 {
    #[inline(always)]
    fn default() -> Self {
        Self::ZERO
    }
}

impl Mask for F64x8 {
    #[inline(always)]
    fn all(self) -> bool {
        F64x8::all(self)
    }
    #[inline(always)]
    fn any(self) -> bool {
        F64x8::any(self)
    }
}

impl Real for F64x8 {
    type Mask = F64x8;
    #[inline(always)]
    fn splat(v: f64) -> Self {
        F64x8::splat(v)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        F64x8::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        F64x8::abs(self)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        F64x8::max(self, o)
    }
    #[inline(always)]
    fn simd_gt(self, o: Self) -> Self {
        F64x8::simd_gt(self, o)
    }
    #[inline(always)]
    fn simd_ge(self, o: Self) -> Self {
        F64x8::simd_ge(self, o)
    }
    #[inline(always)]
    fn simd_lt(self, o: Self) -> Self {
        F64x8::simd_lt(self, o)
    }
    #[inline(always)]
    fn simd_le(self, o: Self) -> Self {
        F64x8::simd_le(self, o)
    }
    #[inline(always)]
    fn simd_ne(self, o: Self) -> Self {
        F64x8::simd_ne(self, o)
    }
    #[inline(always)]
    fn select(mask: Self, t: Self, f: Self) -> Self {
        mask.select(t, f)
    }
}

impl Index<usize> for F64x8 {
    type Output = f64;
    #[inline(always)]
    fn index(&self, l: usize) -> &f64 {
        &self.0[l]
    }
}

impl IndexMut<usize> for F64x8 {
    #[inline(always)]
    fn index_mut(&mut self, l: usize) -> &mut f64 {
        &mut self.0[l]
    }
}

impl From<[f64; L]> for F64x8 {
    #[inline(always)]
    fn from(a: [f64; L]) -> Self {
        Self(a)
    }
}

impl From<F64x8> for [f64; L] {
    #[inline(always)]
    fn from(v: F64x8) -> Self {
        v.0
    }
}

impl From<f64> for F64x8 {
    #[inline(always)]
    fn from(v: f64) -> Self {
        Self([v; L])
    }
}

macro_rules! arithmetic {
    ($($trait:ident $method:ident $op:tt),*) => {$(
        impl $trait for F64x8 {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                each(|l| self.0[l] $op o.0[l])
            }
        }
    )*};
}
arithmetic!(Add add +, Sub sub -, Mul mul *, Div div /);

macro_rules! bitwise {
    ($($trait:ident $method:ident $op:tt),*) => {$(
        impl $trait for F64x8 {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                each(|l| f64::from_bits(self.0[l].to_bits() $op o.0[l].to_bits()))
            }
        }
    )*};
}
bitwise!(BitAnd bitand &, BitOr bitor |, BitXor bitxor ^);

impl Neg for F64x8 {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        each(|l| -self.0[l])
    }
}

impl Not for F64x8 {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        each(|l| f64::from_bits(!self.0[l].to_bits()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A generic expression with a choice in it, evaluated once per lane and once in lanes.
    fn clipped<R: Real>(x: R, y: R) -> R {
        let zero = R::splat(0.0);
        R::select(x.simd_le(zero), zero, (x * x.sqrt() + y / x).max(zero)) + y.signum_or_zero()
    }

    #[test]
    fn each_lane_gets_the_scalar_bits() {
        let xs = [-1.0, 0.0, 1e-9, 0.3, 2.0, f64::INFINITY, 7.5, -0.0];
        let ys = [3.0, -2.0, 0.0, -0.0, 1e300, -5.0, 0.25, 1.0];
        let lanes = clipped(F64x8(xs), F64x8(ys));
        for l in 0..LANES {
            assert_eq!(lanes[l].to_bits(), clipped(xs[l], ys[l]).to_bits(), "lane {l}");
        }
    }

    #[test]
    fn masks_select_and_count() {
        let m = F64x8::mask([true, false, true, false, false, false, false, true]);
        assert_eq!(m.to_bitmask(), 0b1000_0101);
        assert!(m.any() && !m.all() && (m | !m).all() && !(m & !m).any());
        let s = m.select(F64x8::ONE, F64x8::ZERO);
        assert_eq!(s.0, [1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        assert_eq!(F64x8::splat(-2.0).abs(), F64x8::splat(2.0));
    }
}

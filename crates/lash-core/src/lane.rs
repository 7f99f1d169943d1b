//! One number type for physics written once and run at any width: [`Real`], implemented by
//! `f64` (one lane: a single run) and by [`F64x8`] (eight lanes: eight runs of a sweep side by
//! side, in one AVX-512 register where the processor has one).
//!
//! Every operation acts lane by lane and is the IEEE operation the scalar code does, correctly
//! rounded, so a lane of a function written over [`Real`] gets the bits the `f64` instance gets.
//! Choices are selections, not branches ([`Real::select`]); where a branch saves work that the
//! lanes rarely need, it is taken on [`Real::any`] / [`Real::all`] of a mask, which for `f64` is
//! the scalar code's own branch.

use std::ops::{Add, BitAnd, BitOr, BitXor, Div, Index, IndexMut, Mul, Neg, Not, Sub};

/// Lanes of [`F64x8`].
pub const LANES: usize = 8;

/// A number of one or more lanes, with the operations the contact, friction and joint laws need.
pub trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    /// Lanes in one number: 1 for `f64` (one run), 8 for [`F64x8`]. A function written over `Real`
    /// may skip work that every lane can do without only where one run does it (`WIDTH == 1`):
    /// for eight lanes the test and its branch in the middle of the arithmetic can cost more
    /// than the work.
    const WIDTH: usize;
    /// A comparison's result, lane by lane.
    type Mask: Copy + BitAnd<Output = Self::Mask> + BitOr<Output = Self::Mask> + Not<Output = Self::Mask>;
    /// `v` in every lane.
    fn splat(v: f64) -> Self;
    /// √x.
    fn sqrt(self) -> Self;
    /// |x|.
    fn abs(self) -> Self;
    /// `f64::max` lane by lane.
    fn max(self, o: Self) -> Self;
    /// eˣ (`f64::exp` lane by lane).
    fn exp(self) -> Self;
    /// xⁿ for one exponent `n` of every lane (`f64::powf` lane by lane).
    fn powf(self, n: f64) -> Self;
    /// The angle of the point (x, y) = (`x`, `self`) in (−π, π] (`f64::atan2` lane by lane).
    fn atan2(self, x: Self) -> Self;
    /// Lane `l`'s number (`l < WIDTH`): for work that is scalar by nature (a root search
    /// whose steps differ from lane to lane), done lane by lane.
    fn lane(self, l: usize) -> f64;
    /// The number whose lane `l` is `f(l)`.
    fn from_lanes(f: impl FnMut(usize) -> f64) -> Self;
    /// self > o.
    fn simd_gt(self, o: Self) -> Self::Mask;
    /// self ≥ o.
    fn simd_ge(self, o: Self) -> Self::Mask;
    /// self < o.
    fn simd_lt(self, o: Self) -> Self::Mask;
    /// self ≤ o.
    fn simd_le(self, o: Self) -> Self::Mask;
    /// self ≠ o.
    fn simd_ne(self, o: Self) -> Self::Mask;
    /// `t` where `mask`, `f` elsewhere.
    fn select(mask: Self::Mask, t: Self, f: Self) -> Self;
    /// Whether `mask` holds in some lane.
    fn any(mask: Self::Mask) -> bool;
    /// Whether `mask` holds in every lane.
    fn all(mask: Self::Mask) -> bool;
}

impl Real for f64 {
    const WIDTH: usize = 1;
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
    #[inline(always)]
    fn any(mask: bool) -> bool {
        mask
    }
    #[inline(always)]
    fn all(mask: bool) -> bool {
        mask
    }
    #[inline(always)]
    fn powf(self, n: f64) -> Self {
        f64::powf(self, n)
    }
    #[inline(always)]
    fn exp(self) -> Self {
        f64::exp(self)
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        f64::atan2(self, x)
    }
    #[inline(always)]
    fn lane(self, _: usize) -> f64 {
        self
    }
    #[inline(always)]
    fn from_lanes(mut f: impl FnMut(usize) -> f64) -> Self {
        f(0)
    }
}

/// Eight numbers, one per lane; a comparison gives a mask of the same type (all bits set where
/// true). Plain loops over the lanes that the compiler turns into vector instructions of whatever
/// width the CPU offers (the callers compile their hot loops for AVX-512 and AVX2 as well).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct F64x8(pub [f64; LANES]);

#[inline(always)]
fn each(f: impl Fn(usize) -> f64) -> F64x8 {
    F64x8(std::array::from_fn(f))
}

/// One lane of a mask: all bits set where `b`.
#[inline(always)]
pub fn flag(b: bool) -> f64 {
    f64::from_bits(if b { u64::MAX } else { 0 })
}

impl Default for F64x8 {
    #[inline(always)]
    fn default() -> Self {
        Self::ZERO
    }
}

impl F64x8 {
    /// 0 in every lane.
    pub const ZERO: Self = Self([0.0; LANES]);
    /// 1 in every lane.
    pub const ONE: Self = Self([1.0; LANES]);

    /// `v` in every lane.
    #[inline(always)]
    pub fn splat(v: f64) -> Self {
        Self([v; LANES])
    }
    /// `f` of each lane.
    #[inline(always)]
    pub fn map(self, f: impl Fn(f64) -> f64) -> Self {
        each(|l| f(self.0[l]))
    }
    /// `f` of each lane's pair.
    #[inline(always)]
    pub fn zip(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        each(|l| f(self.0[l], o.0[l]))
    }
    /// A mask from per-lane flags.
    #[inline(always)]
    pub fn mask(flags: [bool; LANES]) -> Self {
        Self(flags.map(flag))
    }
    /// `a` in the lanes where `flags` are set, `self` elsewhere.
    #[inline(always)]
    pub fn replaced_where(self, flags: [bool; LANES], a: Self) -> Self {
        each(|l| if flags[l] { a.0[l] } else { self.0[l] })
    }
    /// For a mask (`self`): `t` where set, `f` elsewhere ([`Real::select`] as a method).
    #[inline(always)]
    pub fn select(self, t: Self, f: Self) -> Self {
        <Self as Real>::select(self, t, f)
    }
    /// For a mask: whether every lane is set.
    #[inline(always)]
    pub fn all(self) -> bool {
        <Self as Real>::all(self)
    }
    /// For a mask: bit l set where lane l is.
    #[inline(always)]
    pub fn to_bitmask(self) -> u32 {
        self.0.iter().enumerate().fold(0, |b, (l, v)| b | (((v.to_bits() >> 63) as u32) << l))
    }
}

impl Real for F64x8 {
    const WIDTH: usize = LANES;
    type Mask = F64x8;
    #[inline(always)]
    fn splat(v: f64) -> Self {
        Self([v; LANES])
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        self.map(f64::sqrt)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        self.map(f64::abs)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        self.zip(o, f64::max)
    }
    #[inline(always)]
    fn exp(self) -> Self {
        self.map(f64::exp)
    }
    #[inline(always)]
    fn powf(self, n: f64) -> Self {
        self.map(|v| v.powf(n))
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        self.zip(x, f64::atan2)
    }
    #[inline(always)]
    fn lane(self, l: usize) -> f64 {
        self.0[l]
    }
    #[inline(always)]
    fn from_lanes(f: impl FnMut(usize) -> f64) -> Self {
        Self(std::array::from_fn(f))
    }
    #[inline(always)]
    fn simd_gt(self, o: Self) -> Self {
        each(|l| flag(self.0[l] > o.0[l]))
    }
    #[inline(always)]
    fn simd_ge(self, o: Self) -> Self {
        each(|l| flag(self.0[l] >= o.0[l]))
    }
    #[inline(always)]
    fn simd_lt(self, o: Self) -> Self {
        each(|l| flag(self.0[l] < o.0[l]))
    }
    #[inline(always)]
    fn simd_le(self, o: Self) -> Self {
        each(|l| flag(self.0[l] <= o.0[l]))
    }
    #[inline(always)]
    fn simd_ne(self, o: Self) -> Self {
        each(|l| flag(self.0[l] != o.0[l]))
    }
    #[inline(always)]
    fn select(mask: Self, t: Self, f: Self) -> Self {
        each(|l| {
            let m = mask.0[l].to_bits();
            f64::from_bits((m & t.0[l].to_bits()) | (!m & f.0[l].to_bits()))
        })
    }
    #[inline(always)]
    fn any(mask: Self) -> bool {
        mask.to_bitmask() != 0
    }
    #[inline(always)]
    fn all(mask: Self) -> bool {
        mask.to_bitmask() == (1 << LANES) - 1
    }
}

impl From<[f64; LANES]> for F64x8 {
    #[inline(always)]
    fn from(a: [f64; LANES]) -> Self {
        Self(a)
    }
}

impl From<F64x8> for [f64; LANES] {
    #[inline(always)]
    fn from(v: F64x8) -> Self {
        v.0
    }
}

impl From<f64> for F64x8 {
    #[inline(always)]
    fn from(v: f64) -> Self {
        Self([v; LANES])
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

/// The lane-by-lane operators: IEEE arithmetic, and bitwise on the bits (of masks).
macro_rules! operators {
    ($($trait:ident $method:ident |$a:ident, $b:ident| $body:expr),*) => {$(
        impl $trait for F64x8 {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                each(|l| {
                    let ($a, $b) = (self.0[l], o.0[l]);
                    $body
                })
            }
        }
    )*};
}
operators!(
    Add add |a, b| a + b,
    Sub sub |a, b| a - b,
    Mul mul |a, b| a * b,
    Div div |a, b| a / b,
    BitAnd bitand |a, b| f64::from_bits(a.to_bits() & b.to_bits()),
    BitOr bitor |a, b| f64::from_bits(a.to_bits() | b.to_bits()),
    BitXor bitxor |a, b| f64::from_bits(a.to_bits() ^ b.to_bits())
);

/// Every lane times one number (as `* F64x8::splat(f)`): a step's fractions scale lanes.
impl Mul<f64> for F64x8 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, f: f64) -> Self {
        self.map(|v| v * f)
    }
}

impl Neg for F64x8 {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(|v| -v)
    }
}

impl Not for F64x8 {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        self.map(|v| f64::from_bits(!v.to_bits()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A function written once over [`Real`]: a clipped law with a value formed only where some
    /// lane needs it (and selected by its mask all the same).
    fn clipped<R: Real>(x: R, k: R) -> R {
        let (zero, five) = (R::splat(0.0), R::splat(5.0));
        let far = x.simd_gt(five);
        let rare = if R::any(far) { five / x } else { zero };
        let f = R::select(far, rare, k * x * x.abs().sqrt());
        R::select(x.simd_gt(zero), f.max(zero), zero)
    }

    #[test]
    fn each_lane_gets_the_scalar_bits() {
        let xs = [0.3, -0.0, 0.0, 1e-300, -2.5, 7.0, f64::MIN_POSITIVE, 0.123_456_789];
        let ks = [1.0, 2.0, 3.0, 5e9, 0.1, 1e-3, 4.0, 7.5];
        let lanes = clipped(F64x8(xs), F64x8(ks));
        for l in 0..LANES {
            assert_eq!(lanes[l].to_bits(), clipped(xs[l], ks[l]).to_bits(), "lane {l}");
        }
    }

    #[test]
    fn masks_select_and_count() {
        let a = F64x8([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
        let m = a.simd_gt(F64x8::splat(4.5));
        assert_eq!(m.to_bitmask(), 0b1111_0000);
        assert!(F64x8::any(m) && !F64x8::all(m) && F64x8::all(a.simd_gt(F64x8::ZERO)));
        let s = F64x8::select(m, F64x8::ONE, -F64x8::ONE);
        assert_eq!(s.0, [-1.0, -1.0, -1.0, -1.0, 1.0, 1.0, 1.0, 1.0]);
        assert_eq!(a.replaced_where([true, false, false, false, false, false, false, true], F64x8::ZERO)[7], 0.0);
    }
}

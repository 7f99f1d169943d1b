//! Friction laws: the signed friction coefficient μ(v_t), odd in the slip velocity, so that
//! F_T = μ(v_t) F_N and the force on the journal is −F_T t.

use crate::law::step_of;
use lash_core::Problems;
use lash_core::lane::Real;
use serde::{Deserialize, Serialize};

/// A friction law as written in a scenario file (`law = "ambrosio"`, …).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(tag = "law", rename_all = "snake_case", deny_unknown_fields)]
pub enum FrictionLaw {
    /// No friction.
    #[default]
    None,
    /// μ sign(v_t).
    Coulomb {
        /// μ [-].
        coefficient: f64,
    },
    /// Ambrósio's modified Coulomb: μ c_d(|v_t|) sign(v_t), c_d = 0 below v0, linear to 1 at v1.
    Ambrosio {
        /// μ [-].
        coefficient: f64,
        /// v0 [m/s].
        v0: f64,
        /// v1 [m/s].
        v1: f64,
    },
    /// ADAMS stick–slip: STEP(v, −v_s, −μ_s, v_s, μ_s) below v_s, STEP(|v|, v_s, μ_s, v_d, μ_d)
    /// between v_s and v_d, μ_d above.
    AdamsStickSlip {
        /// Static coefficient μ_s [-].
        static_coefficient: f64,
        /// Dynamic coefficient μ_d [-].
        dynamic_coefficient: f64,
        /// Stiction transition velocity v_s [m/s].
        stiction_velocity: f64,
        /// Friction transition velocity v_d [m/s] (> v_s).
        friction_velocity: f64,
    },
    /// Threlfall: μ (1 − exp(−3|v_t|/v0)) sign(v_t).
    Threlfall {
        /// μ [-].
        coefficient: f64,
        /// v0 [m/s]: 95 % of μ is reached at v0.
        v0: f64,
    },
}

/// The friction laws written for any lane width ([`Real`]): the kind shared by the lanes of a
/// group, their numbers per lane ([`LaneFriction::of`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LaneFriction {
    /// No friction.
    None,
    /// μ sign(v_t): numbers (μ).
    Coulomb,
    /// Ambrósio's modified Coulomb: numbers (μ, v0, v1).
    Ambrosio,
    /// ADAMS stick–slip: numbers (μ_s, μ_d, v_s, v_d).
    StickSlip,
    /// Threlfall: numbers (μ, v0).
    Threlfall,
}

impl LaneFriction {
    /// The kind of `law` and its numbers (unused ones zero).
    pub fn of(law: &FrictionLaw) -> (Self, [f64; 4]) {
        match *law {
            FrictionLaw::None => (LaneFriction::None, [0.0; 4]),
            FrictionLaw::Coulomb { coefficient } => (LaneFriction::Coulomb, [coefficient, 0.0, 0.0, 0.0]),
            FrictionLaw::Ambrosio { coefficient, v0, v1 } => (LaneFriction::Ambrosio, [coefficient, v0, v1, 0.0]),
            FrictionLaw::AdamsStickSlip {
                static_coefficient,
                dynamic_coefficient,
                stiction_velocity,
                friction_velocity,
            } => (
                LaneFriction::StickSlip,
                [static_coefficient, dynamic_coefficient, stiction_velocity, friction_velocity],
            ),
            FrictionLaw::Threlfall { coefficient, v0 } => (LaneFriction::Threlfall, [coefficient, v0, 0.0, 0.0]),
        }
    }
}

/// sign(v) as the friction laws take it: 1, −1, or 0 at rest.
#[inline(always)]
pub fn slip_sign<R: Real>(v: R) -> R {
    let (zero, one) = (R::splat(0.0), R::splat(1.0));
    R::select(v.simd_gt(zero), one, R::select(v.simd_lt(zero), -one, zero))
}

/// Ambrósio's dynamic correction c_d(|v|): 0 up to `v0`, 1 from `v1`, linear between. Behind
/// branches taken when every lane sticks or every lane slides — for one run, the law's own
/// `if`s, which the compiler keeps as branches (one chain of selections cost the scalar micro
/// step a fifth of its time: docs/performance.md) — its division is formed only where some lane
/// is between (rare at speed).
#[inline(always)]
pub fn ambrosio_factor<R: Real>(speed: R, v0: R, v1: R) -> R {
    let (zero, one) = (R::splat(0.0), R::splat(1.0));
    let (stuck, sliding) = (speed.simd_le(v0), speed.simd_ge(v1));
    if R::all(stuck) {
        return zero;
    }
    if R::all(sliding) {
        return R::select(stuck, zero, one);
    }
    R::select(stuck, zero, R::select(sliding, one, (speed - v0) / (v1 - v0)))
}

/// ADAMS stick–slip μ(v): STEP(v, −v_s, −μ_s, v_s, μ_s) below v_s, STEP(|v|, v_s, μ_s, v_d, μ_d)
/// sign(v) up to v_d, μ_d sign(v) beyond — each region a branch where every lane is in it (for
/// one run, the scalar `if`s), selections otherwise.
#[inline(always)]
pub fn stick_slip_coefficient<R: Real>((ms, md, vs, vd): (R, R, R, R), v: R) -> R {
    let (s, a) = (slip_sign(v), v.abs());
    let sticking = a.simd_lt(vs);
    // (Beyond v_d as the scalar `else` takes it: not at or below v_d.)
    let beyond = !a.simd_le(vd);
    if R::all(sticking) {
        return step_of(v, -vs, -ms, vs, ms);
    }
    if R::all(beyond) {
        return md * s;
    }
    let stick = if R::any(sticking) { step_of(v, -vs, -ms, vs, ms) } else { R::splat(0.0) };
    let between = step_of(a, vs, ms, vd, md) * s;
    R::select(sticking, stick, R::select(beyond, md * s, between))
}

/// Threlfall's μ(v) = μ (1 − exp(−3|v|/v0)) sign(v).
#[inline(always)]
pub fn threlfall_coefficient<R: Real>((mu, v0): (R, R), v: R) -> R {
    mu * (R::splat(1.0) - (R::splat(-3.0) * v.abs() / v0).exp()) * slip_sign(v)
}

/// The signed coefficient μ(v) of a law of kind `kind` with the numbers `p`
/// ([`LaneFriction::of`]), for one run or several side by side.
#[inline(always)]
pub fn lane_coefficient<R: Real>(kind: LaneFriction, p: &[R; 4], v: R) -> R {
    match kind {
        LaneFriction::None => R::splat(0.0),
        LaneFriction::Coulomb => p[0] * slip_sign(v),
        LaneFriction::Ambrosio => p[0] * ambrosio_factor(v.abs(), p[1], p[2]) * slip_sign(v),
        LaneFriction::StickSlip => stick_slip_coefficient((p[0], p[1], p[2], p[3]), v),
        LaneFriction::Threlfall => threlfall_coefficient((p[0], p[1]), v),
    }
}

impl FrictionLaw {
    /// The signed coefficient μ(v_t).
    #[inline(always)]
    pub fn coefficient(&self, v: f64) -> f64 {
        // (The laws' arithmetic is [`lane_coefficient`]'s, written once for a run and for the
        // lanes; each arm passes its own numbers.)
        match *self {
            FrictionLaw::None => 0.0,
            FrictionLaw::Coulomb { coefficient } => {
                lane_coefficient(LaneFriction::Coulomb, &[coefficient, 0.0, 0.0, 0.0], v)
            }
            FrictionLaw::Ambrosio { coefficient, v0, v1 } => {
                lane_coefficient(LaneFriction::Ambrosio, &[coefficient, v0, v1, 0.0], v)
            }
            FrictionLaw::AdamsStickSlip {
                static_coefficient: ms,
                dynamic_coefficient: md,
                stiction_velocity: vs,
                friction_velocity: vd,
            } => stick_slip_coefficient((ms, md, vs, vd), v),
            FrictionLaw::Threlfall { coefficient, v0 } => threlfall_coefficient((coefficient, v0), v),
        }
    }

    /// Problems of the law's numbers.
    pub fn validate(&self) -> Problems {
        let mut p = Problems::new();
        match *self {
            FrictionLaw::None => {}
            FrictionLaw::Coulomb { coefficient } => p.non_negative("coefficient", coefficient),
            FrictionLaw::Ambrosio { coefficient, v0, v1 } => {
                p.non_negative("coefficient", coefficient);
                p.non_negative("v0", v0);
                p.positive("v1", v1);
                if v1 <= v0 {
                    p.push("v1", format!("must exceed v0 = {v0}, got {v1}"));
                }
            }
            FrictionLaw::AdamsStickSlip {
                static_coefficient,
                dynamic_coefficient,
                stiction_velocity,
                friction_velocity,
            } => {
                p.non_negative("static_coefficient", static_coefficient);
                p.non_negative("dynamic_coefficient", dynamic_coefficient);
                p.positive("stiction_velocity", stiction_velocity);
                p.positive("friction_velocity", friction_velocity);
                if friction_velocity <= stiction_velocity {
                    p.push("friction_velocity", "must exceed stiction_velocity");
                }
            }
            FrictionLaw::Threlfall { coefficient, v0 } => {
                p.non_negative("coefficient", coefficient);
                p.positive("v0", v0);
            }
        }
        p
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use proptest::prelude::*;

    /// One of every friction law (the crate's tests of the laws and of the joints over them).
    pub(crate) fn laws() -> [FrictionLaw; 5] {
        [
            FrictionLaw::None,
            FrictionLaw::Coulomb { coefficient: 0.1 },
            FrictionLaw::Ambrosio { coefficient: 0.1, v0: 1e-4, v1: 1e-3 },
            FrictionLaw::AdamsStickSlip {
                static_coefficient: 0.15,
                dynamic_coefficient: 0.1,
                stiction_velocity: 1e-4,
                friction_velocity: 1e-3,
            },
            FrictionLaw::Threlfall { coefficient: 0.1, v0: 1e-3 },
        ]
    }

    #[test]
    fn reference_values() {
        let a = FrictionLaw::Ambrosio { coefficient: 0.1, v0: 1e-4, v1: 1e-3 };
        assert_eq!(a.coefficient(5e-5), 0.0);
        assert!((a.coefficient(5.5e-4) - 0.05).abs() < 1e-15);
        assert_eq!(a.coefficient(-1.0), -0.1);
        let s = laws()[3];
        assert!((s.coefficient(1e-4) - 0.15).abs() < 1e-15);
        assert!((s.coefficient(-2e-3) + 0.1).abs() < 1e-15);
        assert_eq!(s.coefficient(0.0), 0.0);
        let t = laws()[4];
        assert!((t.coefficient(1e-3) - 0.1 * (1.0 - (-3.0f64).exp())).abs() < 1e-15);
    }

    #[test]
    fn the_laws_in_lanes_are_the_scalar_laws_bit_for_bit() {
        use lash_core::lane::{F64x8, LANES};
        // Groups all stuck, all sliding, and mixed (stuck, between, sliding, both signs, rest).
        let groups: [[f64; LANES]; 3] = [
            [0.0, 1e-5, -2e-5, 5e-5, -9e-5, 1e-4, -1e-4, 3e-5],
            [2e-3, -5e-3, 1.0, -0.7, 1e-3, -1e-3, 12.0, -3e-3],
            [0.0, 5e-5, -3e-4, 7e-4, -2e-3, 0.4, -1e-4, 1e-3],
        ];
        for v in groups {
            for law in laws() {
                let (kind, numbers) = LaneFriction::of(&law);
                let lanes = lane_coefficient(kind, &numbers.map(F64x8::splat), F64x8(v));
                for l in 0..LANES {
                    assert_eq!(lanes[l].to_bits(), law.coefficient(v[l]).to_bits(), "{kind:?} at {}", v[l]);
                }
            }
        }
    }

    proptest! {
        #[test]
        fn friction_is_odd_and_bounded(v in -1.0f64..1.0) {
            for law in laws() {
                let mu = law.coefficient(v);
                prop_assert!((mu + law.coefficient(-v)).abs() < 1e-15);
                prop_assert!(mu * v >= 0.0, "friction must oppose slip");
                prop_assert!(mu.abs() <= 0.15 + 1e-15);
            }
        }

        /// ADAMS's stick–slip coefficient written as its friction reference does: −STEP(v, −v_s,
        /// μ_s, v_s, −μ_s) in the stiction band, sign(v)·STEP(|v|, v_s, μ_s, v_d, μ_d) in the
        /// transition, sign(v)·μ_d beyond (STEP written out independently).
        #[test]
        fn adams_stick_slip_equals_the_adams_definition(
            v in -5e-3f64..5e-3, ms in 0.05f64..0.5, md_fraction in 0.1f64..1.0, vs in 1e-5f64..1e-3, vd_factor in 1.5f64..20.0
        ) {
            fn adams_step(x: f64, x0: f64, h0: f64, x1: f64, h1: f64) -> f64 {
                if x <= x0 { return h0; }
                if x >= x1 { return h1; }
                let u = (x - x0) / (x1 - x0);
                h0 + (h1 - h0) * u * u * (3.0 - 2.0 * u)
            }
            let (md, vd) = (ms * md_fraction, vs * vd_factor);
            let adams = if v.abs() <= vs {
                -adams_step(v, -vs, ms, vs, -ms)
            } else if v.abs() <= vd {
                v.signum() * adams_step(v.abs(), vs, ms, vd, md)
            } else {
                v.signum() * md
            };
            let law = FrictionLaw::AdamsStickSlip {
                static_coefficient: ms,
                dynamic_coefficient: md,
                stiction_velocity: vs,
                friction_velocity: vd,
            };
            prop_assert!((law.coefficient(v) - adams).abs() < 1e-14, "lash {} vs ADAMS {}", law.coefficient(v), adams);
        }
    }
}

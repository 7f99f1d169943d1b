//! The Dormand–Prince 5(4) pair: 7 stages (first same as last), 4th-order continuous extension
//! at no extra cost, and the options shared by both adaptive methods.
//!
//! Coefficients and the continuous extension follow Hairer, Nørsett & Wanner, *Solving Ordinary
//! Differential Equations I*, §II.5–II.6 (the DOPRI5 code's `contd5`).

use crate::OdeSystem;
use crate::adaptive::{Control, Pair};

/// Options of the adaptive integrators (Dormand–Prince 5(4) and 8(5,3)).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdaptiveOptions {
    /// Relative tolerance (per component, scaled by the larger of |y| at both step ends).
    pub rtol: f64,
    /// Absolute tolerance [state units: m, rad, m/s, rad/s].
    pub atol: f64,
    /// First step tried \[s\].
    #[serde(default = "default_initial_step")]
    pub initial_step: f64,
    /// Largest step allowed \[s\].
    #[serde(default = "default_max_step")]
    pub max_step: f64,
    /// Smallest step allowed before giving up \[s\]. A right side that jumps without an event (pure
    /// Coulomb friction at sticking) drives the step size down here instead of hanging the run.
    #[serde(default = "default_min_step")]
    pub min_step: f64,
}

fn default_initial_step() -> f64 {
    1e-6
}
fn default_max_step() -> f64 {
    1e-3
}
fn default_min_step() -> f64 {
    1e-12
}

impl Default for AdaptiveOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-9,
            atol: 1e-12,
            initial_step: default_initial_step(),
            max_step: default_max_step(),
            min_step: default_min_step(),
        }
    }
}

const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

/// Stages and continuous extension of one DOPRI5 step; allocated once per run.
pub(crate) struct Dopri5 {
    k: [Vec<f64>; 7],
    y_stage: Vec<f64>,
    y_new: Vec<f64>,
    err: Vec<f64>,
    dense: [Vec<f64>; 5],
}

impl Pair for Dopri5 {
    const CONTROL: Control = Control {
        accept_exponent: 0.2 - 0.04 * 0.75,
        beta: 0.04,
        reject_exponent: 0.2,
        shrink: 5.0,
        grow: 10.0,
        reject_floor: 0.2,
    };
    const STAGE_EVALUATIONS: u64 = 6;

    fn new(n: usize) -> Self {
        let v = || vec![0.0; n];
        Self {
            k: [v(), v(), v(), v(), v(), v(), v()],
            y_stage: v(),
            y_new: v(),
            err: v(),
            dense: [v(), v(), v(), v(), v()],
        }
    }

    fn derivative_at_start(&mut self) -> &mut [f64] {
        &mut self.k[0]
    }

    fn step<S: OdeSystem + ?Sized>(&mut self, system: &mut S, t: f64, y: &[f64], h: f64) {
        let n = y.len();
        let [k1, k2, k3, k4, k5, k6, k7] = &mut self.k;
        let ys = &mut self.y_stage;
        for j in 0..n {
            ys[j] = y[j] + h * A21 * k1[j];
        }
        system.rhs(t + C2 * h, ys, k2);
        for j in 0..n {
            ys[j] = y[j] + h * (A31 * k1[j] + A32 * k2[j]);
        }
        system.rhs(t + C3 * h, ys, k3);
        for j in 0..n {
            ys[j] = y[j] + h * (A41 * k1[j] + A42 * k2[j] + A43 * k3[j]);
        }
        system.rhs(t + C4 * h, ys, k4);
        for j in 0..n {
            ys[j] = y[j] + h * (A51 * k1[j] + A52 * k2[j] + A53 * k3[j] + A54 * k4[j]);
        }
        system.rhs(t + C5 * h, ys, k5);
        for j in 0..n {
            ys[j] = y[j] + h * (A61 * k1[j] + A62 * k2[j] + A63 * k3[j] + A64 * k4[j] + A65 * k5[j]);
        }
        system.rhs(t + h, ys, k6);
        for j in 0..n {
            self.y_new[j] = y[j] + h * (A71 * k1[j] + A73 * k3[j] + A74 * k4[j] + A75 * k5[j] + A76 * k6[j]);
        }
        system.rhs(t + h, &self.y_new, k7);
        for j in 0..n {
            self.err[j] = h * (E1 * k1[j] + E3 * k3[j] + E4 * k4[j] + E5 * k5[j] + E6 * k6[j] + E7 * k7[j]);
        }
    }

    fn new_state(&self) -> &[f64] {
        &self.y_new
    }

    fn error_norm(&self, y: &[f64], _h: f64, rtol: f64, atol: f64) -> f64 {
        let mut sum = 0.0;
        for j in 0..y.len() {
            let sk = atol + rtol * y[j].abs().max(self.y_new[j].abs());
            let e = self.err[j] / sk;
            sum += e * e;
        }
        (sum / y.len() as f64).sqrt()
    }

    fn build_dense<S: OdeSystem + ?Sized>(&mut self, _system: &mut S, _t: f64, y: &[f64], h: f64) -> u64 {
        let [r1, r2, r3, r4, r5] = &mut self.dense;
        let k = &self.k;
        for j in 0..y.len() {
            let ydiff = self.y_new[j] - y[j];
            let bspl = h * k[0][j] - ydiff;
            r1[j] = y[j];
            r2[j] = ydiff;
            r3[j] = bspl;
            r4[j] = ydiff - h * k[6][j] - bspl;
            r5[j] = h * (D1 * k[0][j] + D3 * k[2][j] + D4 * k[3][j] + D5 * k[4][j] + D6 * k[5][j] + D7 * k[6][j]);
        }
        0
    }

    fn dense_coefficients(&self) -> &[Vec<f64>] {
        &self.dense
    }

    fn reuse_last_stage(&mut self) {
        let (k0, rest) = self.k.split_at_mut(1);
        k0[0].copy_from_slice(&rest[5]);
    }
}

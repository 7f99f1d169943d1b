//! Dormand–Prince 5(4) with PI step control, dense output and mode-aware event location.
//!
//! Coefficients and the continuous extension follow Hairer, Nørsett & Wanner, *Solving Ordinary
//! Differential Equations I*, §II.5–II.6 (the DOPRI5 code's `contd5`).

use crate::{Dense, Observer, OdeError, OdeSystem, Stats, check_finite, output_count};

/// Options of the adaptive Dormand–Prince integrator.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Dopri5Options {
    /// Relative tolerance (per component, scaled by the larger of |y| at both step ends).
    pub rtol: f64,
    /// Absolute tolerance [state units: m, rad, m/s, rad/s].
    pub atol: f64,
    /// First step tried [s].
    #[serde(default = "default_initial_step")]
    pub initial_step: f64,
    /// Largest step allowed [s].
    #[serde(default = "default_max_step")]
    pub max_step: f64,
    /// Smallest step allowed before giving up [s]. A right side that jumps without an event (pure
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

impl Default for Dopri5Options {
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

/// Buffers of one run; allocated once.
struct Work {
    k: [Vec<f64>; 7],
    y_stage: Vec<f64>,
    y_new: Vec<f64>,
    err: Vec<f64>,
    dense: [Vec<f64>; 5],
    y_dense: Vec<f64>,
    y_event: Vec<f64>,
    g_start: Vec<f64>,
    g_end: Vec<f64>,
    g_probe: Vec<f64>,
}

impl Work {
    fn new(n: usize, m: usize) -> Self {
        let v = || vec![0.0; n];
        Self {
            k: [v(), v(), v(), v(), v(), v(), v()],
            y_stage: v(),
            y_new: v(),
            err: v(),
            dense: [v(), v(), v(), v(), v()],
            y_dense: v(),
            y_event: v(),
            g_start: vec![0.0; m],
            g_end: vec![0.0; m],
            g_probe: vec![0.0; m],
        }
    }

    /// Prepares the continuous extension of the step `(t, y) → (t + h, y_new)`.
    fn build_dense(&mut self, y: &[f64], h: f64) {
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
    }

    /// Dense output at fraction `theta` of the step into `y_dense`.
    fn interpolate(&mut self, theta: f64) {
        Dense { coefficients: &self.dense }.eval(theta, &mut self.y_dense);
    }
}

pub(crate) fn integrate<S: OdeSystem + ?Sized, O: Observer<S>>(
    system: &mut S,
    opt: &Dopri5Options,
    t0: f64,
    y: &mut [f64],
    t_end: f64,
    output_interval: f64,
    observer: &mut O,
) -> Result<Stats, OdeError> {
    for (name, v) in [("rtol", opt.rtol), ("atol", opt.atol), ("initial_step", opt.initial_step)] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(OdeError::Settings(format!("{name} must be > 0, got {v}")));
        }
    }
    if !(opt.max_step > 0.0) || !(opt.min_step > 0.0) || opt.min_step > opt.max_step {
        return Err(OdeError::Settings(format!(
            "need 0 < min_step ≤ max_step, got min_step {} and max_step {}",
            opt.min_step, opt.max_step
        )));
    }
    let n = system.dim();
    let m = system.event_count();
    let mut w = Work::new(n, m);
    let mut stats = Stats::default();
    let n_out = output_count(t0, t_end, output_interval);
    let mut next_out: u64 = 1;
    let out_time = |i: u64| (t0 + i as f64 * output_interval).min(t_end);

    check_finite(t0, y)?;
    observer.observe(system, t0, y).map_err(|message| OdeError::Observer { t: t0, message })?;
    let mut t = t0;
    let mut h = opt.initial_step.min(opt.max_step);
    let mut err_old: f64 = 1e-4;
    let mut need_k1 = true;
    system.events(t, y, &mut w.g_start);

    while t < t_end {
        if need_k1 {
            system.rhs(t, y, &mut w.k[0]);
            stats.rhs_evaluations += 1;
            need_k1 = false;
        }
        let last = t + h >= t_end || t_end - (t + h) < 1e-3 * h;
        if last {
            h = t_end - t;
        }
        if h < opt.min_step && !last {
            return Err(OdeError::StepSizeUnderflow { t, step: h });
        }
        system.take_mode_violation();
        stages(system, t, y, h, &mut w);
        stats.rhs_evaluations += 6;
        let violation = system.take_mode_violation();

        // Error norm.
        let mut sum = 0.0;
        for j in 0..n {
            let sk = opt.atol + opt.rtol * y[j].abs().max(w.y_new[j].abs());
            let e = w.err[j] / sk;
            sum += e * e;
        }
        let err = (sum / n as f64).sqrt();
        if !err.is_finite() || err > 1.0 {
            stats.rejected += 1;
            let fac = if err.is_finite() { (0.9 * err.powf(-0.2)).clamp(0.2, 1.0) } else { 0.1 };
            h *= fac;
            if h < opt.min_step {
                return Err(OdeError::StepSizeUnderflow { t, step: h });
            }
            continue;
        }

        // Mode check at the step end.
        let mut first_event: Option<usize> = None;
        if m > 0 {
            system.events(t + h, &w.y_new, &mut w.g_end);
            for k in 0..m {
                // Only a crossing from ≤ 0 to > 0 is an event; a function already positive at the
                // step start (a system that did not switch its mode) is ignored.
                if w.g_end[k] > 0.0 && w.g_start[k] <= 0.0 {
                    first_event = Some(k);
                }
            }
            if first_event.is_none() && violation {
                // A mode was left and re-entered inside the step: too coarse to see it.
                stats.rejected += 1;
                h *= 0.5;
                if h < opt.min_step {
                    return Err(OdeError::StepSizeUnderflow { t, step: h });
                }
                continue;
            }
        }

        w.build_dense(y, h);
        // PI step-size proposal for the next step (Hairer's DOPRI5 defaults).
        let fac11 = err.powf(0.2 - 0.04 * 0.75);
        let fac = (fac11 / err_old.powf(0.04) / 0.9).clamp(1.0 / 10.0, 1.0 / 0.2);
        let h_next = (h / fac).min(opt.max_step);
        err_old = err.max(1e-4);

        if first_event.is_some() {
            // Locate the earliest crossing among all events that fired.
            let (theta_event, k_event) = locate(system, t, h, &mut w, m);
            let h_event = theta_event * h;
            let t_event = t + h_event;
            w.interpolate(theta_event);
            w.y_event.copy_from_slice(&w.y_dense);
            // Step again, exactly to the event: none of the new stages lies beyond the switching
            // surface, so a right side that jumps there (Kelvin–Voigt onset, say) cannot leak
            // into the state at the event or the outputs before it.
            if h_event > 0.0 {
                stages(system, t, y, h_event, &mut w);
                stats.rhs_evaluations += 6;
                system.take_mode_violation();
                system.events(t_event, &w.y_new, &mut w.g_probe);
                if w.g_probe[k_event] > 0.0 && w.y_new.iter().all(|v| v.is_finite()) {
                    w.y_event.copy_from_slice(&w.y_new);
                }
                w.build_dense(y, h_event);
                emit_outputs(system, observer, &mut w, t, h_event, t_event, &mut next_out, n_out, &out_time)?;
                system.accept_dense(t, h_event, &Dense { coefficients: &w.dense });
            }
            y.copy_from_slice(&w.y_event);
            t = t_event;
            check_finite(t, y)?;
            system.on_event(k_event, t, y);
            stats.events += 1;
            stats.steps += 1;
            system.accept_step(t, y).map_err(|message| OdeError::System { t, message })?;
            system.events(t, y, &mut w.g_start);
            need_k1 = true;
            h = h_next.max(opt.min_step);
            continue;
        }

        emit_outputs(system, observer, &mut w, t, h, t + h, &mut next_out, n_out, &out_time)?;
        system.accept_dense(t, h, &Dense { coefficients: &w.dense });
        t = if last { t_end } else { t + h };
        y.copy_from_slice(&w.y_new);
        check_finite(t, y)?;
        let (k0, rest) = w.k.split_at_mut(1);
        k0[0].copy_from_slice(&rest[5]);
        std::mem::swap(&mut w.g_start, &mut w.g_end);
        stats.steps += 1;
        system.accept_step(t, y).map_err(|message| OdeError::System { t, message })?;
        h = h_next;
    }
    Ok(stats)
}

/// The six new stages of a step, the 5th-order solution in `y_new` and the error in `err`.
fn stages<S: OdeSystem + ?Sized>(system: &mut S, t: f64, y: &[f64], h: f64, w: &mut Work) {
    let n = y.len();
    let [k1, k2, k3, k4, k5, k6, k7] = &mut w.k;
    let ys = &mut w.y_stage;
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
        w.y_new[j] = y[j] + h * (A71 * k1[j] + A73 * k3[j] + A74 * k4[j] + A75 * k5[j] + A76 * k6[j]);
    }
    system.rhs(t + h, &w.y_new, k7);
    for j in 0..n {
        w.err[j] = h * (E1 * k1[j] + E3 * k3[j] + E4 * k4[j] + E5 * k5[j] + E6 * k6[j] + E7 * k7[j]);
    }
}

/// Finds the earliest event crossing inside the step on the dense output. Returns the step
/// fraction just past the root (where the event function is already > 0) and the event index.
fn locate<S: OdeSystem + ?Sized>(system: &mut S, t: f64, h: f64, w: &mut Work, m: usize) -> (f64, usize) {
    let mut best = (1.0, 0usize);
    let mut found = false;
    for k in 0..m {
        if w.g_end[k] <= 0.0 || w.g_start[k] > 0.0 {
            continue;
        }
        // Bracket [a, b] with g(a) ≤ 0 < g(b); Illinois-modified regula falsi.
        let (mut a, mut ga) = (0.0f64, w.g_start[k]);
        let (mut b, mut gb) = (1.0f64, w.g_end[k]);
        let mut side = 0i8;
        // Root located to 1e-14 s (or to float resolution of the step fraction).
        let tol = (1e-14 / h).max(1e-15);
        for _ in 0..200 {
            if b - a <= tol {
                break;
            }
            let mut c = (a * gb - b * ga) / (gb - ga);
            if !(c > a && c < b) {
                c = 0.5 * (a + b);
            }
            w.interpolate(c);
            system.events(t + c * h, &w.y_dense, &mut w.g_probe);
            let gc = w.g_probe[k];
            if gc > 0.0 {
                b = c;
                gb = gc;
                if side == 1 {
                    ga *= 0.5;
                }
                side = 1;
            } else {
                a = c;
                ga = gc;
                if side == -1 {
                    gb *= 0.5;
                }
                side = -1;
            }
        }
        if !found || b < best.0 {
            best = (b, k);
            found = true;
        }
    }
    system.take_mode_violation();
    best
}

/// Calls the observer for every output time in `(t, t_stop]` using the dense output.
#[allow(clippy::too_many_arguments)]
fn emit_outputs<S: OdeSystem + ?Sized, O: Observer<S>>(
    system: &mut S,
    observer: &mut O,
    w: &mut Work,
    t: f64,
    h: f64,
    t_stop: f64,
    next_out: &mut u64,
    n_out: u64,
    out_time: &dyn Fn(u64) -> f64,
) -> Result<(), OdeError> {
    while *next_out < n_out {
        let to = out_time(*next_out);
        if to > t_stop {
            break;
        }
        let theta = ((to - t) / h).clamp(0.0, 1.0);
        w.interpolate(theta);
        let y_out = std::mem::take(&mut w.y_dense);
        let r = observer.observe(system, to, &y_out);
        w.y_dense = y_out;
        r.map_err(|message| OdeError::Observer { t: to, message })?;
        *next_out += 1;
    }
    Ok(())
}

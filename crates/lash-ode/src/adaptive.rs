//! The adaptive stepping loop shared by the embedded Runge–Kutta pairs (DOPRI5, DOP853): error
//! control, PI step-size proposal, dense output, mode-aware event location, outputs.
//!
//! A pair supplies its stages, its error norm and its continuous extension through [`Pair`]; the
//! loop is written once. Nothing is allocated inside it.

use crate::{Dense, Observer, OdeError, OdeSystem, Stats, check_finite, dopri5::AdaptiveOptions, output_count};

/// Step-size control constants of a pair (Hairer's DOPRI5 / DOP853 conventions).
pub(crate) struct Control {
    /// Exponent of the error in the accepted-step proposal (1/(q+1) − 0.75 β).
    pub accept_exponent: f64,
    /// PI (Lund stabilisation) exponent on the previous accepted error.
    pub beta: f64,
    /// Exponent of the error in the rejected-step shrink.
    pub reject_exponent: f64,
    /// Largest shrink factor of an accepted-step proposal (h_new ≥ h / shrink).
    pub shrink: f64,
    /// Largest growth factor (h_new ≤ grow · h).
    pub grow: f64,
    /// Smallest factor applied to a rejected step.
    pub reject_floor: f64,
}

/// An embedded Runge–Kutta pair with a continuous extension.
pub(crate) trait Pair {
    /// Step-size control constants.
    const CONTROL: Control;
    /// Right-hand sides evaluated by [`Pair::step`].
    const STAGE_EVALUATIONS: u64;
    /// True if [`Pair::build_dense`] evaluates nothing (then it is built on every step).
    const DENSE_IS_FREE: bool = true;

    /// Buffers for an n-dimensional system.
    fn new(n: usize) -> Self;
    /// The slot of f(t, y) at the step start (filled by the loop or by [`Pair::reuse_last_stage`]).
    fn derivative_at_start(&mut self) -> &mut [f64];
    /// Evaluates the stages of a step of size h from (t, y): new state and error estimate.
    fn step<S: OdeSystem + ?Sized>(&mut self, system: &mut S, t: f64, y: &[f64], h: f64);
    /// Completes an accepted step (f at its end when the pair needs it); returns evaluations spent.
    fn finish<S: OdeSystem + ?Sized>(&mut self, _system: &mut S, _t: f64, _h: f64) -> u64 {
        0
    }
    /// The solution at the end of the last [`Pair::step`].
    fn new_state(&self) -> &[f64];
    /// Scaled RMS error norm of the last step (≤ 1: accept).
    fn error_norm(&self, y: &[f64], h: f64, rtol: f64, atol: f64) -> f64;
    /// Builds the continuous extension of the finished step; returns evaluations spent.
    fn build_dense<S: OdeSystem + ?Sized>(&mut self, system: &mut S, t: f64, y: &[f64], h: f64) -> u64;
    /// Coefficient vectors of the continuous extension (see [`Dense`]).
    fn dense_coefficients(&self) -> &[Vec<f64>];
    /// Moves f at the end of the finished step into the start slot (first same as last).
    fn reuse_last_stage(&mut self);
}

/// Loop buffers besides the pair's own.
struct Work<P> {
    pair: P,
    y_dense: Vec<f64>,
    y_event: Vec<f64>,
    g_start: Vec<f64>,
    g_end: Vec<f64>,
    g_probe: Vec<f64>,
}

impl<P: Pair> Work<P> {
    fn interpolate(&mut self, theta: f64) {
        Dense { coefficients: self.pair.dense_coefficients() }.eval(theta, &mut self.y_dense);
    }
}

pub(crate) fn integrate<P: Pair, S: OdeSystem + ?Sized, O: Observer<S>>(
    system: &mut S,
    opt: &AdaptiveOptions,
    y: &mut [f64],
    (t0, t_end, output_interval, first_step): (f64, f64, f64, Option<f64>),
    observer: &mut O,
) -> Result<Stats, OdeError> {
    check_options(opt)?;
    let ctl = P::CONTROL;
    let n = system.dim();
    let m = system.event_count();
    let mut w = Work {
        pair: P::new(n),
        y_dense: vec![0.0; n],
        y_event: vec![0.0; n],
        g_start: vec![0.0; m],
        g_end: vec![0.0; m],
        g_probe: vec![0.0; m],
    };
    let mut stats = Stats::default();
    let n_out = output_count(t0, t_end, output_interval);
    let mut next_out: u64 = 1;
    let out_time = |i: u64| (t0 + i as f64 * output_interval).min(t_end);

    check_finite(t0, y)?;
    observer.observe(system, t0, y).map_err(|source| OdeError::Observer { t: t0, source })?;
    let mut t = t0;
    let mut h = first_step.filter(|h| *h > 0.0 && h.is_finite()).unwrap_or(opt.initial_step).min(opt.max_step);
    let mut err_old: f64 = 1e-4;
    let mut need_k1 = true;
    system.events(t, y, &mut w.g_start);

    while t < t_end {
        if need_k1 {
            system.rhs(t, y, w.pair.derivative_at_start());
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
        w.pair.step(system, t, y, h);
        stats.rhs_evaluations += P::STAGE_EVALUATIONS;
        let violation = system.take_mode_violation();

        let err = w.pair.error_norm(y, h, opt.rtol, opt.atol);
        if !err.is_finite() || err > 1.0 {
            stats.rejected += 1;
            let fac =
                if err.is_finite() { (0.9 * err.powf(-ctl.reject_exponent)).clamp(ctl.reject_floor, 1.0) } else { 0.1 };
            h *= fac;
            if h < opt.min_step {
                return Err(OdeError::StepSizeUnderflow { t, step: h });
            }
            continue;
        }

        // Mode check at the step end.
        let mut first_event: Option<usize> = None;
        if m > 0 {
            system.events(t + h, w.pair.new_state(), &mut w.g_end);
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

        // PI step-size proposal for the next step.
        let fac11 = err.powf(ctl.accept_exponent);
        let fac = (fac11 / err_old.powf(ctl.beta) / 0.9).clamp(1.0 / ctl.grow, ctl.shrink);
        let h_next = (h / fac).min(opt.max_step);
        err_old = err.max(1e-4);

        if first_event.is_some() {
            let outputs = (&mut next_out, n_out, &out_time as &dyn Fn(u64) -> f64);
            t = step_to_event(system, observer, &mut w, &mut stats, (t, h), y, outputs)?;
            stats.steps += 1;
            system.accept_step(t, y).map_err(|source| OdeError::System { t, source })?;
            system.events(t, y, &mut w.g_start);
            need_k1 = true;
            // The right side changed its form at the event (contact force on or off): the proposal
            // of the step before says little about the new mode, so restart from the initial step.
            h = h_next.min(opt.initial_step).max(opt.min_step);
            continue;
        }

        stats.rhs_evaluations += w.pair.finish(system, t, h);
        let t_stop = if last { t_end } else { t + h };
        let output_due = next_out < n_out && out_time(next_out) <= t_stop;
        let wants_dense = system.wants_dense();
        if P::DENSE_IS_FREE || output_due || wants_dense {
            stats.rhs_evaluations += w.pair.build_dense(system, t, y, h);
            system.take_mode_violation();
            emit_outputs(system, observer, &mut w, t, h, t_stop, &mut next_out, n_out, &out_time)?;
            if wants_dense {
                system.accept_dense(t, h, &Dense { coefficients: w.pair.dense_coefficients() });
            }
        }
        t = t_stop;
        y.copy_from_slice(w.pair.new_state());
        check_finite(t, y)?;
        w.pair.reuse_last_stage();
        std::mem::swap(&mut w.g_start, &mut w.g_end);
        stats.steps += 1;
        system.accept_step(t, y).map_err(|source| OdeError::System { t, source })?;
        // The last step was cut to reach t_end: continue with the size it proposed before the cut.
        stats.next_step = if last { stats.next_step.max(h_next) } else { h_next };
        h = h_next;
    }
    Ok(stats)
}

/// The step from `t` over `h` in which an event fired, made again up to the earliest crossing
/// (located on its dense output): the outputs before it emitted, the state at the event in `y`,
/// the system switched there (with every other function already past its root). Returns the
/// event's time.
#[allow(clippy::type_complexity)]
fn step_to_event<P: Pair, S: OdeSystem + ?Sized, O: Observer<S>>(
    system: &mut S,
    observer: &mut O,
    w: &mut Work<P>,
    stats: &mut Stats,
    (t, h): (f64, f64),
    y: &mut [f64],
    (next_out, n_out, out_time): (&mut u64, u64, &dyn Fn(u64) -> f64),
) -> Result<f64, OdeError> {
    let m = w.g_start.len();
    stats.rhs_evaluations += w.pair.finish(system, t, h);
    stats.rhs_evaluations += w.pair.build_dense(system, t, y, h);
    // Locate the earliest crossing among all events that fired.
    let (theta_event, k_event) = locate(system, t, h, w, m);
    let h_event = theta_event * h;
    let t_event = t + h_event;
    w.interpolate(theta_event);
    w.y_event.copy_from_slice(&w.y_dense);
    // Step again, exactly to the event: none of the new stages lies beyond the switching
    // surface, so a right side that jumps there (Kelvin–Voigt onset, say) cannot leak
    // into the state at the event or the outputs before it.
    if h_event > 0.0 {
        w.pair.step(system, t, y, h_event);
        stats.rhs_evaluations += P::STAGE_EVALUATIONS;
        system.take_mode_violation();
        system.events(t_event, w.pair.new_state(), &mut w.g_probe);
        if w.g_probe[k_event] > 0.0 && w.pair.new_state().iter().all(|v| v.is_finite()) {
            w.y_event.copy_from_slice(w.pair.new_state());
        }
        stats.rhs_evaluations += w.pair.finish(system, t, h_event);
        stats.rhs_evaluations += w.pair.build_dense(system, t, y, h_event);
        system.take_mode_violation();
        emit_outputs(system, observer, w, t, h_event, t_event, next_out, n_out, out_time)?;
        if system.wants_dense() {
            system.accept_dense(t, h_event, &Dense { coefficients: w.pair.dense_coefficients() });
        }
    }
    y.copy_from_slice(&w.y_event);
    check_finite(t_event, y)?;
    system.on_event(k_event, t_event, y);
    stats.events += 1;
    // Events that fire at the same instant (a block landing flat on two corners): every
    // function already past its root at the event switches there too, or its mode would
    // be left from the next step's first stage on.
    system.events(t_event, y, &mut w.g_start);
    for k in (0..m).filter(|&k| k != k_event) {
        if w.g_start[k] > 0.0 {
            system.on_event(k, t_event, y);
            stats.events += 1;
        }
    }
    Ok(t_event)
}

/// The options' checks: tolerances and the initial step positive, 0 < min_step ≤ max_step.
fn check_options(opt: &AdaptiveOptions) -> Result<(), OdeError> {
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
    Ok(())
}

/// Finds the earliest event crossing inside the step on the dense output. Returns the step
/// fraction just past the root (where the event function is already > 0) and the event index.
fn locate<P: Pair, S: OdeSystem + ?Sized>(system: &mut S, t: f64, h: f64, w: &mut Work<P>, m: usize) -> (f64, usize) {
    let mut best = (1.0, 0usize);
    let mut found = false;
    for k in 0..m {
        if w.g_end[k] <= 0.0 || w.g_start[k] > 0.0 {
            continue;
        }
        // Bracket [a, b] with g(a) ≤ 0 < g(b) in the step fraction.
        let mut bracket = crate::root::Bracket::new(0.0, w.g_start[k], 1.0, w.g_end[k]);
        // Root located to 1e-14 s (or to float resolution of the step fraction).
        let tol = (1e-14 / h).max(1e-15);
        for _ in 0..200 {
            if bracket.b - bracket.a <= tol {
                break;
            }
            let c = bracket.next();
            w.interpolate(c);
            system.events(t + c * h, &w.y_dense, &mut w.g_probe);
            bracket.update(c, w.g_probe[k]);
        }
        let b = bracket.b;
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
fn emit_outputs<P: Pair, S: OdeSystem + ?Sized, O: Observer<S>>(
    system: &mut S,
    observer: &mut O,
    w: &mut Work<P>,
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
        r.map_err(|source| OdeError::Observer { t: to, source })?;
        *next_out += 1;
    }
    Ok(())
}

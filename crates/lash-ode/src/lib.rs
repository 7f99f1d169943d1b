//! ODE integrators for lash's stiff-impact problems.
//!
//! * [`Method::Rk4`]: classical fixed-step Runge–Kutta, events detected at step ends.
//! * [`Method::Dopri5`]: Dormand–Prince 5(4) with PI step-size control, Hairer's 4th-order dense
//!   output, and **mode-aware event location**: a system describes its discrete mode (a contact
//!   open or closed) by event functions `g_k(t, y)` that are ≤ 0 while the mode is valid. A step
//!   that ends with some `g_k > 0` is cut at the located root; a step whose stages left the mode
//!   although its end did not is rejected and halved, so a whole impact can never hide inside one
//!   step.
//!
//! Nothing is allocated inside the stepping loop: all buffers are created once per run.
//! Why not an existing crate: the crates that offer DOPRI5 (ode_solvers, russell_ode, diffsol)
//! either allocate per step or lack the mode-aware root finding with stage guard that contact
//! onset needs (capturing the approach velocity at the located onset).

pub use lash_core::BoxError;
mod adaptive;
mod dop853;
mod dopri5;
mod rk4;
pub mod root;

/// The continuous extension of one accepted step `[t, t + h]` (4th order for DOPRI5, 7th for
/// DOP853), in Hairer's nested form y(θ) = r₀ + θ(r₁ + (1−θ)(r₂ + θ(r₃ + (1−θ)(r₄ + …)))).
pub struct Dense<'a> {
    coefficients: &'a [Vec<f64>],
}

impl Dense<'_> {
    /// The state at `t + theta·h`, `theta` in [0, 1], written into `out`.
    pub fn eval(&self, theta: f64, out: &mut [f64]) {
        let th1 = 1.0 - theta;
        match self.coefficients {
            [r0, r1, r2, r3, r4] => {
                for (j, o) in out.iter_mut().enumerate().take(r0.len()) {
                    *o = r0[j] + theta * (r1[j] + th1 * (r2[j] + theta * (r3[j] + th1 * r4[j])));
                }
            }
            [r0, r1, r2, r3, r4, r5, r6, r7] => {
                for (j, o) in out.iter_mut().enumerate().take(r0.len()) {
                    let inner = r4[j] + theta * (r5[j] + th1 * (r6[j] + theta * r7[j]));
                    *o = r0[j] + theta * (r1[j] + th1 * (r2[j] + theta * (r3[j] + th1 * inner)));
                }
            }
            r => {
                let last = r.len() - 1;
                for (j, o) in out.iter_mut().enumerate().take(r[0].len()) {
                    let mut acc = r[last][j];
                    for i in (0..last).rev() {
                        acc = r[i][j] + if i % 2 == 0 { theta } else { th1 } * acc;
                    }
                    *o = acc;
                }
            }
        }
    }
}

pub use dopri5::AdaptiveOptions;

/// A first-order system y' = f(t, y) with optional discrete modes and events.
pub trait OdeSystem {
    /// Number of state components.
    fn dim(&self) -> usize;

    /// Evaluates `dydt = f(t, y)`.
    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]);

    /// Called once before an integration starts. `locates_events` is true for the adaptive
    /// methods, which locate every event root and cut the step there, so a right side may stay
    /// in its current mode (smooth within the mode, the error control undisturbed by the
    /// switching surface); false for fixed-step RK4, which only sees events at step ends, so its
    /// stages must feel a switch inside the step.
    fn begin(&mut self, _locates_events: bool) {}

    /// Number of event functions.
    fn event_count(&self) -> usize {
        0
    }

    /// Evaluates the event functions; the current mode is valid while every `g[k] ≤ 0`.
    fn events(&mut self, _t: f64, _y: &[f64], _g: &mut [f64]) {}

    /// Event `k` fired at `(t, y)` (its function crossed from ≤ 0 to > 0): switch the mode.
    fn on_event(&mut self, _k: usize, _t: f64, _y: &[f64]) {}

    /// True if any [`OdeSystem::rhs`] call since the last call of this method saw a state outside
    /// the current mode. Reading resets the flag.
    fn take_mode_violation(&mut self) -> bool {
        false
    }

    /// Whether the next accepted step should be handed to [`OdeSystem::accept_dense`]. DOP853 spends
    /// three extra evaluations on a continuous extension, so a system that samples inside steps
    /// only sometimes (while a contact is open) says so here.
    fn wants_dense(&self) -> bool {
        true
    }

    /// Called after accepted adaptive steps (those for which [`OdeSystem::wants_dense`] is true)
    /// with the step's continuous extension, before [`OdeSystem::accept_step`]: a place to sample
    /// the trajectory inside the step (a force peak).
    fn accept_dense(&mut self, _t: f64, _h: f64, _dense: &Dense<'_>) {}

    /// Called after every accepted step: a place to check for blow-up. An error stops the run.
    fn accept_step(&mut self, _t: f64, _y: &[f64]) -> Result<(), BoxError> {
        Ok(())
    }
}

/// Integration method and its parameters.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "method", rename_all = "snake_case", deny_unknown_fields)]
pub enum Method {
    /// Fixed-step classical Runge–Kutta 4.
    Rk4 {
        /// Step size \[s\].
        step: f64,
    },
    /// Error-controlled Dormand–Prince 5(4) with event location.
    Dopri5(AdaptiveOptions),
    /// Error-controlled Dormand–Prince 8(5,3) (Hairer's DOP853) with its 7th-order continuous
    /// extension and the same event location: fewer steps than DOPRI5 at tight tolerances.
    Dop853(AdaptiveOptions),
}

/// Counters of one integration.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct Stats {
    /// Accepted steps (a step cut at an event counts once).
    pub steps: u64,
    /// Rejected step attempts (error too large, or a mode left inside the step).
    pub rejected: u64,
    /// Right-hand-side evaluations by the integrator (observer evaluations not counted).
    pub rhs_evaluations: u64,
    /// Events handled.
    pub events: u64,
    /// Adaptive methods: the step size proposed for going on past the end (to continue the
    /// integration with [`integrate_from`]); 0 for RK4.
    pub next_step: f64,
}

impl Stats {
    /// Adds the counters of `other` (one more integration of the same system) to these; the
    /// proposed step stays (it belongs to the integration that ended last).
    pub fn add(&mut self, other: &Stats) {
        self.steps += other.steps;
        self.rejected += other.rejected;
        self.rhs_evaluations += other.rhs_evaluations;
        self.events += other.events;
    }
}

/// Why an integration stopped early.
#[derive(Debug, thiserror::Error)]
pub enum OdeError {
    /// The adaptive step fell below its minimum.
    #[error("step size {step:e} s fell below the minimum at t = {t} s")]
    StepSizeUnderflow {
        /// Time reached.
        t: f64,
        /// Step that was too small.
        step: f64,
    },
    /// The state became NaN or infinite.
    #[error("state component {index} became {value} at t = {t} s")]
    NonFinite {
        /// Time of the step that produced it.
        t: f64,
        /// Index of the component.
        index: usize,
        /// The value.
        value: f64,
    },
    /// The system refused an accepted step (blow-up check).
    #[error("the system stopped the run at t = {t} s")]
    System {
        /// Time of the step.
        t: f64,
        /// What the system said.
        source: BoxError,
    },
    /// The observer asked to stop.
    #[error("output failed at t = {t} s")]
    Observer {
        /// Time of the sample.
        t: f64,
        /// What the observer said.
        source: BoxError,
    },
    /// The settings do not fit (e.g. output interval not a multiple of the fixed step).
    #[error("integrator settings: {0}")]
    Settings(String),
}

/// An observer receives the system and the state at each output time.
pub trait Observer<S: ?Sized> {
    /// Records the state `y` at time `t`.
    fn observe(&mut self, system: &mut S, t: f64, y: &[f64]) -> Result<(), BoxError>;
}

impl<S: ?Sized, F: FnMut(&mut S, f64, &[f64]) -> Result<(), BoxError>> Observer<S> for F {
    fn observe(&mut self, system: &mut S, t: f64, y: &[f64]) -> Result<(), BoxError> {
        self(system, t, y)
    }
}

/// Integrates `system` from `(t0, y0)` to `t_end`, calling `observer` at `t0 + k·output_interval`.
///
/// `y0` is overwritten with the final state.
pub fn integrate<S: OdeSystem + ?Sized, O: Observer<S>>(
    method: &Method,
    system: &mut S,
    t0: f64,
    y0: &mut [f64],
    t_end: f64,
    output_interval: f64,
    observer: &mut O,
) -> Result<Stats, OdeError> {
    integrate_from(method, system, t0, y0, t_end, output_interval, observer, None)
}

/// [`integrate`], with the adaptive methods' first step given (`Some(stats.next_step)` of the
/// integration that ended at `t0` continues it without the start-up from `initial_step`). Used by
/// a subsystem that integrates one communication step at a time.
#[allow(clippy::too_many_arguments)]
pub fn integrate_from<S: OdeSystem + ?Sized, O: Observer<S>>(
    method: &Method,
    system: &mut S,
    t0: f64,
    y0: &mut [f64],
    t_end: f64,
    output_interval: f64,
    observer: &mut O,
    first_step: Option<f64>,
) -> Result<Stats, OdeError> {
    if !(output_interval > 0.0 && output_interval.is_finite()) {
        return Err(OdeError::Settings(format!("output interval must be > 0, got {output_interval}")));
    }
    if !(t_end > t0) {
        return Err(OdeError::Settings(format!("end time {t_end} must exceed start time {t0}")));
    }
    system.begin(!matches!(method, Method::Rk4 { .. }));
    let span = (t0, t_end, output_interval, first_step);
    match method {
        Method::Rk4 { step } => rk4::integrate(system, *step, t0, y0, t_end, output_interval, observer),
        Method::Dopri5(options) => adaptive::integrate::<dopri5::Dopri5, _, _>(system, options, y0, span, observer),
        Method::Dop853(options) => adaptive::integrate::<dop853::Dop853, _, _>(system, options, y0, span, observer),
    }
}

/// Number of output samples in `[t0, t_end]` at `interval` (both ends included when they fit).
pub(crate) fn output_count(t0: f64, t_end: f64, interval: f64) -> u64 {
    ((t_end - t0) / interval * (1.0 + 1e-12)).floor() as u64 + 1
}

pub(crate) fn check_finite(t: f64, y: &[f64]) -> Result<(), OdeError> {
    match y.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(OdeError::NonFinite { t, index, value: y[index] }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests;

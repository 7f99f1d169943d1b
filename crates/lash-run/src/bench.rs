//! Shared pieces of the benchmarks (criterion benches and `lash bench`).

use lash_full_model::FullModel;
use lash_ode::OdeSystem;

/// Fixed-step classical RK4 on the full model with preallocated stage buffers, restarted from the
/// initial state every 3.6 ms so that the steps sample free flight and impacts alike. It runs the
/// same arithmetic as `lash_ode`'s RK4 loop, contact mode switches at step ends included, without
/// its output bookkeeping.
pub struct Rk4Stepper<'a> {
    model: &'a mut FullModel,
    h: f64,
    t: f64,
    y0: Vec<f64>,
    y: Vec<f64>,
    k: [Vec<f64>; 4],
    tmp: Vec<f64>,
    g: Vec<f64>,
}

impl<'a> Rk4Stepper<'a> {
    /// A stepper of step `h` from the model's initial state.
    pub fn new(model: &'a mut FullModel, h: f64) -> Self {
        let y0 = model.initial_state(0.0).expect("initial state");
        let n = y0.len();
        let g = vec![0.0; model.event_count()];
        Self { model, h, t: 0.0, y: y0.clone(), y0, k: std::array::from_fn(|_| vec![0.0; n]), tmp: vec![0.0; n], g }
    }

    /// One RK4 step; returns the new time.
    pub fn step(&mut self) -> f64 {
        if self.t >= 3.6e-3 {
            self.t = 0.0;
            self.y.copy_from_slice(&self.y0);
            self.model.reset(0.0, &self.y0);
        }
        let (h, t, n) = (self.h, self.t, self.y.len());
        let [k1, k2, k3, k4] = &mut self.k;
        self.model.rhs(t, &self.y, k1);
        for j in 0..n {
            self.tmp[j] = self.y[j] + 0.5 * h * k1[j];
        }
        self.model.rhs(t + 0.5 * h, &self.tmp, k2);
        for j in 0..n {
            self.tmp[j] = self.y[j] + 0.5 * h * k2[j];
        }
        self.model.rhs(t + 0.5 * h, &self.tmp, k3);
        for j in 0..n {
            self.tmp[j] = self.y[j] + h * k3[j];
        }
        self.model.rhs(t + h, &self.tmp, k4);
        for j in 0..n {
            self.y[j] += h / 6.0 * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j]);
        }
        self.t += h;
        self.model.events(self.t, &self.y, &mut self.g);
        for k in 0..self.g.len() {
            if self.g[k] > 0.0 {
                self.model.on_event(k, self.t, &self.y);
            }
        }
        self.t
    }
}

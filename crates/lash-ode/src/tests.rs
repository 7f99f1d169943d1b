use super::*;

/// x'' = -x, y = [x, v].
struct Oscillator;
impl OdeSystem for Oscillator {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&mut self, _t: f64, y: &[f64], d: &mut [f64]) {
        d[0] = y[1];
        d[1] = -y[0];
    }
}

fn final_error(method: Method, t_end: f64) -> f64 {
    let mut y = [1.0, 0.0];
    let mut samples = Vec::new();
    integrate(&method, &mut Oscillator, 0.0, &mut y, t_end, 0.5, &mut |_: &mut Oscillator, t: f64, y: &[f64]| {
        samples.push((t, y[0]));
        Ok(())
    })
    .unwrap();
    // Dense-output samples must also be accurate.
    let sample_err = samples.iter().map(|(t, x)| (x - t.cos()).abs()).fold(0.0, f64::max);
    (y[0] - t_end.cos()).abs().max((y[1] + t_end.sin()).abs()).max(sample_err)
}

#[test]
fn rk4_is_fourth_order() {
    let e1 = final_error(Method::Rk4 { step: 0.01 }, 10.0);
    let e2 = final_error(Method::Rk4 { step: 0.005 }, 10.0);
    let order = (e1 / e2).log2();
    assert!((order - 4.0).abs() < 0.1, "observed order {order}");
}

#[test]
fn dopri5_meets_tolerance_on_oscillator() {
    for rtol in [1e-6, 1e-9, 1e-11] {
        let opts = AdaptiveOptions { rtol, atol: rtol * 1e-2, ..Default::default() };
        let e = final_error(Method::Dopri5(opts), 10.0);
        assert!(e < 100.0 * rtol, "rtol {rtol}: error {e}");
    }
}

#[test]
fn dop853_meets_tolerance_with_fewer_evaluations_than_dopri5() {
    for rtol in [1e-6, 1e-9, 1e-11] {
        let opts = AdaptiveOptions { rtol, atol: rtol * 1e-2, max_step: 10.0, ..Default::default() };
        let e = final_error(Method::Dop853(opts), 10.0);
        assert!(e < 100.0 * rtol, "rtol {rtol}: error {e}");
    }
    // At a tight tolerance the 8th-order pair needs clearly fewer evaluations.
    let count = |method: Method| {
        let mut y = [1.0, 0.0];
        integrate(
            &method,
            &mut Oscillator,
            0.0,
            &mut y,
            10.0,
            10.0,
            &mut |_: &mut Oscillator, _: f64, _: &[f64]| Ok(()),
        )
        .unwrap()
        .rhs_evaluations
    };
    let opts = AdaptiveOptions { rtol: 1e-11, atol: 1e-13, max_step: 10.0, ..Default::default() };
    let (n5, n8) = (count(Method::Dopri5(opts)), count(Method::Dop853(opts)));
    assert!(2 * n8 < n5, "DOP853 {n8} evaluations vs DOPRI5 {n5}");
}

#[test]
fn dop853_dense_output_is_seventh_order() {
    // One step of size h over the oscillator, dense output at θ = 0.37 vs the exact solution:
    // the error must scale like h^8 (local error of a 7th-order continuous extension).
    let err = |h: f64| {
        let opts = AdaptiveOptions { rtol: 1.0, atol: 1.0, initial_step: h, max_step: h, min_step: 1e-12 };
        let mut y = [1.0, 0.0];
        let mut sample = f64::NAN;
        integrate(
            &Method::Dop853(opts),
            &mut Oscillator,
            0.0,
            &mut y,
            h,
            0.37 * h,
            &mut |_: &mut Oscillator, t: f64, y: &[f64]| {
                if sample.is_nan() && t > 0.0 {
                    sample = (y[0] - t.cos()).abs();
                }
                Ok(())
            },
        )
        .unwrap();
        sample
    };
    let (e1, e2) = (err(0.8), err(0.4));
    let order = (e1 / e2).log2();
    assert!(order > 7.5, "local order of the dense output {order} ({e1:e}, {e2:e})");
}

#[test]
fn rk4_rejects_non_multiple_output() {
    let mut y = [1.0, 0.0];
    let r = integrate(
        &Method::Rk4 { step: 0.3 },
        &mut Oscillator,
        0.0,
        &mut y,
        1.0,
        0.5,
        &mut |_: &mut Oscillator, _: f64, _: &[f64]| Ok(()),
    );
    assert!(matches!(r, Err(OdeError::Settings(_))));
}

/// A ball falling onto the ground at x = 0 and bouncing elastically: exact bounce times.
struct Ball {
    bounces: Vec<f64>,
    below: bool,
}
const GRAV: f64 = 9.81;
impl OdeSystem for Ball {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&mut self, _t: f64, _y: &[f64], d: &mut [f64]) {
        d[0] = _y[1];
        d[1] = -GRAV;
    }
    fn event_count(&self) -> usize {
        1
    }
    fn events(&mut self, _t: f64, y: &[f64], g: &mut [f64]) {
        g[0] = if self.below { y[0] } else { -y[0] };
    }
    fn on_event(&mut self, _k: usize, _t: f64, _y: &[f64]) {
        self.below = !self.below;
        self.bounces.push(_t);
    }
}

#[test]
fn adaptive_methods_locate_events_to_high_accuracy() {
    for method in [Method::Dopri5, Method::Dop853] {
        let opts = AdaptiveOptions { rtol: 1e-10, atol: 1e-12, max_step: 0.1, ..Default::default() };
        let mut ball = Ball { bounces: vec![], below: false };
        let mut y = [1.0, 0.0];
        integrate(&method(opts), &mut ball, 0.0, &mut y, 0.6, 0.1, &mut |_: &mut Ball, _: f64, _: &[f64]| Ok(()))
            .unwrap();
        let exact = (2.0 / GRAV).sqrt();
        assert_eq!(ball.bounces.len(), 1);
        assert!((ball.bounces[0] - exact).abs() < 1e-12, "{} vs {exact}", ball.bounces[0]);
    }
}

/// A stiff linear wall at x = 1 (k = 1e6, unit mass): the bounce lasts π/1000 s, far shorter than
/// the initial step tried. The integrator must see it, locate entry and exit, and conserve energy.
struct Wall {
    inside: bool,
    violation: bool,
    switches: Vec<f64>,
}
const WALL_K: f64 = 1.0e6;
impl OdeSystem for Wall {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&mut self, _t: f64, y: &[f64], d: &mut [f64]) {
        let pen = y[0] - 1.0;
        if (pen > 0.0) != self.inside {
            self.violation = true;
        }
        d[0] = y[1];
        d[1] = if pen > 0.0 { -WALL_K * pen } else { 0.0 };
    }
    fn event_count(&self) -> usize {
        1
    }
    fn events(&mut self, _t: f64, y: &[f64], g: &mut [f64]) {
        g[0] = if self.inside { 1.0 - y[0] } else { y[0] - 1.0 };
    }
    fn on_event(&mut self, _k: usize, t: f64, _y: &[f64]) {
        self.inside = !self.inside;
        self.switches.push(t);
    }
    fn take_mode_violation(&mut self) -> bool {
        std::mem::take(&mut self.violation)
    }
}

#[test]
fn adaptive_methods_never_step_over_a_contact() {
    for method in [Method::Dopri5, Method::Dop853] {
        let opts = AdaptiveOptions { rtol: 1e-10, atol: 1e-12, max_step: 0.7, initial_step: 0.7, ..Default::default() };
        let mut w = Wall { inside: false, violation: false, switches: vec![] };
        let mut y = [0.0, 1.0];
        integrate(&method(opts), &mut w, 0.0, &mut y, 2.0, 0.5, &mut |_: &mut Wall, _: f64, _: &[f64]| Ok(())).unwrap();
        assert_eq!(w.switches.len(), 2, "switches {:?}", w.switches);
        assert!((w.switches[0] - 1.0).abs() < 1e-9);
        let duration = w.switches[1] - w.switches[0];
        assert!((duration - std::f64::consts::PI / WALL_K.sqrt()).abs() < 1e-9, "duration {duration}");
        assert!((y[1] + 1.0).abs() < 1e-8, "exit velocity {}", y[1]);
        assert!((y[0] - (1.0 - (2.0 - w.switches[1]))).abs() < 1e-8);
    }
}

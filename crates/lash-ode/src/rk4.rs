//! Fixed-step classical Runge–Kutta 4 with events detected at step ends.

use crate::{Observer, OdeError, OdeSystem, Stats, check_finite};

/// Whole number `a / b` if `a` is (up to float noise) a multiple of `b`.
fn whole_ratio(a: f64, b: f64) -> Option<u64> {
    let r = a / b;
    let n = r.round();
    (n >= 1.0 && (r - n).abs() <= 1e-9 * n).then_some(n as u64)
}

pub(crate) fn integrate<S: OdeSystem + ?Sized, O: Observer<S>>(
    system: &mut S,
    step: f64,
    t0: f64,
    y: &mut [f64],
    t_end: f64,
    output_interval: f64,
    observer: &mut O,
) -> Result<Stats, OdeError> {
    if !(step > 0.0 && step.is_finite()) {
        return Err(OdeError::Settings(format!("RK4 step must be > 0, got {step}")));
    }
    let every = whole_ratio(output_interval, step).ok_or_else(|| {
        OdeError::Settings(format!(
            "output interval {output_interval} s is not a whole multiple of the RK4 step {step} s"
        ))
    })?;
    let n_steps = whole_ratio(t_end - t0, step).ok_or_else(|| {
        OdeError::Settings(format!("horizon {} s is not a whole multiple of the RK4 step {step} s", t_end - t0))
    })?;
    let n = system.dim();
    let m = system.event_count();
    let mut k1 = vec![0.0; n];
    let mut k2 = vec![0.0; n];
    let mut k3 = vec![0.0; n];
    let mut k4 = vec![0.0; n];
    let mut tmp = vec![0.0; n];
    let mut y_old = vec![0.0; n];
    let mut g_old = vec![0.0; m];
    let mut g_new = vec![0.0; m];
    let mut crossings: Vec<(f64, usize)> = Vec::with_capacity(m);
    let mut stats = Stats::default();

    check_finite(t0, y)?;
    system.events(t0, y, &mut g_old);
    observer.observe(system, t0, y).map_err(|source| OdeError::Observer { t: t0, source })?;
    for i in 0..n_steps {
        let t = t0 + i as f64 * step;
        let t_next = t0 + (i + 1) as f64 * step;
        let h = t_next - t;
        y_old.copy_from_slice(y);
        system.rhs(t, y, &mut k1);
        for j in 0..n {
            tmp[j] = y[j] + 0.5 * h * k1[j];
        }
        system.rhs(t + 0.5 * h, &tmp, &mut k2);
        for j in 0..n {
            tmp[j] = y[j] + 0.5 * h * k2[j];
        }
        system.rhs(t + 0.5 * h, &tmp, &mut k3);
        for j in 0..n {
            tmp[j] = y[j] + h * k3[j];
        }
        system.rhs(t_next, &tmp, &mut k4);
        for j in 0..n {
            y[j] += h / 6.0 * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j]);
        }
        stats.rhs_evaluations += 4;
        stats.steps += 1;
        system.take_mode_violation();
        check_finite(t_next, y)?;
        if m > 0 {
            system.events(t_next, y, &mut g_new);
            crossings.clear();
            for k in 0..m {
                if g_new[k] > 0.0 {
                    // Linear estimate of the crossing inside the step.
                    let denom = g_new[k] - g_old[k].min(0.0);
                    let frac = if denom > 0.0 { -g_old[k].min(0.0) / denom } else { 1.0 };
                    crossings.push((frac, k));
                }
            }
            if !crossings.is_empty() {
                crossings.sort_by(|a, b| a.0.total_cmp(&b.0));
                for &(frac, k) in &crossings {
                    for j in 0..n {
                        tmp[j] = y_old[j] + frac * (y[j] - y_old[j]);
                    }
                    system.on_event(k, t + frac * h, &tmp);
                    stats.events += 1;
                }
                system.events(t_next, y, &mut g_new);
            }
            std::mem::swap(&mut g_old, &mut g_new);
        }
        system.accept_step(t_next, y).map_err(|source| OdeError::System { t: t_next, source })?;
        if (i + 1) % every == 0 {
            observer.observe(system, t_next, y).map_err(|source| OdeError::Observer { t: t_next, source })?;
        }
    }
    Ok(stats)
}

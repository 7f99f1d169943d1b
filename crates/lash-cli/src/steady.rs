//! `lash compare`'s speed-ups, measured so that they do not move with the machine's load. Each
//! model's simulation alone (rows discarded, no output) is timed in rounds: in every round each
//! model runs once, a fast one several times over so that every model takes about the same wall
//! time in the round, and the models take turns. Whatever else the machine does then weighs on
//! all of them alike; a speed-up is the median over rounds of the round's ratio. Rounds continue
//! until they add up to [`BUDGET_S`] (at least [`MIN_ROUNDS`] while the next fits in three budgets).
//! A single reduced run of A's default horizon lasts about a millisecond, where a busy 2-core
//! machine moves one timing by a factor of several.

use lash_run::{AnyRunner, RunError};
use serde::Serialize;

/// Wall time the rounds add up to, at least \[s\].
pub const BUDGET_S: f64 = 1.0;
/// The fewest rounds, unless one more would end past three times [`BUDGET_S`].
pub const MIN_ROUNDS: usize = 3;
/// The most rounds.
pub const MAX_ROUNDS: usize = 50;

/// A model's timing over the rounds.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Timed {
    /// Median over the rounds of the wall time of one run, simulation alone \[s\].
    pub median_s: f64,
    /// Runs in the last round.
    pub runs_per_round: usize,
    /// Median over the rounds of this model's time over the first model's (the reference).
    pub ratio_to_first: f64,
}

/// Builds a runner of one model (each built outside the timing).
pub type Make<'a> = &'a mut dyn FnMut() -> Result<AnyRunner, RunError>;

/// Wall time of `runs` runs of `make`'s model, rows discarded \[s\].
fn run(make: &mut dyn FnMut() -> Result<AnyRunner, RunError>, runs: usize) -> Result<f64, RunError> {
    let mut total = 0.0;
    for _ in 0..runs {
        let mut runner = make()?;
        let clock = std::time::Instant::now();
        runner.execute(&mut |row| Ok(std::hint::black_box(row).len()).map(|_| ()), &mut |_| {})?;
        total += clock.elapsed().as_secs_f64();
    }
    Ok(total)
}

/// Times the models in rounds; returns each one's timing and the number of rounds.
pub fn time(makers: &mut [Make<'_>]) -> Result<(Vec<Timed>, usize), RunError> {
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    // How often each runs per round, as long as the slowest: from a run after a warm-up run
    // (the first run of a process pays for its page faults; a run of 50 ms or more is its own
    // warm-up), then from the rounds' medians.
    let per_run = |runs: &[f64]| -> Vec<usize> {
        let slowest = runs.iter().copied().fold(0.0, f64::max);
        runs.iter().map(|&t| ((slowest / t.max(1e-9)).round() as usize).clamp(1, 1000)).collect()
    };
    let mut first = Vec::new();
    for make in makers.iter_mut() {
        let once = run(*make, 1)?;
        first.push(if once < 0.05 { run(*make, 1)? } else { once });
    }
    let mut runs = per_run(&first);
    let mut per_round: Vec<Vec<f64>> = vec![Vec::new(); makers.len()];
    let mut total = 0.0;
    // Rounds until the budget is spent, and at least MIN_ROUNDS as long as one more round (as
    // long as the mean so far) ends within three budgets: long runs read steadier, and a
    // comparison of seconds-long runs should not take a minute.
    let more = |rounds: usize, total: f64| {
        let next_ends = total * (rounds + 1) as f64 / rounds.max(1) as f64;
        rounds < MAX_ROUNDS && (total < BUDGET_S || (rounds < MIN_ROUNDS && next_ends <= 3.0 * BUDGET_S))
    };
    while more(per_round[0].len(), total) {
        for (k, make) in makers.iter_mut().enumerate() {
            let t = run(*make, runs[k])?;
            total += t;
            per_round[k].push(t / runs[k] as f64);
        }
        runs = per_run(&per_round.iter().map(|v| median(v.clone())).collect::<Vec<_>>());
    }
    let rounds = per_round[0].len();
    let timed = per_round
        .iter()
        .zip(&runs)
        .map(|(times, &runs_per_round)| Timed {
            median_s: median(times.clone()),
            runs_per_round,
            ratio_to_first: median(times.iter().zip(&per_round[0]).map(|(t, t0)| t / t0).collect()),
        })
        .collect();
    Ok((timed, rounds))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rounds continue to the budget; a model ten times as long as another runs once per round
    /// where the other runs about ten times, and their ratio reads about ten.
    #[test]
    fn models_take_turns_for_equal_time() {
        let a = lash_scenario::builtin::by_name("A").unwrap();
        let reduced = |horizon: f64| {
            let mut s = a.clone();
            s.simulation.horizon = horizon;
            move || -> Result<AnyRunner, RunError> {
                Ok(AnyRunner::Reduced(Box::new(lash_run::ReducedRun::new(&s, lash_run::ReducedOptions::default())?)))
            }
        };
        let (mut short, mut long) = (reduced(0.002), reduced(0.02));
        let (timed, rounds) = time(&mut [&mut short, &mut long]).unwrap();
        assert!((MIN_ROUNDS..=MAX_ROUNDS).contains(&rounds), "{rounds}");
        assert_eq!(timed[1].runs_per_round, 1);
        assert!((4..=25).contains(&timed[0].runs_per_round), "{timed:?}");
        assert!((4.0..25.0).contains(&timed[1].ratio_to_first), "{timed:?}");
    }
}

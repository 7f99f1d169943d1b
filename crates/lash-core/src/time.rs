//! Exact simulation time as an integer count of picoseconds.
//!
//! Multirate schemes (a macro step of 1 ms, a micro step of 10 µs, an output interval of 10 µs)
//! need exact ratios: `0.009999999999999998 / 1e-5` must be 1000, not 999. Times and step sizes
//! given in seconds are converted once to [`Ticks`]; all step counting is done in integers.

use serde::{Deserialize, Serialize};

/// Ticks per second: one tick is one picosecond.
pub const TICKS_PER_SECOND: i64 = 1_000_000_000_000;

/// A time or a duration in picoseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct Ticks(pub i64);

/// Why a time in seconds cannot be represented exactly as [`Ticks`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TicksError {
    /// The value is NaN or infinite.
    #[error("{0} s is not a finite time")]
    NotFinite(f64),
    /// The value is outside the ±106 days that 64-bit picoseconds cover.
    #[error("{0} s is outside the representable range")]
    OutOfRange(f64),
    /// The value is not a whole number of picoseconds (beyond float rounding noise).
    #[error("{0} s is not a whole number of picoseconds")]
    NotWholePicoseconds(f64),
}

impl Ticks {
    /// Zero time.
    pub const ZERO: Ticks = Ticks(0);

    /// Converts seconds to ticks, absorbing float noise (relative 1e-9) but rejecting times that
    /// are not whole picoseconds.
    pub fn from_seconds(seconds: f64) -> Result<Ticks, TicksError> {
        if !seconds.is_finite() {
            return Err(TicksError::NotFinite(seconds));
        }
        let exact = seconds * TICKS_PER_SECOND as f64;
        if exact.abs() > 9.0e18 {
            return Err(TicksError::OutOfRange(seconds));
        }
        let rounded = exact.round();
        if (exact - rounded).abs() > 1e-9 * exact.abs().max(1.0) {
            return Err(TicksError::NotWholePicoseconds(seconds));
        }
        Ok(Ticks(rounded as i64))
    }

    /// This time in seconds.
    pub fn seconds(self) -> f64 {
        self.0 as f64 / TICKS_PER_SECOND as f64
    }

    /// How many whole `step`s fit in `self`, if it is an exact multiple.
    pub fn exact_ratio(self, step: Ticks) -> Option<i64> {
        if step.0 <= 0 || self.0 % step.0 != 0 { None } else { Some(self.0 / step.0) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_noise_does_not_change_step_counts() {
        let macro_step = Ticks::from_seconds(0.009999999999999998).unwrap();
        let micro_step = Ticks::from_seconds(1e-5).unwrap();
        assert_eq!(macro_step, Ticks(10_000_000_000));
        assert_eq!(macro_step.exact_ratio(micro_step), Some(1000));
        assert_eq!(Ticks::from_seconds(0.036).unwrap().exact_ratio(micro_step), Some(3600));
    }

    #[test]
    fn rejects_bad_times() {
        assert!(matches!(Ticks::from_seconds(f64::NAN), Err(TicksError::NotFinite(_))));
        assert!(matches!(Ticks::from_seconds(1e-13), Err(TicksError::NotWholePicoseconds(_))));
        assert!(matches!(Ticks::from_seconds(1e8), Err(TicksError::OutOfRange(_))));
        assert_eq!(Ticks::from_seconds(3e-5).unwrap().exact_ratio(Ticks(20_000_000)), None);
    }
}

//! What observers record: signals, and the observer trait.

use super::*;

/// A quantity that observers can record.
#[derive(Debug, Clone, PartialEq)]
pub enum Signal {
    /// Element `element` of micro output `variable`, at every micro step.
    Micro {
        /// Signal name.
        name: String,
        /// Micro variable name.
        variable: String,
        /// Element index (row-major).
        element: usize,
    },
    /// Element of a macro output interpolated across the macro step: cubic Hermite when a
    /// derivative variable is given, linear otherwise.
    Macro {
        /// Signal name.
        name: String,
        /// Macro variable name.
        variable: String,
        /// Element index.
        element: usize,
        /// (variable, element) holding its time derivative.
        derivative: Option<(String, usize)>,
    },
    /// `free + Σ gain_c load_c` with the maps interpolated linearly and the loads the micro
    /// subsystem's contact forces (n) and friction loads (m) at the same instant.
    Propagated {
        /// Signal name.
        name: String,
        /// (variable, element) of the value at zero load.
        free: (String, usize),
        /// (variable, first element) of the n + m gains, one per load, in load order.
        gain: (String, usize),
    },
}

impl Signal {
    /// The signal's name.
    pub fn name(&self) -> &str {
        match self {
            Signal::Micro { name, .. } | Signal::Macro { name, .. } | Signal::Propagated { name, .. } => name,
        }
    }
}

/// Receives the requested signals at its interval.
pub trait Observer {
    /// Called with the time and the signal values (in the order the master was given them).
    fn observe(&mut self, t: Ticks, signals: &[f64]) -> Result<(), lash_core::BoxError>;
}

impl<F: FnMut(Ticks, &[f64]) -> Result<(), lash_core::BoxError>> Observer for F {
    fn observe(&mut self, t: Ticks, signals: &[f64]) -> Result<(), lash_core::BoxError> {
        self(t, signals)
    }
}

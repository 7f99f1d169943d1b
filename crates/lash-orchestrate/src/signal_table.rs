//! The signals' node values laid out for the evaluation at every sample.

use super::*;

/// The signals grouped by kind, with the node values of the current macro step laid out for the
/// evaluation at every sample ([`SignalTable::prepare`] once per macro step, then
/// [`SignalTable::fill`] per sample). Each value is computed with the same operations in the same
/// order as from the frames directly — a value at fraction s is `a + (b − a) s`, a propagated
/// signal `free(s) + Σ gain_c(s) L_c` over the loads that act, in load order — so the results are
/// bit for bit those of reading the frames; the layout only puts the propagated signals' gains of
/// one load side by side (one pass over the signals per acting load, which the compiler
/// vectorises) and takes the differences b − a once per macro step instead of once per sample.
pub(crate) struct SignalTable {
    /// (output position, micro output index).
    micro: Vec<(usize, usize)>,
    /// (output position, frame element of the value, frame element of its derivative).
    hermite: Vec<(usize, usize, usize)>,
    /// (output position, frame element).
    linear: Vec<(usize, usize)>,
    /// (output position, frame element of the free value, frame element of the first gain).
    propagated: Vec<(usize, usize, usize)>,
    /// Number of loads (contact forces, then friction loads).
    loads: usize,
    /// Macro step \[s\].
    step: f64,
    /// Per `hermite` entry: a, ȧ, b, ḃ of the current step.
    hermite_nodes: Vec<[f64; 4]>,
    /// Per `linear` entry: a, b − a.
    linear_nodes: Vec<[f64; 2]>,
    /// Free values at a and their differences b − a, per propagated signal.
    free: Vec<f64>,
    free_change: Vec<f64>,
    /// Gains at a and their differences, load-major: entry c P + p is load c of signal p.
    gain: Vec<f64>,
    gain_change: Vec<f64>,
    /// The propagated values being summed (one per propagated signal).
    sums: Vec<f64>,
}

/// [`SignalTable::fill_in`] compiled for the baseline, AVX2 and AVX-512 (`multiversion` detects the
/// CPU's features once and calls the widest copy): the same IEEE operations, so the same bits.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512vl+avx512dq", "x86_64+avx2"))]
pub(crate) fn fill_dispatched(table: &mut SignalTable, s: f64, loads: &[f64], micro: &[f64], out: &mut [f64]) {
    table.fill_in(s, loads, micro, out)
}

impl SignalTable {
    pub(crate) fn new(resolved: &[Resolved], loads: usize, step: f64) -> Self {
        let (mut micro, mut hermite, mut linear, mut propagated) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (at, r) in resolved.iter().enumerate() {
            match *r {
                Resolved::Micro(i) => micro.push((at, i)),
                Resolved::Macro { value, derivative: Some(d) } => hermite.push((at, value, d)),
                Resolved::Macro { value, derivative: None } => linear.push((at, value)),
                Resolved::Propagated { free, gain } => propagated.push((at, free, gain)),
            }
        }
        let p = propagated.len();
        Self {
            hermite_nodes: vec![[0.0; 4]; hermite.len()],
            linear_nodes: vec![[0.0; 2]; linear.len()],
            free: vec![0.0; p],
            free_change: vec![0.0; p],
            gain: vec![0.0; p * loads],
            gain_change: vec![0.0; p * loads],
            sums: vec![0.0; p],
            micro,
            hermite,
            linear,
            propagated,
            loads,
            step,
        }
    }

    /// Takes the node values of the macro step `w`.
    pub(crate) fn prepare(&mut self, w: &Window<'_>) {
        for (n, &(_, value, d)) in self.hermite_nodes.iter_mut().zip(&self.hermite) {
            *n = [w.a[value], w.a[d], w.b[value], w.b[d]];
        }
        for (n, &(_, value)) in self.linear_nodes.iter_mut().zip(&self.linear) {
            *n = [w.a[value], w.b[value] - w.a[value]];
        }
        let count = self.propagated.len();
        for (p, &(_, free, gain)) in self.propagated.iter().enumerate() {
            self.free[p] = w.a[free];
            self.free_change[p] = w.b[free] - w.a[free];
            for c in 0..self.loads {
                self.gain[c * count + p] = w.a[gain + c];
                self.gain_change[c * count + p] = w.b[gain + c] - w.a[gain + c];
            }
        }
    }

    /// Every signal at fraction `s` of the prepared macro step, from the loads (contact forces,
    /// then friction loads) and the micro outputs. With four propagated signals or more, compiled
    /// for the baseline, AVX2 and AVX-512 (the CPU's, detected once): the same IEEE operations in
    /// wider registers and no fused multiply–add, so the bits do not depend on the CPU (E with
    /// four channels: the fill 5.9 → 4.8 % of the run; with one signal, a sweep of A, the dispatch
    /// measured ~2 % slower, so fewer signals are filled in the baseline set).
    #[inline]
    pub(crate) fn fill(&mut self, s: f64, loads: &[f64], micro: &[f64], out: &mut [f64]) {
        if self.propagated.len() < 4 {
            return self.fill_in(s, loads, micro, out);
        }
        fill_dispatched(self, s, loads, micro, out)
    }

    /// [`SignalTable::fill`] in the instruction set it was dispatched to.
    #[inline(always)]
    fn fill_in(&mut self, s: f64, loads: &[f64], micro: &[f64], out: &mut [f64]) {
        for &(at, i) in &self.micro {
            out[at] = micro[i];
        }
        for (&(at, _, _), n) in self.hermite.iter().zip(&self.hermite_nodes) {
            out[at] = hermite(n[0], n[1], n[2], n[3], s, self.step).0;
        }
        for (&(at, _), n) in self.linear.iter().zip(&self.linear_nodes) {
            out[at] = n[0] + n[1] * s;
        }
        let count = self.propagated.len();
        if count == 0 {
            return;
        }
        if count >= 4 {
            return self.fill_propagated_by_fours(s, loads, out);
        }
        if count == 1 {
            // One signal (a sweep's one propagated channel): the same operations in the same
            // order as the loops below, without their bookkeeping.
            let mut sum = self.free[0] + self.free_change[0] * s;
            for (c, &load) in loads[..self.loads].iter().enumerate() {
                if load != 0.0 {
                    sum += (self.gain[c] + self.gain_change[c] * s) * load;
                }
            }
            out[self.propagated[0].0] = sum;
            return;
        }
        // Equal lengths, written out: the loops then compile to straight vector code.
        let sums = &mut self.sums[..count];
        let (free, free_change) = (&self.free[..count], &self.free_change[..count]);
        for p in 0..count {
            sums[p] = free[p] + free_change[p] * s;
        }
        // Loads that do not act (a joint in free flight) add nothing and are skipped.
        for (c, &load) in loads[..self.loads].iter().enumerate() {
            if load == 0.0 {
                continue;
            }
            let (a, d) = (&self.gain[c * count..(c + 1) * count], &self.gain_change[c * count..(c + 1) * count]);
            for p in 0..count {
                sums[p] += (a[p] + d[p] * s) * load;
            }
        }
        for (&(at, _, _), v) in self.propagated.iter().zip(&self.sums) {
            out[at] = *v;
        }
    }

    /// The propagated signals of [`SignalTable::fill_in`], four at a time in fixed-size arrays
    /// (one vector register each in AVX2), the rest one by one: each signal's sum takes the same
    /// operations in the same order as one by one, so the bits are the same. The loop over any
    /// count of signals spent ~1 100 instructions per sample on E's four channels and twelve
    /// loads (its bookkeeping, not its arithmetic).
    #[inline(always)]
    fn fill_propagated_by_fours(&mut self, s: f64, loads: &[f64], out: &mut [f64]) {
        let count = self.propagated.len();
        let (free, free_change) = (&self.free[..count], &self.free_change[..count]);
        let loads = &loads[..self.loads];
        let whole = count - count % 4;
        for first in (0..whole).step_by(4) {
            let mut sums: [f64; 4] = std::array::from_fn(|q| free[first + q] + free_change[first + q] * s);
            for (c, &load) in loads.iter().enumerate() {
                if load == 0.0 {
                    continue;
                }
                let at = c * count + first;
                let a: &[f64; 4] = self.gain[at..at + 4].try_into().expect("four gains");
                let d: &[f64; 4] = self.gain_change[at..at + 4].try_into().expect("four changes");
                for q in 0..4 {
                    sums[q] += (a[q] + d[q] * s) * load;
                }
            }
            self.sums[first..first + 4].copy_from_slice(&sums);
        }
        for p in whole..count {
            let mut sum = free[p] + free_change[p] * s;
            for (c, &load) in loads.iter().enumerate() {
                if load != 0.0 {
                    sum += (self.gain[c * count + p] + self.gain_change[c * count + p] * s) * load;
                }
            }
            self.sums[p] = sum;
        }
        for (&(at, _, _), v) in self.propagated.iter().zip(&self.sums) {
            out[at] = *v;
        }
    }
}

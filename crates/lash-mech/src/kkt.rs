//! The KKT system's kernels over [`Real`]: the Schur complement S = Φ_q M⁻¹ Φ_qᵀ from the rows,
//! the solve for q̈ and λ with a factor of S, and the Baumgarte-stabilised right side γ̂. One
//! source for the scalar [`crate::Solver`] (every full-model right-hand side, every macro step)
//! and the macro lanes ([`crate::lanes`], eight mechanisms side by side), so that each lane's
//! numbers are bit for bit its mechanism's.
//!
//! A constraint row is its two blocks (x, y, θ of each of its two bodies; a ground block is
//! zeros), read through a `row(a)` function; the pinned rows and S's structure are the
//! [`Structure`]'s. Coordinate-sized work vectors carry three padding entries (index n..n + 3,
//! always zero) that stand for the ground, so every row has exactly two blocks.

use crate::solver::Structure;
use lash_core::lane::Real;

/// One constraint row's Jacobian entries: ∂Φ/∂(x, y, θ) of its first body, then of its second.
pub(crate) type RowEntries<R> = [R; 6];

/// Φ_q v of one row whose blocks sit at coordinate offsets `[o0, o1]`.
#[inline(always)]
pub(crate) fn row_times<R: Real>(j: &RowEntries<R>, [o0, o1]: [usize; 2], v: &[R]) -> R {
    j[0] * v[o0] + j[1] * v[o0 + 1] + j[2] * v[o0 + 2] + j[3] * v[o1] + j[4] * v[o1 + 1] + j[5] * v[o1 + 2]
}

/// Adds S's structural entries (the pairs of blocks that share a body) of the rows to `s`, which
/// the caller has zeroed: S[a][b] += Σ over the shared body's coordinates of J_a M⁻¹ J_b.
/// `half(k)`: block k of the flattened rows (row k / 2, side k % 2); `inverse_mass`: M⁻¹ of the
/// free coordinates (pinned ones zero).
#[inline(always)]
pub(crate) fn add_schur<R: Real>(st: &Structure, half: impl Fn(usize) -> [R; 3], inverse_mass: &[R], s: &mut [R]) {
    for &(ja, jb, index, k) in &st.pairs {
        let (pa, pb) = (half(ja), half(jb));
        let w = &inverse_mass[k..k + 3];
        s[index] = s[index] + (pa[0] * pb[0] * w[0] + pa[1] * pb[1] * w[1] + pa[2] * pb[2] * w[2]);
    }
}

/// γ̂ = γ − 2α(Φ_q q̇ − ν) − β²Φ, row by row, into `gamma_hat`; `v` the velocities, padded.
#[inline(always)]
pub(crate) fn stabilised_gamma<R: Real>(
    st: &Structure,
    row: impl Fn(usize) -> RowEntries<R>,
    v: &[R],
    (gamma, nu, phi): (&[R], &[R], &[R]),
    (alpha, beta): (R, R),
    gamma_hat: &mut [R],
) {
    for (a, offsets) in st.offsets.iter().enumerate() {
        let jqd = row_times(&row(a), *offsets, v);
        gamma_hat[a] = gamma[a] - R::splat(2.0) * alpha * (jqd - nu[a]) - beta * beta * phi[a];
    }
}

/// Work vectors of one solve: M⁻¹Q and the pinned accelerations, Φ_qᵀλ (both padded), and the
/// free rows' multipliers.
pub(crate) struct Work<'a, R> {
    pub acc: &'a mut [R],
    pub reaction: &'a mut [R],
    pub lam: &'a mut [R],
}

/// The KKT solve for q̈ (into `qdd`) under the load `forces` (None: zero) and the right side
/// `gamma`, with `solve_schur` solving S x = b in place by the current factor. With `lambda`,
/// the multipliers too: the free rows' from S, the pinned rows' from their coordinates'
/// equations of motion, c λ = Q_k − m_k q̈_k − (Φ_qᵀλ)_k (with the full M⁻¹ given; 1/c = c).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve<R: Real>(
    st: &Structure,
    row: impl Fn(usize) -> RowEntries<R>,
    inverse_mass: &[R],
    (forces, gamma): (Option<&[R]>, &[R]),
    work: Work<'_, R>,
    solve_schur: impl FnOnce(&mut [R]),
    qdd: &mut [R],
    lambda: Option<(&mut [R], &[R])>,
) {
    let Work { acc, reaction, lam } = work;
    let n = qdd.len();
    let zero = R::splat(0.0);
    let im = &inverse_mass[..n];
    // acc = M⁻¹Q on free coordinates and the pinned accelerations γ/c (c = ±1).
    for k in 0..n {
        acc[k] = im[k] * forces.map_or(zero, |f| f[k]);
    }
    for &(r, k, c) in &st.fixed {
        acc[k] = gamma[r] * R::splat(c);
    }
    // λ' = S⁻¹ (Φ_q acc − γ) over the free rows.
    for (a, &r) in st.free_rows.iter().enumerate() {
        lam[a] = row_times(&row(r), st.offsets[r], acc) - gamma[r];
    }
    solve_schur(lam);
    // reaction = Φ_qᵀλ over the free rows; q̈ = acc − M⁻¹ reaction (pinned: M⁻¹ entry is 0).
    reaction[..n + 3].fill(zero);
    for (a, &r) in st.free_rows.iter().enumerate() {
        let [o0, o1] = st.offsets[r];
        let j = row(r);
        for i in 0..3 {
            reaction[o0 + i] = reaction[o0 + i] + j[i] * lam[a];
            reaction[o1 + i] = reaction[o1 + i] + j[3 + i] * lam[a];
        }
    }
    for k in 0..n {
        qdd[k] = acc[k] - im[k] * reaction[k];
    }
    if let Some((lambda, full_inverse_mass)) = lambda {
        for (a, &r) in st.free_rows.iter().enumerate() {
            lambda[r] = lam[a];
        }
        for &(r, k, c) in &st.fixed {
            let f = forces.map_or(zero, |f| f[k]);
            lambda[r] = (f - qdd[k] / full_inverse_mass[k] - reaction[k]) * R::splat(c);
        }
    }
}

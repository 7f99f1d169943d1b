//! The Dormand–Prince 8(5,3) pair (Hairer's DOP853): 12 stages, an 8th-order solution, the
//! combined 5th/3rd-order error estimate, and a 7th-order continuous extension that costs three
//! extra evaluations (built only when an output, an event or the system needs it).
//!
//! Coefficients: Hairer, Nørsett & Wanner, *Solving Ordinary Differential Equations I*, §II.10 and
//! the DOP853 code (`contd8`). Consistency (Σ_j a_ij = c_i, Σ b = 1, Σ e = 0) is checked in tests.

use crate::OdeSystem;
use crate::adaptive::{Control, Pair};

// Generated from the published DOP853 coefficients (Hairer, Nørsett & Wanner; Hairer's dop853.f).
/// Nodes c_i of the 12 stages, the end-point evaluation and the 3 dense-output stages.
const C: [f64; 16] = [
    0.0,
    0.05260015195876773,
    0.0789002279381516,
    0.1183503419072274,
    0.2816496580927726,
    0.3333333333333333,
    0.25,
    0.3076923076923077,
    0.6512820512820513,
    0.6,
    0.8571428571428571,
    1.0,
    1.0,
    0.1,
    0.2,
    0.7777777777777778,
];
/// Stage coefficients a_ij (row i: stage i; the row 12 is b, rows 13–15 the dense stages).
const A: [[f64; 16]; 16] = [
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.05260015195876773, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0197250569845379, 0.0591751709536137, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.02958758547680685, 0.0, 0.08876275643042054, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [
        0.2413651341592667,
        0.0,
        -0.8845494793282861,
        0.924834003261792,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.037037037037037035,
        0.0,
        0.0,
        0.17082860872947386,
        0.12546768756682242,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.037109375,
        0.0,
        0.0,
        0.17025221101954405,
        0.06021653898045596,
        -0.017578125,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.03709200011850479,
        0.0,
        0.0,
        0.17038392571223998,
        0.10726203044637328,
        -0.015319437748624402,
        0.008273789163814023,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.6241109587160757,
        0.0,
        0.0,
        -3.3608926294469414,
        -0.868219346841726,
        27.59209969944671,
        20.154067550477894,
        -43.48988418106996,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.47766253643826434,
        0.0,
        0.0,
        -2.4881146199716677,
        -0.590290826836843,
        21.230051448181193,
        15.279233632882423,
        -33.28821096898486,
        -0.020331201708508627,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        -0.9371424300859873,
        0.0,
        0.0,
        5.186372428844064,
        1.0914373489967295,
        -8.149787010746927,
        -18.52006565999696,
        22.739487099350505,
        2.4936055526796523,
        -3.0467644718982196,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        2.273310147516538,
        0.0,
        0.0,
        -10.53449546673725,
        -2.0008720582248625,
        -17.9589318631188,
        27.94888452941996,
        -2.8589982771350235,
        -8.87285693353063,
        12.360567175794303,
        0.6433927460157636,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.054293734116568765,
        0.0,
        0.0,
        0.0,
        0.0,
        4.450312892752409,
        1.8915178993145003,
        -5.801203960010585,
        0.3111643669578199,
        -0.1521609496625161,
        0.20136540080403034,
        0.04471061572777259,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.056167502283047954,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.25350021021662483,
        -0.2462390374708025,
        -0.12419142326381637,
        0.15329179827876568,
        0.00820105229563469,
        0.007567897660545699,
        -0.008298,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.03183464816350214,
        0.0,
        0.0,
        0.0,
        0.0,
        0.028300909672366776,
        0.053541988307438566,
        -0.05492374857139099,
        0.0,
        0.0,
        -0.00010834732869724932,
        0.0003825710908356584,
        -0.00034046500868740456,
        0.1413124436746325,
        0.0,
        0.0,
    ],
    [
        -0.42889630158379194,
        0.0,
        0.0,
        0.0,
        0.0,
        -4.697621415361164,
        7.683421196062599,
        4.06898981839711,
        0.3567271874552811,
        0.0,
        0.0,
        0.0,
        -0.0013990241651590145,
        2.9475147891527724,
        -9.15095847217987,
        0.0,
    ],
];
/// 5th-order error weights (over stages 0–11).
const E5: [f64; 12] = [
    0.01312004499419488,
    0.0,
    0.0,
    0.0,
    0.0,
    -1.2251564463762044,
    -0.4957589496572502,
    1.6643771824549864,
    -0.35032884874997366,
    0.3341791187130175,
    0.08192320648511571,
    -0.022355307863886294,
];
/// 3rd-order error weights (over stages 0–11).
const E3: [f64; 12] = [
    -0.18980075407240762,
    0.0,
    0.0,
    0.0,
    0.0,
    4.450312892752409,
    1.8915178993145003,
    -5.801203960010585,
    -0.4226823213237919,
    -0.1521609496625161,
    0.20136540080403034,
    0.02265179219836082,
];
/// Dense-output weights of the four higher coefficients (over all 16 evaluations).
const D: [[f64; 16]; 4] = [
    [
        -8.428938276109013,
        0.0,
        0.0,
        0.0,
        0.0,
        0.5667149535193777,
        -3.0689499459498917,
        2.38466765651207,
        2.117034582445028,
        -0.871391583777973,
        2.2404374302607883,
        0.6315787787694688,
        -0.08899033645133331,
        18.148505520854727,
        -9.194632392478356,
        -4.436036387594894,
    ],
    [
        10.427508642579134,
        0.0,
        0.0,
        0.0,
        0.0,
        242.28349177525817,
        165.20045171727028,
        -374.5467547226902,
        -22.113666853125306,
        7.733432668472264,
        -30.674084731089398,
        -9.332130526430229,
        15.697238121770845,
        -31.139403219565178,
        -9.35292435884448,
        35.81684148639408,
    ],
    [
        19.985053242002433,
        0.0,
        0.0,
        0.0,
        0.0,
        -387.0373087493518,
        -189.17813819516758,
        527.8081592054236,
        -11.57390253995963,
        6.8812326946963,
        -1.0006050966910838,
        0.7777137798053443,
        -2.778205752353508,
        -60.19669523126412,
        84.32040550667716,
        11.99229113618279,
    ],
    [
        -25.69393346270375,
        0.0,
        0.0,
        0.0,
        0.0,
        -154.18974869023643,
        -231.5293791760455,
        357.6391179106141,
        93.40532418362432,
        -37.45832313645163,
        104.0996495089623,
        29.8402934266605,
        -43.53345659001114,
        96.32455395918828,
        -39.17726167561544,
        -149.72683625798564,
    ],
];

/// Index of f(t + h, y_new) among the evaluations (first same as last).
const END: usize = 12;

/// Stages and continuous extension of one DOP853 step; allocated once per run.
pub(crate) struct Dop853 {
    /// k[0..12]: stages; k[12]: f at the step end; k[13..16]: dense-output stages.
    k: [Vec<f64>; 16],
    y_stage: Vec<f64>,
    y_new: Vec<f64>,
    dense: [Vec<f64>; 8],
}

impl Dop853 {
    /// y_stage = y + h Σ_{j<i} a_ij k_j.
    fn stage_state(&mut self, i: usize, y: &[f64], h: f64) {
        let row = &A[i];
        self.y_stage.copy_from_slice(y);
        for (j, a) in row.iter().enumerate().take(i) {
            if *a != 0.0 {
                let ha = h * a;
                for (s, k) in self.y_stage.iter_mut().zip(&self.k[j]) {
                    *s += ha * k;
                }
            }
        }
    }
}

impl Pair for Dop853 {
    const CONTROL: Control = Control {
        accept_exponent: 1.0 / 8.0,
        beta: 0.0,
        reject_exponent: 1.0 / 8.0,
        shrink: 1.0 / 0.333,
        grow: 6.0,
        reject_floor: 0.333,
    };
    const STAGE_EVALUATIONS: u64 = 11;
    const DENSE_IS_FREE: bool = false;

    fn new(n: usize) -> Self {
        Self {
            k: std::array::from_fn(|_| vec![0.0; n]),
            y_stage: vec![0.0; n],
            y_new: vec![0.0; n],
            dense: std::array::from_fn(|_| vec![0.0; n]),
        }
    }

    fn derivative_at_start(&mut self) -> &mut [f64] {
        &mut self.k[0]
    }

    fn step<S: OdeSystem + ?Sized>(&mut self, system: &mut S, t: f64, y: &[f64], h: f64) {
        for i in 1..12 {
            self.stage_state(i, y, h);
            system.rhs(t + C[i] * h, &self.y_stage, &mut self.k[i]);
        }
        self.stage_state(END, y, h);
        self.y_new.copy_from_slice(&self.y_stage);
    }

    fn finish<S: OdeSystem + ?Sized>(&mut self, system: &mut S, t: f64, h: f64) -> u64 {
        system.rhs(t + h, &self.y_new, &mut self.k[END]);
        1
    }

    fn new_state(&self) -> &[f64] {
        &self.y_new
    }

    fn error_norm(&self, y: &[f64], h: f64, rtol: f64, atol: f64) -> f64 {
        let n = y.len();
        let (mut sum5, mut sum3) = (0.0, 0.0);
        for j in 0..n {
            let sk = atol + rtol * y[j].abs().max(self.y_new[j].abs());
            let (mut e5, mut e3) = (0.0, 0.0);
            for i in 0..12 {
                e5 += E5[i] * self.k[i][j];
                e3 += E3[i] * self.k[i][j];
            }
            sum5 += (e5 / sk) * (e5 / sk);
            sum3 += (e3 / sk) * (e3 / sk);
        }
        let mut denominator = sum5 + 0.01 * sum3;
        if denominator <= 0.0 {
            denominator = 1.0;
        }
        h.abs() * sum5 / (denominator * n as f64).sqrt()
    }

    fn build_dense<S: OdeSystem + ?Sized>(&mut self, system: &mut S, t: f64, y: &[f64], h: f64) -> u64 {
        for i in 13..16 {
            self.stage_state(i, y, h);
            system.rhs(t + C[i] * h, &self.y_stage, &mut self.k[i]);
        }
        let [r0, r1, r2, r3, rest @ ..] = &mut self.dense;
        for j in 0..y.len() {
            let ydiff = self.y_new[j] - y[j];
            let bspl = h * self.k[0][j] - ydiff;
            r0[j] = y[j];
            r1[j] = ydiff;
            r2[j] = bspl;
            r3[j] = ydiff - h * self.k[END][j] - bspl;
        }
        for (r, d) in rest.iter_mut().zip(&D) {
            r.fill(0.0);
            for (i, weight) in d.iter().enumerate() {
                if *weight != 0.0 {
                    let hw = h * weight;
                    for (x, k) in r.iter_mut().zip(&self.k[i]) {
                        *x += hw * k;
                    }
                }
            }
        }
        3
    }

    fn dense_coefficients(&self) -> &[Vec<f64>] {
        &self.dense
    }

    fn reuse_last_stage(&mut self) {
        let (k0, rest) = self.k.split_at_mut(1);
        k0[0].copy_from_slice(&rest[END - 1]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coefficients_are_consistent() {
        for i in 1..16 {
            let sum: f64 = A[i].iter().sum();
            assert!((sum - C[i]).abs() < 1e-14, "row {i}: Σ a = {sum}, c = {}", C[i]);
        }
        assert!((A[END].iter().sum::<f64>() - 1.0).abs() < 1e-14);
        assert!(E5.iter().sum::<f64>().abs() < 1e-14);
        assert!(E3.iter().sum::<f64>().abs() < 1e-14);
    }
}

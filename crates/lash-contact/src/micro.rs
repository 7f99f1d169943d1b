//! The micro subsystem of the reduced interface model: the clearance interface alone,
//! `M̃(t) ẅ = f̃(t) + f_c(e, ė)` with state (e, ė), driven by the macro subsystem's effective mass
//! M̃ and effective force f̃ (docs/theory.md §6).
//!
//! Inputs arrive at each communication point as a value and a rate (FMI input derivatives, as
//! separate variables so FMI 3.0 carries them too): inside a step the model sees
//! `u(τ) = u(t) + u̇(t)(τ − t)`. With linear interpolation across the macro step the rate is the
//! slope of the segment, so the micro model follows the interpolant exactly; with cubic Hermite it
//! follows it to O(h_r²) per step.
//!
//! Two integrators: fixed-step RK4 (the reduced-interface-model papers' choice; one contact-law evaluation per stage, the
//! 2×2 solve by Cramer's rule, no allocation, no trigonometry), and error-controlled DOPRI5 with
//! location of contact onset and exit (a 2-DOF model can afford a converged answer).

use crate::clearance::{ClearanceJoint, ContactState, Impact, ImpactTracker};
use crate::parameters::ClearanceDefinition;
use lash_core::subsystem::{Causality, Phase, Variability, VariableTable, element_count};
use lash_core::{SavedState, StepOutcome, Subsystem, SubsystemError, Ticks, ValueReference, Variable};
use lash_mech::Vec2;
use lash_ode::{Dopri5Options, Method, OdeSystem};
use nalgebra::Matrix2;

/// The macro terms seen by the micro model at a communication point: values and rates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterfaceInputs {
    /// Effective mass M̃ [kg].
    pub effective_mass: Matrix2<f64>,
    /// dM̃/dt [kg/s].
    pub effective_mass_rate: Matrix2<f64>,
    /// Effective force f̃ [N].
    pub effective_force: Vec2,
    /// df̃/dt [N/s].
    pub effective_force_rate: Vec2,
    /// Angular velocity of the journal body [rad/s].
    pub journal_angular_velocity: f64,
    /// Its rate [rad/s²].
    pub journal_angular_acceleration: f64,
    /// Angular velocity of the bearing body [rad/s].
    pub bearing_angular_velocity: f64,
    /// Its rate [rad/s²].
    pub bearing_angular_acceleration: f64,
}

impl Default for InterfaceInputs {
    fn default() -> Self {
        Self {
            effective_mass: Matrix2::identity(),
            effective_mass_rate: Matrix2::zeros(),
            effective_force: Vec2::zeros(),
            effective_force_rate: Vec2::zeros(),
            journal_angular_velocity: 0.0,
            journal_angular_acceleration: 0.0,
            bearing_angular_velocity: 0.0,
            bearing_angular_acceleration: 0.0,
        }
    }
}

/// Which integrator the micro model uses.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub enum MicroIntegrator {
    /// Classical RK4 with the given step [s]; a communication step is cut into whole steps.
    Rk4 {
        /// Step h_r [s].
        step: f64,
    },
    /// DOPRI5 with event location of contact onset and exit.
    Dopri5(Dopri5Options),
}

/// The clearance interface as a 2-DOF system with state (e, ė) and the impulse ∫f_c dt.
#[derive(Clone)]
pub struct InterfaceModel {
    /// Geometry, contact and friction laws (its discrete contact state is used too).
    pub joint: ClearanceJoint,
    /// Eccentricity e [m].
    pub eccentricity: Vec2,
    /// Its rate ė [m/s].
    pub eccentricity_rate: Vec2,
    /// ∫ f_c dt on the journal since the start [N s].
    pub impulse: Vec2,
    /// Completed impacts.
    pub impacts: Vec<Impact>,
    /// Inputs of the current step.
    pub inputs: InterfaceInputs,
    /// Time of `inputs` [s].
    pub input_time: f64,
    open: Option<ImpactTracker>,
    violation: bool,
    /// The last integration was an adaptive one (continuous extensions reach `accept_dense`).
    located: bool,
    /// The contact force at the end of the last RK4 step, with its (t, e, ė): the next step's
    /// first stage is the same state and reuses it.
    end_force: Option<(f64, Vec2, Vec2, Vec2)>,
}

impl InterfaceModel {
    /// A centred, resting interface.
    pub fn new(joint: ClearanceJoint) -> Self {
        Self {
            joint,
            eccentricity: Vec2::zeros(),
            eccentricity_rate: Vec2::zeros(),
            impulse: Vec2::zeros(),
            impacts: Vec::with_capacity(1024),
            inputs: InterfaceInputs::default(),
            input_time: 0.0,
            open: None,
            violation: false,
            located: false,
            end_force: None,
        }
    }

    /// Contact state at (e, ė) at time `t`, using the current mode.
    #[inline(always)]
    pub fn contact_at(&self, t: f64, e: Vec2, ed: Vec2) -> ContactState {
        let dt = t - self.input_time;
        let u = &self.inputs;
        let wj = u.journal_angular_velocity + u.journal_angular_acceleration * dt;
        let wb = u.bearing_angular_velocity + u.bearing_angular_acceleration * dt;
        let s = self.joint.evaluate_relative(e, ed, wj, wb, self.joint.onset_velocity);
        if !self.joint.in_contact && s.penetration > 0.0 {
            // A stage ahead of the onset: the local approach velocity stands in for δ̇⁻.
            self.joint.evaluate_relative(e, ed, wj, wb, s.penetration_rate.max(0.0))
        } else {
            s
        }
    }

    /// f_c at (t, e, ė) alone: in free flight (|e| ≤ c, so F_N = F_T = 0) nothing but |e|² is
    /// computed.
    #[inline(always)]
    fn contact_force_at(&self, t: f64, e: Vec2, ed: Vec2) -> Vec2 {
        let c = self.joint.radial_clearance();
        if e.norm_squared() <= c * c {
            return Vec2::zeros();
        }
        self.contact_at(t, e, ed).force_on_journal
    }

    /// ë and f_c at (t, e, ė).
    #[inline(always)]
    fn acceleration(&self, t: f64, e: Vec2, ed: Vec2) -> (Vec2, Vec2) {
        self.acceleration_with(t, self.contact_force_at(t, e, ed))
    }

    /// ë at t for a given contact force: M̃(t)⁻¹ (f̃(t) + f_c) by Cramer's rule.
    #[inline(always)]
    fn acceleration_with(&self, t: f64, fc: Vec2) -> (Vec2, Vec2) {
        let dt = t - self.input_time;
        let u = &self.inputs;
        let m = u.effective_mass + u.effective_mass_rate * dt;
        let f = u.effective_force + u.effective_force_rate * dt;
        let r = f + fc;
        let det = m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)];
        let inv = 1.0 / det;
        (Vec2::new((m[(1, 1)] * r.x - m[(0, 1)] * r.y) * inv, (m[(0, 0)] * r.y - m[(1, 0)] * r.x) * inv), fc)
    }

    /// One RK4 step of size `h` from `t`. Returns the contact state at the end of the step.
    pub fn rk4_step(&mut self, t: f64, h: f64) -> ContactState {
        self.located = false;
        let (e0, v0) = (self.eccentricity, self.eccentricity_rate);
        let (k1v, f1) = match self.end_force {
            Some((te, ee, ve, fe)) if (te - t).abs() < 1e-12 && ee == e0 && ve == v0 => self.acceleration_with(t, fe),
            _ => self.acceleration(t, e0, v0),
        };
        let k1e = v0;
        let k2e = v0 + k1v * (0.5 * h);
        let (k2v, f2) = self.acceleration(t + 0.5 * h, e0 + k1e * (0.5 * h), k2e);
        let k3e = v0 + k2v * (0.5 * h);
        let (k3v, f3) = self.acceleration(t + 0.5 * h, e0 + k2e * (0.5 * h), k3e);
        let k4e = v0 + k3v * h;
        let (k4v, f4) = self.acceleration(t + h, e0 + k3e * h, k4e);
        let e1 = e0 + (k1e + (k2e + k3e) * 2.0 + k4e) * (h / 6.0);
        let v1 = v0 + (k1v + (k2v + k3v) * 2.0 + k4v) * (h / 6.0);
        self.impulse += (f1 + (f2 + f3) * 2.0 + f4) * (h / 6.0);
        // Mode switches at the step end; the onset is placed by linear interpolation.
        let c = self.joint.radial_clearance();
        let (d0, d1) = (e0.norm() - c, e1.norm() - c);
        if !self.joint.in_contact && d1 > 0.0 {
            let frac = if d1 - d0 > 0.0 { (-d0 / (d1 - d0)).clamp(0.0, 1.0) } else { 1.0 };
            let (ec, vc) = (e0 + (e1 - e0) * frac, v0 + (v1 - v0) * frac);
            let rate = vc.dot(&(ec / ec.norm().max(f64::MIN_POSITIVE)));
            self.open_contact(t + frac * h, rate);
        } else if self.joint.in_contact && d1 <= 0.0 {
            let frac = if d0 - d1 > 0.0 { (d0 / (d0 - d1)).clamp(0.0, 1.0) } else { 1.0 };
            self.close_contact(t + frac * h);
        }
        self.eccentricity = e1;
        self.eccentricity_rate = v1;
        let s = self.contact_at(t + h, e1, v1);
        self.end_force = Some((t + h, e1, v1, s.force_on_journal));
        if let Some(tr) = self.open.as_mut() {
            tr.sample(t + h, s.normal_force, s.penetration);
        }
        s
    }

    fn open_contact(&mut self, t: f64, rate: f64) {
        self.joint.in_contact = true;
        self.joint.onset_velocity = rate.max(0.0);
        self.open = Some(ImpactTracker::open(t, rate, self.located));
    }

    fn close_contact(&mut self, t: f64) {
        self.joint.in_contact = false;
        if let Some(tr) = self.open.take() {
            self.impacts.push(tr.close(t));
        }
    }

    /// Integrates from `t` to `t + h` with DOPRI5 and event location. Returns the end state and
    /// the number of accepted steps.
    pub fn dopri5_step(&mut self, options: &Dopri5Options, t: f64, h: f64) -> Result<(ContactState, u64), String> {
        let mut y = [
            self.eccentricity.x,
            self.eccentricity.y,
            self.eccentricity_rate.x,
            self.eccentricity_rate.y,
            self.impulse.x,
            self.impulse.y,
        ];
        let method = Method::Dopri5(Dopri5Options { max_step: options.max_step.min(h), ..*options });
        let stats =
            lash_ode::integrate(&method, self, t, &mut y, t + h, h, &mut |_: &mut Self, _: f64, _: &[f64]| Ok(()))
                .map_err(|e| e.to_string())?;
        self.eccentricity = Vec2::new(y[0], y[1]);
        self.eccentricity_rate = Vec2::new(y[2], y[3]);
        self.impulse = Vec2::new(y[4], y[5]);
        Ok((self.contact_at(t + h, self.eccentricity, self.eccentricity_rate), stats.steps))
    }

    /// Impacts still open (closed at `t` for reporting, exit time NaN).
    pub fn open_impacts(&self, t: f64) -> Vec<Impact> {
        self.open.iter().map(|tr| tr.so_far(t)).collect()
    }
}

impl OdeSystem for InterfaceModel {
    fn dim(&self) -> usize {
        6
    }

    fn rhs(&mut self, t: f64, y: &[f64], dydt: &mut [f64]) {
        let (e, ed) = (Vec2::new(y[0], y[1]), Vec2::new(y[2], y[3]));
        let delta = e.norm() - self.joint.radial_clearance();
        if (delta > 0.0) != self.joint.in_contact {
            self.violation = true;
        }
        let (a, fc) = self.acceleration(t, e, ed);
        dydt.copy_from_slice(&[ed.x, ed.y, a.x, a.y, fc.x, fc.y]);
    }

    fn begin(&mut self, locates_events: bool) {
        self.located = locates_events;
    }

    fn event_count(&self) -> usize {
        1
    }

    fn events(&mut self, _t: f64, y: &[f64], g: &mut [f64]) {
        let delta = (y[0] * y[0] + y[1] * y[1]).sqrt() - self.joint.radial_clearance();
        g[0] = if self.joint.in_contact { -delta } else { delta };
    }

    fn on_event(&mut self, _k: usize, t: f64, y: &[f64]) {
        if self.joint.in_contact {
            self.close_contact(t);
        } else {
            let e = Vec2::new(y[0], y[1]);
            let rate = Vec2::new(y[2], y[3]).dot(&(e / e.norm().max(f64::MIN_POSITIVE)));
            self.open_contact(t, rate);
        }
    }

    fn take_mode_violation(&mut self) -> bool {
        std::mem::take(&mut self.violation)
    }

    fn wants_dense(&self) -> bool {
        self.open.is_some()
    }

    fn accept_dense(&mut self, t: f64, h: f64, dense: &lash_ode::Dense<'_>) {
        if self.open.is_none() {
            return;
        }
        let mut y = [0.0; 6];
        let mut deepest = 0.0f64;
        let peak = crate::clearance::step_peak(|theta| {
            dense.eval(theta, &mut y);
            let s = self.contact_at(t + theta * h, Vec2::new(y[0], y[1]), Vec2::new(y[2], y[3]));
            deepest = deepest.max(s.penetration);
            s.normal_force
        });
        if let Some(tr) = self.open.as_mut() {
            tr.deepen(deepest);
            if let Some((theta, f)) = peak {
                tr.peak_candidate(t + theta * h, f);
            }
        }
    }

    fn accept_step(&mut self, t: f64, y: &[f64]) -> Result<(), String> {
        let s = self.contact_at(t, Vec2::new(y[0], y[1]), Vec2::new(y[2], y[3]));
        if let Some(tr) = self.open.as_mut() {
            tr.sample(t, s.normal_force, s.penetration);
        }
        check_penetration(&self.joint, &s)
    }
}

/// Largest penetration accepted, as a fraction of the journal radius (as in the full model).
const PENETRATION_LIMIT_FRACTION: f64 = 0.1;

fn check_penetration(joint: &ClearanceJoint, s: &ContactState) -> Result<(), String> {
    if s.penetration <= PENETRATION_LIMIT_FRACTION * joint.journal_radius && s.eccentricity_norm.is_finite() {
        Ok(())
    } else {
        Err(format!(
            "penetration {:e} m of clearance joint {:?} in the micro model exceeds {} × the journal radius: the \
             simulation blew up (micro step too large for the contact stiffness?)",
            s.penetration, joint.name, PENETRATION_LIMIT_FRACTION
        ))
    }
}

/// Value references of the interface subsystem's variables (in table order).
pub mod vr {
    use lash_core::ValueReference;
    /// Input M̃ (2×2).
    pub const EFFECTIVE_MASS: ValueReference = 0;
    /// Input dM̃/dt (2×2).
    pub const EFFECTIVE_MASS_RATE: ValueReference = 1;
    /// Input f̃ (2).
    pub const EFFECTIVE_FORCE: ValueReference = 2;
    /// Input df̃/dt (2).
    pub const EFFECTIVE_FORCE_RATE: ValueReference = 3;
    /// Input ω of the journal body.
    pub const JOURNAL_ANGULAR_VELOCITY: ValueReference = 4;
    /// Input its rate.
    pub const JOURNAL_ANGULAR_ACCELERATION: ValueReference = 5;
    /// Input ω of the bearing body.
    pub const BEARING_ANGULAR_VELOCITY: ValueReference = 6;
    /// Input its rate.
    pub const BEARING_ANGULAR_ACCELERATION: ValueReference = 7;
    /// Output f_c on the journal (2).
    pub const CONTACT_FORCE: ValueReference = 8;
    /// Output ∫f_c dt (2).
    pub const CONTACT_IMPULSE: ValueReference = 9;
    /// Output F_N.
    pub const NORMAL_FORCE: ValueReference = 10;
    /// Output F_T.
    pub const FRICTION_FORCE: ValueReference = 11;
    /// Output e (2).
    pub const ECCENTRICITY: ValueReference = 12;
    /// Output ė (2).
    pub const ECCENTRICITY_RATE: ValueReference = 13;
    /// Output |e|.
    pub const ECCENTRICITY_NORM: ValueReference = 14;
    /// Output δ.
    pub const PENETRATION: ValueReference = 15;
    /// Output δ̇.
    pub const PENETRATION_RATE: ValueReference = 16;
    /// Output v_t.
    pub const SLIP_VELOCITY: ValueReference = 17;
    /// Output: completed impacts.
    pub const IMPACTS: ValueReference = 18;
    /// Output: 1 in contact, 0 in free flight.
    pub const IN_CONTACT: ValueReference = 19;
    /// Parameter: radial clearance (read-only here; the law is fixed at construction).
    pub const RADIAL_CLEARANCE: ValueReference = 20;
    /// Output |f_c|.
    pub const CONTACT_FORCE_MAGNITUDE: ValueReference = 21;
    /// Output: micro steps taken since initialization (DOPRI5: accepted steps).
    pub const MICRO_STEPS: ValueReference = 22;
    /// First parameter (with a [`crate::ClearanceDefinition`]): `journal_radius`, then
    /// `bearing_radius`, then the laws' numeric fields.
    pub const FIRST_PARAMETER: ValueReference = 23;
}

/// The clearance interface as a [`Subsystem`] (the micro subsystem).
#[derive(Clone)]
pub struct InterfaceSubsystem {
    name: String,
    variables: Vec<Variable>,
    lens: Vec<usize>,
    /// The model (public for in-process observers and summaries).
    pub model: InterfaceModel,
    integrator: MicroIntegrator,
    micro_step: Ticks,
    time: Ticks,
    phase: Phase,
    state: ContactState,
    definition: Option<ClearanceDefinition>,
    parameter_values: Vec<f64>,
    micro_steps: u64,
}

impl InterfaceSubsystem {
    /// A micro subsystem for `joint`, centred and at rest relative to the bearing.
    pub fn new(joint: ClearanceJoint, integrator: MicroIntegrator) -> Result<Self, SubsystemError> {
        Self::with_definition(joint, integrator, None)
    }

    /// As [`InterfaceSubsystem::new`], with the joint's definition: its radii and law
    /// coefficients become parameters (value references from [`vr::FIRST_PARAMETER`] on), which
    /// may be set before `initialize`, where they are checked and resolved into the joint.
    pub fn with_definition(
        joint: ClearanceJoint,
        integrator: MicroIntegrator,
        definition: Option<ClearanceDefinition>,
    ) -> Result<Self, SubsystemError> {
        let micro_step = match integrator {
            MicroIntegrator::Rk4 { step } => Ticks::from_seconds(step)
                .map_err(|e| SubsystemError::BadValue { name: "micro_step".into(), problem: e.to_string() })?,
            MicroIntegrator::Dopri5(_) => Ticks(0),
        };
        if matches!(integrator, MicroIntegrator::Rk4 { .. }) && micro_step.0 <= 0 {
            return Err(SubsystemError::BadValue { name: "micro_step".into(), problem: "must be > 0".into() });
        }
        use Causality::{Input, Local, Output};
        use Variability::{Continuous as C, Discrete as D, Fixed};
        let mut t = VariableTable::new();
        let eye = [1.0, 0.0, 0.0, 1.0];
        t.add("effective_mass", Input, C, "kg", "effective mass M~ of the interface", &[2, 2], &eye);
        t.add("effective_mass_rate", Input, C, "kg/s", "dM~/dt", &[2, 2], &[0.0]);
        t.add("effective_force", Input, C, "N", "effective force f~ on the journal", &[2], &[0.0]);
        t.add("effective_force_rate", Input, C, "N/s", "df~/dt", &[2], &[0.0]);
        t.add("journal_angular_velocity", Input, C, "rad/s", "angular velocity of the journal body", &[], &[0.0]);
        t.add("journal_angular_acceleration", Input, C, "rad/s^2", "its rate", &[], &[0.0]);
        t.add("bearing_angular_velocity", Input, C, "rad/s", "angular velocity of the bearing body", &[], &[0.0]);
        t.add("bearing_angular_acceleration", Input, C, "rad/s^2", "its rate", &[], &[0.0]);
        t.add("contact_force", Output, C, "N", "contact force f_c on the journal", &[2], &[0.0]);
        t.add("contact_impulse", Output, C, "N.s", "integral of f_c since the start", &[2], &[0.0]);
        t.add("normal_force", Output, C, "N", "normal contact force F_N", &[], &[0.0]);
        t.add("friction_force", Output, C, "N", "friction force F_T", &[], &[0.0]);
        t.add("eccentricity", Output, C, "m", "journal centre minus bearing centre", &[2], &[0.0]);
        t.add("eccentricity_rate", Output, C, "m/s", "its rate", &[2], &[0.0]);
        t.add("eccentricity_norm", Output, C, "m", "|e|", &[], &[0.0]);
        t.add("penetration", Output, C, "m", "|e| - c", &[], &[-joint.radial_clearance()]);
        t.add("penetration_rate", Output, C, "m/s", "d(penetration)/dt", &[], &[0.0]);
        t.add("slip_velocity", Output, C, "m/s", "relative tangential velocity", &[], &[0.0]);
        t.add("impacts", Output, D, "1", "completed impacts", &[], &[0.0]);
        t.add("in_contact", Output, D, "1", "1 in contact, 0 in free flight", &[], &[0.0]);
        t.add("radial_clearance", Local, Fixed, "m", "c = R_B - R_J", &[], &[joint.radial_clearance()]);
        t.add("contact_force_magnitude", Output, C, "N", "|f_c|", &[], &[0.0]);
        t.add(
            "micro_steps",
            Output,
            D,
            "1",
            "micro steps taken since initialization (RK4: h / h_r per step; DOPRI5: accepted steps)",
            &[],
            &[0.0],
        );
        let parameters = definition.as_ref().map(ClearanceDefinition::parameters).unwrap_or_default();
        for p in &parameters {
            t.add(
                &p.name,
                Causality::Parameter,
                Fixed,
                p.unit,
                "clearance joint parameter (as in the scenario file)",
                &[],
                &[p.value],
            );
        }
        let model = InterfaceModel::new(joint);
        let state = model.contact_at(0.0, Vec2::zeros(), Vec2::zeros());
        let variables = t.into_variables();
        Ok(Self {
            name: format!("interface {}", model.joint.name),
            lens: variables.iter().map(Variable::len).collect(),
            variables,
            model,
            integrator,
            micro_step,
            time: Ticks::ZERO,
            phase: Phase::Instantiated,
            state,
            definition,
            parameter_values: parameters.iter().map(|p| p.value).collect(),
            micro_steps: 0,
        })
    }

    /// The integrator it was built with.
    pub fn integrator(&self) -> MicroIntegrator {
        self.integrator
    }

    /// The contact state at the current time.
    pub fn contact(&self) -> &ContactState {
        &self.state
    }

    /// Sets the inputs directly (the in-process fast path, equal to `set_f64` on the eight inputs).
    #[inline]
    pub fn set_inputs(&mut self, inputs: InterfaceInputs) -> Result<(), SubsystemError> {
        let u = &inputs;
        let finite = u.effective_mass.iter().chain(u.effective_mass_rate.iter()).all(|v| v.is_finite())
            && u.effective_force.iter().chain(u.effective_force_rate.iter()).all(|v| v.is_finite())
            && [
                u.journal_angular_velocity,
                u.journal_angular_acceleration,
                u.bearing_angular_velocity,
                u.bearing_angular_acceleration,
            ]
            .iter()
            .all(|v| v.is_finite());
        if !finite {
            return Err(SubsystemError::BadValue {
                name: "effective_mass/effective_force/angular velocities".into(),
                problem: "non-finite input".into(),
            });
        }
        self.model.inputs = inputs;
        self.model.input_time = self.time.seconds();
        Ok(())
    }

    fn outputs(&self, vr: ValueReference, out: &mut [f64]) {
        let s = &self.state;
        let m = &self.model;
        if vr >= self::vr::FIRST_PARAMETER {
            out[0] = self.parameter_values[(vr - self::vr::FIRST_PARAMETER) as usize];
            return;
        }
        match vr {
            vr::CONTACT_FORCE => out.copy_from_slice(s.force_on_journal.as_slice()),
            vr::CONTACT_IMPULSE => out.copy_from_slice(m.impulse.as_slice()),
            vr::NORMAL_FORCE => out[0] = s.normal_force,
            vr::FRICTION_FORCE => out[0] = s.friction_force,
            vr::ECCENTRICITY => out.copy_from_slice(m.eccentricity.as_slice()),
            vr::ECCENTRICITY_RATE => out.copy_from_slice(m.eccentricity_rate.as_slice()),
            vr::ECCENTRICITY_NORM => out[0] = s.eccentricity_norm,
            vr::PENETRATION => out[0] = s.penetration,
            vr::PENETRATION_RATE => out[0] = s.penetration_rate,
            vr::SLIP_VELOCITY => out[0] = s.slip_velocity,
            vr::IMPACTS => out[0] = m.impacts.len() as f64,
            vr::IN_CONTACT => out[0] = if m.joint.in_contact { 1.0 } else { 0.0 },
            vr::RADIAL_CLEARANCE => out[0] = m.joint.radial_clearance(),
            vr::CONTACT_FORCE_MAGNITUDE => out[0] = s.force_on_journal.norm(),
            vr::MICRO_STEPS => out[0] = self.micro_steps as f64,
            vr::EFFECTIVE_MASS => out.copy_from_slice(&row_major(&m.inputs.effective_mass)),
            vr::EFFECTIVE_MASS_RATE => out.copy_from_slice(&row_major(&m.inputs.effective_mass_rate)),
            vr::EFFECTIVE_FORCE => out.copy_from_slice(m.inputs.effective_force.as_slice()),
            vr::EFFECTIVE_FORCE_RATE => out.copy_from_slice(m.inputs.effective_force_rate.as_slice()),
            vr::JOURNAL_ANGULAR_VELOCITY => out[0] = m.inputs.journal_angular_velocity,
            vr::JOURNAL_ANGULAR_ACCELERATION => out[0] = m.inputs.journal_angular_acceleration,
            vr::BEARING_ANGULAR_VELOCITY => out[0] = m.inputs.bearing_angular_velocity,
            vr::BEARING_ANGULAR_ACCELERATION => out[0] = m.inputs.bearing_angular_acceleration,
            _ => unreachable!("checked by element_count"),
        }
    }
}

/// Row-major elements of a 2×2 matrix (the FMI array layout).
pub fn row_major(m: &Matrix2<f64>) -> [f64; 4] {
    [m[(0, 0)], m[(0, 1)], m[(1, 0)], m[(1, 1)]]
}

/// The 2×2 matrix of row-major elements.
pub fn from_row_major(v: &[f64]) -> Matrix2<f64> {
    Matrix2::new(v[0], v[1], v[2], v[3])
}

impl Subsystem for InterfaceSubsystem {
    fn name(&self) -> &str {
        &self.name
    }

    fn variables(&self) -> &[Variable] {
        &self.variables
    }

    fn setup(&mut self, start: Ticks, _stop: Option<Ticks>) -> Result<(), SubsystemError> {
        self.phase.require("setup", &[Phase::Instantiated])?;
        self.time = start;
        self.model.input_time = start.seconds();
        self.phase = Phase::Configured;
        Ok(())
    }

    fn initialize(&mut self) -> Result<(), SubsystemError> {
        self.phase.require("initialize", &[Phase::Configured])?;
        if let Some(d) = &self.definition {
            let d = d
                .with_values(&self.parameter_values)
                .map_err(|problem| SubsystemError::BadValue { name: "parameters".into(), problem })?;
            let j = &mut self.model.joint;
            j.journal_radius = d.journal_radius;
            j.bearing_radius = d.bearing_radius;
            j.law = d.normal_force();
            j.friction = d.friction;
        }
        let m = &mut self.model;
        m.joint.in_contact = false;
        m.joint.onset_velocity = 0.0;
        self.state = m.contact_at(self.time.seconds(), m.eccentricity, m.eccentricity_rate);
        if self.state.penetration > 0.0 {
            return Err(SubsystemError::BadValue {
                name: "eccentricity".into(),
                problem: "the initial eccentricity exceeds the radial clearance".into(),
            });
        }
        self.phase = Phase::Stepping;
        Ok(())
    }

    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        self.phase.require("set_f64", &[Phase::Configured, Phase::Stepping])?;
        // One pass: the inputs are applied to a copy, committed only if every reference and value
        // is good (no partial update on error).
        let mut u = self.model.inputs;
        let mut parameters: Vec<(ValueReference, f64)> = Vec::new();
        let mut at = 0;
        for &r in refs {
            let len = *self.lens.get(r as usize).ok_or(SubsystemError::UnknownValueReference(r))?;
            let Some(v) = values.get(at..at + len) else {
                let n = element_count(&self.variables, refs)?;
                return Err(SubsystemError::BadArguments(format!("{} values for {} elements", values.len(), n)));
            };
            at += len;
            if r >= vr::FIRST_PARAMETER {
                let name = &self.variables[r as usize].name;
                if self.phase != Phase::Configured {
                    return Err(SubsystemError::BadValue {
                        name: name.clone(),
                        problem: "is a parameter (fixed): set it before initialization".into(),
                    });
                }
                if !v[0].is_finite() {
                    return Err(SubsystemError::BadValue {
                        name: name.clone(),
                        problem: format!("{} is not finite", v[0]),
                    });
                }
                parameters.push((r, v[0]));
                continue;
            }
            if r > vr::BEARING_ANGULAR_ACCELERATION {
                let name = self.variables[r as usize].name.clone();
                return Err(SubsystemError::BadValue { name, problem: "is not an input".into() });
            }
            if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
                let name = self.variables[r as usize].name.clone();
                return Err(SubsystemError::BadValue { name, problem: format!("{bad} is not finite") });
            }
            match r {
                vr::EFFECTIVE_MASS => u.effective_mass = from_row_major(v),
                vr::EFFECTIVE_MASS_RATE => u.effective_mass_rate = from_row_major(v),
                vr::EFFECTIVE_FORCE => u.effective_force = Vec2::new(v[0], v[1]),
                vr::EFFECTIVE_FORCE_RATE => u.effective_force_rate = Vec2::new(v[0], v[1]),
                vr::JOURNAL_ANGULAR_VELOCITY => u.journal_angular_velocity = v[0],
                vr::JOURNAL_ANGULAR_ACCELERATION => u.journal_angular_acceleration = v[0],
                vr::BEARING_ANGULAR_VELOCITY => u.bearing_angular_velocity = v[0],
                _ => u.bearing_angular_acceleration = v[0],
            }
        }
        if at != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {} elements", values.len(), at)));
        }
        self.model.inputs = u;
        self.model.input_time = self.time.seconds();
        for (r, v) in parameters {
            self.parameter_values[(r - vr::FIRST_PARAMETER) as usize] = v;
        }
        Ok(())
    }

    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        let mut at = 0;
        for &r in refs {
            let len = *self.lens.get(r as usize).ok_or(SubsystemError::UnknownValueReference(r))?;
            let Some(out) = values.get_mut(at..at + len) else {
                let n = element_count(&self.variables, refs)?;
                return Err(SubsystemError::BadArguments(format!("{} values for {} elements", values.len(), n)));
            };
            self.outputs(r, out);
            at += len;
        }
        if at != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {} elements", values.len(), at)));
        }
        Ok(())
    }

    fn do_step(&mut self, t: Ticks, h: Ticks) -> Result<StepOutcome, SubsystemError> {
        self.phase.require("do_step", &[Phase::Stepping])?;
        if t != self.time {
            return Err(SubsystemError::BadArguments(format!(
                "do_step at t = {} s but the subsystem is at {} s",
                t.seconds(),
                self.time.seconds()
            )));
        }
        if h.0 <= 0 {
            return Err(SubsystemError::BadArguments(format!("step size {} s must be > 0", h.seconds())));
        }
        let fail = |phase: &mut Phase, t: f64, message: String| {
            *phase = Phase::Failed;
            Err(SubsystemError::Simulation { t, message })
        };
        match self.integrator {
            MicroIntegrator::Rk4 { .. } => {
                // Whole micro steps; a remainder (a communication step that is not a multiple) is
                // taken as one shorter step.
                let (steps, rest) = (h.0 / self.micro_step.0, h.0 % self.micro_step.0);
                let mut now = t;
                self.micro_steps += (steps + i64::from(rest > 0)) as u64;
                for k in 0..steps + i64::from(rest > 0) {
                    let dh = if k < steps { self.micro_step } else { Ticks(rest) };
                    self.state = self.model.rk4_step(now.seconds(), dh.seconds());
                    now = Ticks(now.0 + dh.0);
                    if let Err(m) = check_penetration(&self.model.joint, &self.state) {
                        return fail(&mut self.phase, now.seconds(), m);
                    }
                }
            }
            MicroIntegrator::Dopri5(options) => match self.model.dopri5_step(&options, t.seconds(), h.seconds()) {
                Ok((s, steps)) => {
                    self.state = s;
                    self.micro_steps += steps;
                }
                Err(m) => return fail(&mut self.phase, t.seconds(), m),
            },
        }
        self.time = Ticks(t.0 + h.0);
        Ok(StepOutcome::Completed)
    }

    fn time(&self) -> Ticks {
        self.time
    }

    fn save_state(&self) -> Result<SavedState, SubsystemError> {
        Ok(SavedState(Box::new((self.model.clone(), self.time, self.phase, self.state, self.micro_steps))))
    }

    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError> {
        let (model, time, phase, s, micro_steps) = state
            .0
            .downcast_ref::<(InterfaceModel, Ticks, Phase, ContactState, u64)>()
            .ok_or_else(|| SubsystemError::Other("the saved state is not an interface subsystem's".into()))?;
        self.model = model.clone();
        self.time = *time;
        self.phase = *phase;
        self.state = *s;
        self.micro_steps = *micro_steps;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{FrictionLaw, NormalForce};
    use lash_mech::BodyId;

    fn joint() -> ClearanceJoint {
        ClearanceJoint {
            name: "pin".into(),
            journal_body: BodyId::Body(0),
            journal_point: Vec2::zeros(),
            bearing_body: BodyId::Ground,
            bearing_point: Vec2::zeros(),
            journal_radius: 0.0099,
            bearing_radius: 0.01,
            law: NormalForce::Hysteresis { stiffness: 1e10, exponent: 1.5, chi: 0.2, floor: 1e-5 },
            friction: FrictionLaw::None,
            in_contact: false,
            onset_velocity: 0.0,
        }
    }

    fn ready(integrator: MicroIntegrator) -> InterfaceSubsystem {
        let mut s = InterfaceSubsystem::new(joint(), integrator).unwrap();
        s.setup(Ticks::ZERO, None).unwrap();
        s.initialize().unwrap();
        s
    }

    #[test]
    fn parameters_are_set_before_initialization_only_and_checked_there() {
        let definition = crate::ClearanceDefinition {
            journal_radius: 0.0099,
            bearing_radius: 0.01,
            contact: crate::ContactLaw::Hertz { stiffness: Some(1e10), exponent: 1.5 },
            friction: FrictionLaw::Coulomb { coefficient: 0.1 },
            journal_material: crate::Material::STEEL,
            bearing_material: crate::Material::STEEL,
        };
        let mut s = InterfaceSubsystem::with_definition(joint(), MicroIntegrator::Rk4 { step: 1e-5 }, Some(definition))
            .unwrap();
        let index =
            |s: &InterfaceSubsystem, name: &str| s.variables().iter().position(|v| v.name == name).unwrap() as u32;
        let bearing = index(&s, "bearing_radius");
        let mu = index(&s, "friction.coefficient");
        assert_eq!(s.variables()[mu as usize].causality, Causality::Parameter);
        s.setup(Ticks::ZERO, None).unwrap();
        s.set_f64(&[bearing, mu], &[0.0102, 0.3]).unwrap();
        s.initialize().unwrap();
        let mut c = [0.0];
        s.get_f64(&[vr::RADIAL_CLEARANCE], &mut c).unwrap();
        assert!((c[0] - 3e-4).abs() < 1e-15, "clearance {}", c[0]);
        assert_eq!(s.model.joint.friction, FrictionLaw::Coulomb { coefficient: 0.3 });
        assert_eq!(s.model.joint.law, NormalForce::Power { stiffness: 1e10, exponent: 1.5 });
        // Fixed after initialization.
        let e = s.set_f64(&[mu], &[0.2]).unwrap_err().to_string();
        assert!(e.contains("friction.coefficient") && e.contains("before initialization"), "{e}");
        // A bad value is named at initialization.
        let mut s =
            InterfaceSubsystem::with_definition(joint(), MicroIntegrator::Rk4 { step: 1e-5 }, s.definition.clone())
                .unwrap();
        s.setup(Ticks::ZERO, None).unwrap();
        s.set_f64(&[bearing], &[0.009]).unwrap();
        let e = s.initialize().unwrap_err().to_string();
        assert!(e.contains("bearing_radius"), "{e}");
    }

    #[test]
    fn free_flight_follows_the_closed_form_cubic() {
        // No contact: ë = M̃⁻¹ (f̃ + ḟ t) with constant M̃; RK4 integrates a cubic exactly.
        let mut s = ready(MicroIntegrator::Rk4 { step: 1e-5 });
        let (m, f, fd) = (Matrix2::new(2.0, 0.5, 0.5, 1.0), Vec2::new(0.01, -0.02), Vec2::new(3.0, 1.0));
        let mut values = [0.0; 16];
        values[..4].copy_from_slice(&row_major(&m));
        values[8..10].copy_from_slice(f.as_slice());
        values[10..12].copy_from_slice(fd.as_slice());
        s.set_f64(&(0..8).collect::<Vec<_>>(), &values).unwrap();
        let h = Ticks::from_seconds(5e-4).unwrap();
        assert_eq!(s.do_step(Ticks::ZERO, h).unwrap(), lash_core::StepOutcome::Completed);
        let t = 5e-4;
        let inv = m.try_inverse().unwrap();
        let exact = inv * f * (t * t / 2.0) + inv * fd * (t * t * t / 6.0);
        let mut e = [0.0; 2];
        s.get_f64(&[vr::ECCENTRICITY], &mut e).unwrap();
        assert!((Vec2::new(e[0], e[1]) - exact).norm() < 1e-15 * 1e3, "{e:?} vs {exact:?}");
        assert!(exact.norm() > 1e-9 && exact.norm() < joint().radial_clearance());
        assert_eq!(s.time(), h);
    }

    #[test]
    fn bad_calls_are_refused_with_the_variable_named() {
        let mut fresh = InterfaceSubsystem::new(joint(), MicroIntegrator::Rk4 { step: 1e-5 }).unwrap();
        let e = fresh.do_step(Ticks::ZERO, Ticks(10)).unwrap_err();
        assert_eq!(e.to_string(), "do_step is not allowed in state instantiated");
        let mut s = ready(MicroIntegrator::Rk4 { step: 1e-5 });
        let e = s.set_f64(&[vr::CONTACT_FORCE], &[1.0, 2.0]).unwrap_err();
        assert_eq!(e.to_string(), "variable contact_force: is not an input");
        let e = s.set_f64(&[vr::EFFECTIVE_FORCE], &[f64::NAN, 0.0]).unwrap_err();
        assert_eq!(e.to_string(), "variable effective_force: NaN is not finite");
        assert!(matches!(s.set_f64(&[vr::EFFECTIVE_FORCE], &[1.0]), Err(SubsystemError::BadArguments(_))));
        assert_eq!(s.get_f64(&[99], &mut [0.0]), Err(SubsystemError::UnknownValueReference(99)));
        assert!(matches!(s.do_step(Ticks(5), Ticks(10)), Err(SubsystemError::BadArguments(_))));
        assert!(InterfaceSubsystem::new(joint(), MicroIntegrator::Rk4 { step: 0.0 }).is_err());
        assert!(InterfaceSubsystem::new(joint(), MicroIntegrator::Rk4 { step: f64::NAN }).is_err());
    }

    #[test]
    fn restoring_a_saved_state_replays_the_same_impact_bit_for_bit() {
        for integrator in [
            MicroIntegrator::Rk4 { step: 1e-6 },
            MicroIntegrator::Dopri5(Dopri5Options {
                rtol: 1e-9,
                atol: 1e-12,
                initial_step: 1e-7,
                max_step: 1e-5,
                min_step: 1e-14,
            }),
        ] {
            let mut s = ready(integrator);
            s.set_f64(&[vr::EFFECTIVE_MASS, vr::EFFECTIVE_FORCE], &[0.1, 0.0, 0.0, 0.1, 5000.0, 0.0]).unwrap();
            let h = Ticks::from_seconds(1e-5).unwrap();
            let mut t = Ticks::ZERO;
            let advance = |s: &mut InterfaceSubsystem, t: &mut Ticks, n: usize| -> Vec<f64> {
                let mut out = Vec::new();
                for _ in 0..n {
                    assert_eq!(s.do_step(*t, h).unwrap(), lash_core::StepOutcome::Completed);
                    *t = Ticks(t.0 + h.0);
                    let mut v = [0.0; 4];
                    s.get_f64(&[vr::CONTACT_FORCE, vr::ECCENTRICITY], &mut v).unwrap();
                    out.extend(v);
                }
                out
            };
            advance(&mut s, &mut t, 3);
            let saved = s.save_state().unwrap();
            let t_saved = t;
            let first = advance(&mut s, &mut t, 40);
            assert!(s.model.impacts.len() + s.model.open_impacts(0.0).len() >= 1, "{integrator:?}: an impact");
            s.restore_state(&saved).unwrap();
            t = t_saved;
            let again = advance(&mut s, &mut t, 40);
            assert!(first.iter().zip(&again).all(|(a, b)| a.to_bits() == b.to_bits()), "{integrator:?}");
        }
    }
}

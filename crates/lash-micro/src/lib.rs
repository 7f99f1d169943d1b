//! The micro subsystem of the reduced interface model: the clearance interface of every clearance
//! joint of a mechanism, `M̃(t) ẅ = f̃(t) + f_c(w, ẇ) + H(t) F_T(w, ẇ)` with state (w, ẇ), driven
//! by the macro subsystem's coupled effective mass M̃, effective force f̃ and friction-moment map
//! H (docs/theory.md §6, §8). Its size and kind come from the scenario: k planar revolute clearance
//! joints give n = 2k interface coordinates and k friction loads, k spherical ones n = 3k and 6k
//! ([`model::InterfaceModel`] over [`MicroJoint`], dispatched once at construction).
//!
//! Inputs arrive at each communication point as a value and a rate (FMI input derivatives, as
//! separate variables so FMI 3.0 carries them too): inside a step the model sees
//! `u(τ) = u(t) + u̇(t)(τ − t)`. With linear interpolation across the macro step the rate is the
//! slope of the segment, so the micro model follows the interpolant exactly; with cubic Hermite it
//! follows it to O(h_r²) per step.
//!
//! Two integrators: fixed-step RK4 (the reduced-interface-model papers' choice; one contact-law
//! evaluation per joint and stage, no allocation, no trigonometry), and error-controlled DOPRI5
//! with location of every joint's contact onset and exit.
//!
//! Variables: per-joint quantities are arrays of k elements (scalars when k = 1), interface
//! vectors have n elements, matrices are row-major; joint parameters are named as in the scenario
//! file, prefixed with the joint's name when there are several joints.

pub mod bushing;
pub mod guide;
pub mod joint;
pub mod lanes;
pub mod model;
pub mod spherical_lanes;
pub mod stages;

pub use bushing::BushingJoint;
pub use guide::GuideJoint;
pub use joint::MicroJoint;
use lash_contact::PenetrationError;
use lash_contact::clearance::{ClearanceJoint, Impact};
use lash_contact::joint::Clearance;
use lash_contact::parameters::ClearanceDefinition;
use lash_contact::spherical::SphericalClearance;
use lash_core::subsystem::{Causality, Phase, Variability, VariableTable, element_count, per_joint_shape, row_major};
use lash_core::{SavedState, StepOutcome, Steps, Subsystem, SubsystemError, Ticks, ValueReference, Variable};
use lash_ode::AdaptiveOptions;
pub use model::{InterfaceInputs, InterfaceModel, Loads, PLANAR_JOINT_COORDINATES, PlanarInputs, PlanarInterfaceModel};

/// Largest number of interface coordinates n the micro subsystem takes (six planar or four
/// spherical clearance joints).
pub const MAX_COORDINATES: usize = 12;

/// Largest number of friction loads (four spherical joints, three each; six planar, one each).
pub const MAX_FRICTION_LOADS: usize = 12;

/// Which integrator the micro model uses.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub enum MicroIntegrator {
    /// Classical RK4 with the given step \[s\]; a communication step is cut into whole steps.
    Rk4 {
        /// Step h_r \[s\].
        step: f64,
    },
    /// DOPRI5 with event location of contact onset and exit.
    Dopri5(AdaptiveOptions),
}

/// Value references of the interface subsystem's variables (in table order, numbered by the
/// declaration).
pub mod vr {
    use lash_core::ValueReference;
    lash_core::value_references! {
        /// Input M̃ (n × n); joints in mobility form ([`MicroJoint::MOBILITY_FORM`]): W = M̃⁻¹
        /// (`mobility`).
        EFFECTIVE_MASS,
        /// Input dM̃/dt (n × n); mobility form: dW/dt.
        EFFECTIVE_MASS_RATE,
        /// Input f̃ (n); mobility form: a_free = W f̃ (`free_acceleration`).
        EFFECTIVE_FORCE,
        /// Input df̃/dt (n); mobility form: da_free/dt.
        EFFECTIVE_FORCE_RATE,
        /// Input H (n × m): interface force equivalent to each friction load, per unit load;
        /// mobility form: G = W H (`friction_mobility`).
        FRICTION_MOMENT_FORCE,
        /// Input dH/dt (n × m); mobility form: dG/dt.
        FRICTION_MOMENT_FORCE_RATE,
        /// Input ω of each journal body (planar k; spherical 3k, world frame).
        JOURNAL_ANGULAR_VELOCITY,
        /// Input its rate.
        JOURNAL_ANGULAR_ACCELERATION,
        /// Input ω of each bearing body.
        BEARING_ANGULAR_VELOCITY,
        /// Input its rate. The last input.
        BEARING_ANGULAR_ACCELERATION,
        /// Output f_c on each journal (n).
        CONTACT_FORCE,
        /// Output ∫f_c dt (n).
        CONTACT_IMPULSE,
        /// Output F_N (k).
        NORMAL_FORCE,
        /// Output F_T (k).
        FRICTION_FORCE,
        /// Output: the friction loads L (m; planar F_T, spherical n × F_T of each joint).
        FRICTION_LOAD,
        /// Output ∫L dt (m).
        FRICTION_IMPULSE,
        /// Output e (n).
        ECCENTRICITY,
        /// Output ė (n).
        ECCENTRICITY_RATE,
        /// Output |e| (k).
        ECCENTRICITY_NORM,
        /// Output δ (k).
        PENETRATION,
        /// Output δ̇ (k).
        PENETRATION_RATE,
        /// Output v_t (k).
        SLIP_VELOCITY,
        /// Output: completed impacts (k).
        IMPACTS,
        /// Output: 1 in contact, 0 in free flight (k).
        IN_CONTACT,
        /// Local: radial clearance (k).
        RADIAL_CLEARANCE,
        /// Output |f_c| (k).
        CONTACT_FORCE_MAGNITUDE,
        /// Output: micro steps taken since initialization (DOPRI5: accepted steps).
        MICRO_STEPS,
        /// Output: each contact's F_N (k · contacts per joint: a translational joint's corners).
        CONTACT_NORMAL_FORCE,
        /// Output: each contact's δ.
        CONTACT_PENETRATION,
    }
    /// First parameter (with the joints' [`lash_contact::ClearanceDefinition`]s): each joint's
    /// `journal_radius`, `bearing_radius`, then its laws' numeric fields.
    pub const FIRST_PARAMETER: ValueReference = DECLARED;
}

/// The model of one kind and size.
#[derive(Clone)]
enum Core {
    C2(Box<PlanarInterfaceModel<2, 1>>),
    C4(Box<PlanarInterfaceModel<4, 2>>),
    C6(Box<PlanarInterfaceModel<6, 3>>),
    C8(Box<PlanarInterfaceModel<8, 4>>),
    C10(Box<PlanarInterfaceModel<10, 5>>),
    C12(Box<PlanarInterfaceModel<12, 6>>),
    S3(Box<InterfaceModel<SphericalClearance, 3, 1, 3, 3>>),
    S6(Box<InterfaceModel<SphericalClearance, 6, 2, 6, 6>>),
    S9(Box<InterfaceModel<SphericalClearance, 9, 3, 9, 9>>),
    S12(Box<InterfaceModel<SphericalClearance, 12, 4, 12, 12>>),
    B2(Box<InterfaceModel<BushingJoint, 2, 1, 1, 1>>),
    B4(Box<InterfaceModel<BushingJoint, 4, 2, 2, 2>>),
    B6(Box<InterfaceModel<BushingJoint, 6, 3, 3, 3>>),
    G2(Box<InterfaceModel<GuideJoint, 2, 1, 1, 1>>),
}

/// Runs `$body` with `$m` bound to the model of whichever kind and size `$core` holds.
macro_rules! each_core {
    ($core:expr, $m:ident => $body:expr) => {
        match $core {
            Core::C2($m) => $body,
            Core::C4($m) => $body,
            Core::C6($m) => $body,
            Core::C8($m) => $body,
            Core::C10($m) => $body,
            Core::C12($m) => $body,
            Core::S3($m) => $body,
            Core::S6($m) => $body,
            Core::S9($m) => $body,
            Core::S12($m) => $body,
            Core::B2($m) => $body,
            Core::B4($m) => $body,
            Core::B6($m) => $body,
            Core::G2($m) => $body,
        }
    };
}

/// Joints that a micro subsystem can be built of.
pub trait CoreJoint: MicroJoint + Sized {
    /// The model of `joints` (1 to the largest count of the kind).
    #[doc(hidden)]
    fn core(joints: Vec<Self>) -> Option<CoreBox>;
    /// Writes the definition's radii and laws into the joint (at initialization).
    fn apply(&mut self, d: &ClearanceDefinition);
}

/// The model behind a micro subsystem (opaque).
#[doc(hidden)]
pub struct CoreBox(Core);

/// [`CoreJoint`] of a clearance joint kind with radii and laws (its definition's), whose models
/// of 1, 2, … joints are the `Core` variants listed.
macro_rules! clearance_core_joint {
    ($joint:ty $(, $film:ident)?; $($count:literal => $variant:ident),+) => {
        impl CoreJoint for $joint {
            fn core(joints: Vec<Self>) -> Option<CoreBox> {
                Some(CoreBox(match joints.len() {
                    $($count => Core::$variant(Box::new(InterfaceModel::new(joints))),)+
                    _ => return None,
                }))
            }
            fn apply(&mut self, d: &ClearanceDefinition) {
                self.journal_radius = d.journal_radius;
                self.bearing_radius = d.bearing_radius;
                self.law = d.normal_force();
                self.friction = d.friction;
                $(self.$film = d.$film;)?
            }
        }
    };
}

clearance_core_joint!(ClearanceJoint, film; 1 => C2, 2 => C4, 3 => C6, 4 => C8, 5 => C10, 6 => C12);
clearance_core_joint!(SphericalClearance; 1 => S3, 2 => S6, 3 => S9, 4 => S12);

impl CoreJoint for BushingJoint {
    fn core(joints: Vec<Self>) -> Option<CoreBox> {
        Some(CoreBox(match joints.len() {
            1 => Core::B2(Box::new(InterfaceModel::new(joints))),
            2 => Core::B4(Box::new(InterfaceModel::new(joints))),
            3 => Core::B6(Box::new(InterfaceModel::new(joints))),
            _ => return None,
        }))
    }
    /// A bushing has no clearance definition (its stiffness and damping are its own).
    fn apply(&mut self, _d: &ClearanceDefinition) {}
}

impl CoreJoint for GuideJoint {
    fn core(joints: Vec<Self>) -> Option<CoreBox> {
        (joints.len() == 1).then(|| CoreBox(Core::G2(Box::new(InterfaceModel::new(joints)))))
    }
    /// A guide's block and laws are its own (no radii to resolve).
    fn apply(&mut self, _d: &ClearanceDefinition) {}
}

/// Applies resolved definitions to a model's joints, resets the contacts, and returns the first
/// joint whose journal starts outside its clearance.
fn apply_definitions<J: CoreJoint, const N: usize, const K: usize, const M: usize, const R: usize>(
    m: &mut InterfaceModel<J, N, K, M, R>,
    resolved: &[ClearanceDefinition],
    t: f64,
) -> Option<usize> {
    for (joint, d) in m.joints.iter_mut().zip(resolved) {
        joint.apply(d);
    }
    m.reset_contacts(t);
    m.states.iter().position(|s| J::penetration(s) > 0.0)
}

/// One RK4 step compiled as a function of its own: inlined into the loop below, the step ran ~10 %
/// slower in the coupled run (measured with `lash run A --model reduced`: 0.175 s against 0.158 s
/// for 10⁶ micro steps), while the isolated step in `lash bench` is fastest inlined into its loop.
#[inline(never)]
fn rk4_step_outlined<J: MicroJoint, const N: usize, const K: usize, const M: usize, const R: usize>(
    m: &mut InterfaceModel<J, N, K, M, R>,
    t: f64,
    h: f64,
) {
    m.rk4_step(t, h);
}

/// Whole RK4 micro steps (and a shorter remainder) from `t`; checks every joint's penetration
/// after each step. On failure: the time reached and the message.
fn rk4_steps<J: MicroJoint, const N: usize, const K: usize, const M: usize, const R: usize>(
    m: &mut InterfaceModel<J, N, K, M, R>,
    t: Ticks,
    step: Ticks,
    steps: i64,
    rest: i64,
) -> Result<(), (f64, PenetrationError)> {
    let mut now = t;
    for i in 0..steps + i64::from(rest > 0) {
        let dh = if i < steps { step } else { Ticks(rest) };
        rk4_step_outlined(m, now.seconds(), dh.seconds());
        now = Ticks(now.0 + dh.0);
        for j in 0..K {
            m.check_penetration(j).map_err(|e| (now.seconds(), e))?;
        }
    }
    Ok(())
}

/// `steps` RK4 micro steps of `m` from `t`, each followed by every joint's penetration check,
/// through the loop a run's micro subsystem compiles for a model of this size (the step called
/// out of line for one planar joint, inlined and in the CPU's widest instruction set for larger
/// models); nothing recorded. What `lash bench` times as the cost of a micro step. On failure:
/// the steps completed, the time reached and the message.
pub fn rk4_steps_as_in_a_run<J: MicroJoint, const N: usize, const K: usize, const M: usize, const R: usize>(
    m: &mut InterfaceModel<J, N, K, M, R>,
    t: Ticks,
    step: Ticks,
    steps: usize,
) -> Result<(), (usize, f64, PenetrationError)> {
    const CHUNK: [bool; 256] = [false; 256];
    let mut done = 0;
    while done < steps {
        let n = (steps - done).min(CHUNK.len());
        let start = Ticks(t.0 + done as i64 * step.0);
        rk4_recorded(m, start, step, &CHUNK[..n], (0, &[], &[]), &[], 0, &mut [])
            .map_err(|(i, at, e)| (done + i, at, e))?;
        done += n;
    }
    Ok(())
}

/// [`rk4_steps`] of one micro step each, `record.len()` of them, reading `refs` into the next row of
/// `rows` after each flagged step. On failure: the steps completed, the time reached and the
/// message.
#[allow(clippy::too_many_arguments)]
fn rk4_recorded<J: MicroJoint, const N: usize, const K: usize, const M: usize, const R: usize>(
    m: &mut InterfaceModel<J, N, K, M, R>,
    t: Ticks,
    step: Ticks,
    record: &[bool],
    context: (u64, &[f64], &[usize]),
    refs: &[ValueReference],
    width: usize,
    rows: &mut [f64],
) -> Result<(), (usize, f64, PenetrationError)> {
    if N == 2 {
        // One planar joint: the step outlined, in the baseline instruction set (the AVX2 copy
        // below, with the step inlined, measured 3 % slower on scenario A).
        return rk4_recorded_in::<J, N, K, M, R, false>(m, t, step, record, context, refs, width, rows);
    }
    // Larger models: the loop with the step inlined, compiled for the baseline, AVX2 and AVX-512
    // (multiversion detects the CPU's features once): the same IEEE operations in wider registers
    // and no fused multiply–add (Rust never fuses a product and a sum by itself), so the bits do
    // not depend on the CPU. E's micro part: 22.6 → 19.6 ms in AVX2, two planar joints (C) 9 %
    // faster; AVX-512 (32 registers) took E with four channels from 21.5–21.6 to 20.9–21.0 ms.
    rk4_recorded_dispatched(m, t, step, record, context, refs, width, rows)
}

/// [`rk4_recorded_in`] with the step inlined, in the widest instruction set the CPU has.
#[allow(clippy::too_many_arguments)]
#[multiversion::multiversion(targets("x86_64+avx512f+avx512vl+avx512dq", "x86_64+avx2"))]
fn rk4_recorded_dispatched<J: MicroJoint, const N: usize, const K: usize, const M: usize, const R: usize>(
    m: &mut InterfaceModel<J, N, K, M, R>,
    t: Ticks,
    step: Ticks,
    record: &[bool],
    context: (u64, &[f64], &[usize]),
    refs: &[ValueReference],
    width: usize,
    rows: &mut [f64],
) -> Result<(), (usize, f64, PenetrationError)> {
    rk4_recorded_in::<J, N, K, M, R, true>(m, t, step, record, context, refs, width, rows)
}

/// [`rk4_recorded`]'s loop, with the step inlined (`INLINE`) or called.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn rk4_recorded_in<
    J: MicroJoint,
    const N: usize,
    const K: usize,
    const M: usize,
    const R: usize,
    const INLINE: bool,
>(
    m: &mut InterfaceModel<J, N, K, M, R>,
    t: Ticks,
    step: Ticks,
    record: &[bool],
    (micro_steps, parameters, lens): (u64, &[f64], &[usize]),
    refs: &[ValueReference],
    width: usize,
    rows: &mut [f64],
) -> Result<(), (usize, f64, PenetrationError)> {
    let h = step.seconds();
    let mut row = 0;
    for (i, &flag) in record.iter().enumerate() {
        if INLINE {
            m.rk4_step(Ticks(t.0 + i as i64 * step.0).seconds(), h);
        } else {
            rk4_step_outlined(m, Ticks(t.0 + i as i64 * step.0).seconds(), h);
        }
        for j in 0..K {
            m.check_penetration(j).map_err(|e| (i, Ticks(t.0 + (i as i64 + 1) * step.0).seconds(), e))?;
        }
        if flag {
            let out = &mut rows[row * width..(row + 1) * width];
            read(m, micro_steps + i as u64 + 1, parameters, lens, refs, out);
            row += 1;
        }
    }
    Ok(())
}

/// [`Subsystem::do_steps`] of several micro subsystems (independent runs at the same point of
/// their runs, each with its inputs set), with the same results bit for bit: those stepped by RK4
/// at their own micro step whose joints run in lanes — one planar clearance joint
/// ([`lanes::lane_laws`]), or one to four spherical ones ([`spherical_lanes::ball_laws`]) — are
/// advanced [`lanes::LANES`] at a time in lockstep ([`lanes::advance`],
/// [`spherical_lanes::advance_balls`]), the lanes of a group alike in their joints and their
/// laws' kinds; the others, and the last group of a kind when it is not full, one by one.
/// `rows[i]` receives subsystem i's flagged rows as `do_steps` writes them. (The interface master
/// of runs stepped together hands them over by their type: lash-orchestrate's `GroupStep`.)
pub fn do_steps_together(
    subs: &mut [&mut InterfaceSubsystem],
    t: Ticks,
    h: Ticks,
    record: &[bool],
    refs: &[ValueReference],
    rows: &mut [&mut [f64]],
) -> Vec<Steps> {
    assert_eq!(subs.len(), rows.len(), "one row buffer per subsystem");
    let mut results: Vec<Option<Steps>> = (0..subs.len()).map(|_| None).collect();
    // Which subsystems can run in lanes, by their kind, with their row widths.
    let mut groups: Vec<(LaneGroup, Vec<(usize, usize)>)> = Vec::new();
    for (i, (micro, out)) in subs.iter_mut().zip(rows.iter_mut()).enumerate() {
        let fast = matches!(micro.integrator, MicroIntegrator::Rk4 { .. })
            && h == micro.micro_step
            && micro.phase == Phase::Stepping
            && t == micro.time;
        let (Some(kind), true) = (LaneGroup::of(&micro.core), fast) else { continue };
        let width = match lash_core::subsystem::recorded_rows(&micro.variables, record, refs, out) {
            Ok(w) => w,
            Err(e) => {
                results[i] = Some(Steps { taken: 0, last: Err(e) });
                continue;
            }
        };
        match groups.iter_mut().find(|(k, members)| *k == kind && members.len() < lanes::LANES) {
            Some((_, members)) => members.push((i, width)),
            None => groups.push((kind, vec![(i, width)])),
        }
    }
    for (kind, members) in groups.iter().filter(|(_, m)| m.len() == lanes::LANES) {
        let mut picked = pick(subs, rows, members);
        let at = [t; lanes::LANES];
        // (The spherical kinds alike but for their joint count.)
        macro_rules! balls {
            ($variant:ident, $laws:expr) => {
                in_lanes(
                    &mut picked,
                    refs,
                    |c| as_variant!(c, $variant),
                    |models, sample| spherical_lanes::advance_balls(models, $laws, at, h, record, sample),
                )
            };
        }
        let outcome = match *kind {
            LaneGroup::Planar(laws) => in_lanes(
                &mut picked,
                refs,
                |c| as_variant!(c, C2),
                |models, sample| lanes::advance(models, laws, at, h, record, sample),
            ),
            LaneGroup::Balls1(laws) => balls!(S3, laws),
            LaneGroup::Balls2(laws) => balls!(S6, laws),
            LaneGroup::Balls3(laws) => balls!(S9, laws),
            LaneGroup::Balls4(laws) => balls!(S12, laws),
        };
        for ((micro, _, _), (outcome, &(i, _))) in picked.iter_mut().zip(outcome.into_iter().zip(members)) {
            results[i] = Some(match outcome {
                Ok(()) => {
                    micro.micro_steps += record.len() as u64;
                    micro.time = Ticks(t.0 + record.len() as i64 * h.0);
                    Steps { taken: record.len(), last: Ok(StepOutcome::Completed) }
                }
                Err((taken, at, e)) => {
                    micro.micro_steps += taken as u64 + 1;
                    micro.phase = Phase::Failed;
                    Steps { taken, last: Err(SubsystemError::Simulation { t: at, message: e.to_string() }) }
                }
            });
        }
    }
    subs.iter_mut()
        .zip(rows.iter_mut())
        .zip(results)
        .map(|((sub, out), r)| r.unwrap_or_else(|| sub.do_steps(t, h, record, refs, out)))
        .collect()
}

/// What the micro models of a group of lanes share: their kind of joints and the laws' kinds.
#[derive(Debug, Clone, Copy, PartialEq)]
enum LaneGroup {
    Planar(lanes::LaneLaws),
    Balls1([lanes::LaneLaws; 1]),
    Balls2([lanes::LaneLaws; 2]),
    Balls3([lanes::LaneLaws; 3]),
    Balls4([lanes::LaneLaws; 4]),
}

impl LaneGroup {
    /// The group of a micro model that can run in lanes, or `None`.
    fn of(core: &Core) -> Option<Self> {
        use spherical_lanes::ball_laws;
        match core {
            Core::C2(m) => lanes::lane_laws(m).map(Self::Planar),
            Core::S3(m) => Some(Self::Balls1(ball_laws(m))),
            Core::S6(m) => Some(Self::Balls2(ball_laws(m))),
            Core::S9(m) => Some(Self::Balls3(ball_laws(m))),
            Core::S12(m) => Some(Self::Balls4(ball_laws(m))),
            _ => None,
        }
    }
}

/// The model of a core of variant `$variant` (grouped by it: any other is a bug).
macro_rules! as_variant {
    ($core:expr, $variant:ident) => {
        match $core {
            Core::$variant(m) => &mut **m,
            _ => unreachable!("grouped by the core's kind"),
        }
    };
}
use as_variant;

/// A group's members (subsystem index, row width) with their row buffers, taken apart from the
/// others.
fn pick<'a>(
    subs: &'a mut [&mut InterfaceSubsystem],
    rows: &'a mut [&mut [f64]],
    members: &[(usize, usize)],
) -> Vec<(&'a mut InterfaceSubsystem, &'a mut [f64], usize)> {
    let mut picked = Vec::with_capacity(members.len());
    let (mut rest, mut rows_rest, mut offset) = (subs, rows, 0);
    for &(i, width) in members {
        let (sub, sub_tail) = std::mem::take(&mut rest)[i - offset..].split_first_mut().expect("a member index");
        let (out, row_tail) = std::mem::take(&mut rows_rest)[i - offset..].split_first_mut().expect("a member index");
        picked.push((&mut **sub, &mut **out, width));
        (rest, rows_rest, offset) = (sub_tail, row_tail, i + 1);
    }
    picked
}

/// Steps a full group's models (`model_of` each subsystem's core) by `advance`, each flagged
/// step's outputs read into its rows as `do_steps` reads them.
fn in_lanes<J: MicroJoint, const N: usize, const K: usize, const M: usize, const R: usize>(
    picked: &mut [(&mut InterfaceSubsystem, &mut [f64], usize)],
    refs: &[ValueReference],
    model_of: impl Fn(&mut Core) -> &mut InterfaceModel<J, N, K, M, R>,
    advance: impl FnOnce(
        &mut [&mut InterfaceModel<J, N, K, M, R>; lanes::LANES],
        &mut dyn FnMut(usize, usize, &InterfaceModel<J, N, K, M, R>),
    ) -> [lanes::LaneOutcome; lanes::LANES],
) -> [lanes::LaneOutcome; lanes::LANES] {
    let mut contexts = Vec::with_capacity(lanes::LANES);
    let mut models = Vec::with_capacity(lanes::LANES);
    for (micro, out, width) in picked.iter_mut() {
        let InterfaceSubsystem { core, lens, parameter_values, micro_steps, .. } = &mut **micro;
        models.push(model_of(core));
        contexts.push((*micro_steps, &parameter_values[..], &lens[..], &mut **out, *width, 0usize));
    }
    let mut models: [_; lanes::LANES] = models.try_into().unwrap_or_else(|_| unreachable!("a full group"));
    advance(&mut models, &mut |l, i, m| {
        let (steps, parameters, lens, out, width, row) = &mut contexts[l];
        read(m, *steps + i as u64 + 1, parameters, lens, refs, &mut out[*row * *width..(*row + 1) * *width]);
        *row += 1;
    })
}

/// Writes input `r` (already checked: an input, finite, of the right length) into `u`.
fn set_input<J: MicroJoint, const N: usize, const K: usize, const M: usize, const R: usize>(
    model: &mut InterfaceModel<J, N, K, M, R>,
    r: ValueReference,
    v: &[f64],
) {
    fn matrix<const R: usize, const C: usize>(m: &mut nalgebra::SMatrix<f64, R, C>, v: &[f64]) {
        for (i, &x) in v.iter().enumerate() {
            m[(i / C, i % C)] = x;
        }
    }
    if J::MOBILITY_FORM {
        let p = &mut model.mobility;
        match r {
            vr::EFFECTIVE_MASS => return matrix(&mut p.mobility, v),
            vr::EFFECTIVE_MASS_RATE => return matrix(&mut p.mobility_rate, v),
            vr::EFFECTIVE_FORCE => return p.free_acceleration.copy_from_slice(v),
            vr::EFFECTIVE_FORCE_RATE => return p.free_acceleration_rate.copy_from_slice(v),
            vr::FRICTION_MOMENT_FORCE => return matrix(&mut p.friction_mobility, v),
            vr::FRICTION_MOMENT_FORCE_RATE => return matrix(&mut p.friction_mobility_rate, v),
            _ => {}
        }
    }
    let u = &mut model.inputs;
    match r {
        vr::EFFECTIVE_MASS => matrix(&mut u.effective_mass, v),
        vr::EFFECTIVE_MASS_RATE => matrix(&mut u.effective_mass_rate, v),
        vr::EFFECTIVE_FORCE => u.effective_force.copy_from_slice(v),
        vr::EFFECTIVE_FORCE_RATE => u.effective_force_rate.copy_from_slice(v),
        vr::FRICTION_MOMENT_FORCE => matrix(&mut u.friction_moment_force, v),
        vr::FRICTION_MOMENT_FORCE_RATE => matrix(&mut u.friction_moment_force_rate, v),
        vr::JOURNAL_ANGULAR_VELOCITY => u.journal_angular_velocity.copy_from_slice(v),
        vr::JOURNAL_ANGULAR_ACCELERATION => u.journal_angular_acceleration.copy_from_slice(v),
        vr::BEARING_ANGULAR_VELOCITY => u.bearing_angular_velocity.copy_from_slice(v),
        _ => u.bearing_angular_acceleration.copy_from_slice(v),
    }
}

/// One value per joint.
#[inline(always)]
fn each_joint(out: &mut [f64], f: impl Fn(usize) -> f64) {
    for (j, o) in out.iter_mut().enumerate() {
        *o = f(j);
    }
}

/// Reads every variable of `refs` (lengths checked) below the parameters into `values`;
/// parameters from `parameters`. Compiled per model size: one size-independent copy measured
/// 24 ns for the four outputs the reduced runner reads per sample, the per-size copies 18 ns.
fn read<J: MicroJoint, const N: usize, const K: usize, const M: usize, const R: usize>(
    model: &InterfaceModel<J, N, K, M, R>,
    micro_steps: u64,
    parameters: &[f64],
    lens: &[usize],
    refs: &[ValueReference],
    values: &mut [f64],
) {
    let (m, u, s) = (model, &model.inputs, &model.states);
    let mut at = 0;
    for &r in refs {
        let len = lens[r as usize];
        let out = &mut values[at..at + len];
        at += len;
        match r {
            vr::CONTACT_FORCE => {
                let d = J::COORDINATES;
                for (j, s) in s.iter().enumerate() {
                    for i in 0..d {
                        out[d * j + i] = J::force_component(s, i);
                    }
                }
            }
            vr::FRICTION_FORCE => each_joint(out, |j| J::friction_force(&s[j])),
            vr::FRICTION_LOAD => {
                let (d, l) = (J::COORDINATES, J::FRICTION_LOADS);
                let mut force = [0.0; 3];
                for (j, s) in s.iter().enumerate() {
                    m.joints[j].loads(s, &mut force[..d], &mut out[l * j..l * (j + 1)]);
                }
            }
            vr::CONTACT_IMPULSE => out.copy_from_slice(m.impulse.as_slice()),
            vr::NORMAL_FORCE => each_joint(out, |j| J::normal_force(&s[j])),
            vr::FRICTION_IMPULSE => out.copy_from_slice(m.friction_impulse.as_slice()),
            vr::ECCENTRICITY => out.copy_from_slice(m.eccentricity.as_slice()),
            vr::ECCENTRICITY_RATE => out.copy_from_slice(m.eccentricity_rate.as_slice()),
            vr::ECCENTRICITY_NORM => each_joint(out, |j| J::eccentricity_norm(&s[j])),
            vr::PENETRATION => each_joint(out, |j| J::penetration(&s[j])),
            vr::PENETRATION_RATE => each_joint(out, |j| J::penetration_rate(&s[j])),
            vr::SLIP_VELOCITY => each_joint(out, |j| J::slip(&s[j])),
            vr::IMPACTS => each_joint(out, |j| {
                m.impacts[j * J::CONTACTS..(j + 1) * J::CONTACTS].iter().map(Vec::len).sum::<usize>() as f64
            }),
            vr::IN_CONTACT => each_joint(out, |j| if m.joints[j].in_contact() { 1.0 } else { 0.0 }),
            vr::RADIAL_CLEARANCE => each_joint(out, |j| m.joints[j].radial_clearance()),
            vr::CONTACT_FORCE_MAGNITUDE => each_joint(out, |j| m.joints[j].force_magnitude(&s[j])),
            vr::MICRO_STEPS => out[0] = micro_steps as f64,
            vr::CONTACT_NORMAL_FORCE | vr::CONTACT_PENETRATION => {
                for (j, s) in s.iter().enumerate() {
                    for k in 0..J::CONTACTS {
                        let (force, penetration) = J::contact_sample(s, k);
                        out[j * J::CONTACTS + k] = if r == vr::CONTACT_NORMAL_FORCE { force } else { penetration };
                    }
                }
            }
            vr::EFFECTIVE_MASS..=vr::FRICTION_MOMENT_FORCE_RATE if J::MOBILITY_FORM => {
                let p = &m.mobility;
                match r {
                    vr::EFFECTIVE_MASS => row_major(out, p.mobility.as_slice(), N),
                    vr::EFFECTIVE_MASS_RATE => row_major(out, p.mobility_rate.as_slice(), N),
                    vr::EFFECTIVE_FORCE => out.copy_from_slice(p.free_acceleration.as_slice()),
                    vr::EFFECTIVE_FORCE_RATE => out.copy_from_slice(p.free_acceleration_rate.as_slice()),
                    vr::FRICTION_MOMENT_FORCE => row_major(out, p.friction_mobility.as_slice(), N),
                    _ => row_major(out, p.friction_mobility_rate.as_slice(), N),
                }
            }
            vr::EFFECTIVE_MASS => row_major(out, u.effective_mass.as_slice(), N),
            vr::EFFECTIVE_MASS_RATE => row_major(out, u.effective_mass_rate.as_slice(), N),
            vr::EFFECTIVE_FORCE => out.copy_from_slice(u.effective_force.as_slice()),
            vr::EFFECTIVE_FORCE_RATE => out.copy_from_slice(u.effective_force_rate.as_slice()),
            vr::FRICTION_MOMENT_FORCE => row_major(out, u.friction_moment_force.as_slice(), N),
            vr::FRICTION_MOMENT_FORCE_RATE => row_major(out, u.friction_moment_force_rate.as_slice(), N),
            vr::JOURNAL_ANGULAR_VELOCITY => out.copy_from_slice(&u.journal_angular_velocity),
            vr::JOURNAL_ANGULAR_ACCELERATION => out.copy_from_slice(&u.journal_angular_acceleration),
            vr::BEARING_ANGULAR_VELOCITY => out.copy_from_slice(&u.bearing_angular_velocity),
            vr::BEARING_ANGULAR_ACCELERATION => out.copy_from_slice(&u.bearing_angular_acceleration),
            _ => out[0] = parameters[(r - vr::FIRST_PARAMETER) as usize],
        }
    }
}

/// The clearance interface of a mechanism's clearance joints as a [`Subsystem`] (the micro
/// subsystem).
#[derive(Clone)]
pub struct InterfaceSubsystem {
    name: String,
    variables: Vec<Variable>,
    lens: Vec<usize>,
    core: Core,
    integrator: MicroIntegrator,
    micro_step: Ticks,
    time: Ticks,
    phase: Phase,
    /// Each joint's definition and the range of its parameters in `parameter_values`.
    definitions: Vec<(ClearanceDefinition, std::ops::Range<usize>)>,
    parameter_values: Vec<f64>,
    micro_steps: u64,
}

impl InterfaceSubsystem {
    /// A micro subsystem for `joints`, centred and at rest relative to their bearings.
    pub fn new<J: CoreJoint>(joints: Vec<J>, integrator: MicroIntegrator) -> Result<Self, SubsystemError> {
        Self::with_definitions(joints, integrator, Vec::new())
    }

    /// As [`InterfaceSubsystem::new`], with the joints' definitions (one per joint, or none): their
    /// radii and law coefficients become parameters (value references from
    /// [`vr::FIRST_PARAMETER`] on), which may be set before `initialize`, where they are checked
    /// and resolved into the joints.
    pub fn with_definitions<J: CoreJoint>(
        joints: Vec<J>,
        integrator: MicroIntegrator,
        definitions: Vec<ClearanceDefinition>,
    ) -> Result<Self, SubsystemError> {
        let micro_step = checked_micro_step(&joints, integrator)?;
        if !definitions.is_empty() && definitions.len() != joints.len() {
            return Err(SubsystemError::BadArguments(format!(
                "{} definitions for {} clearance joints",
                definitions.len(),
                joints.len()
            )));
        }
        let k = joints.len();
        let core = J::core(joints.clone())
            .ok_or_else(|| SubsystemError::BadValue {
                name: "clearance joints".into(),
                problem: format!(
                    "{k} clearance joints of {} coordinates each: the micro subsystem takes 1 to {}",
                    J::COORDINATES,
                    MAX_COORDINATES / J::COORDINATES
                ),
            })?
            .0;
        let mut t = VariableTable::new();
        add_coupled_terms::<J>(&mut t, k);
        add_outputs(&mut t, &joints);
        let (definitions, parameter_values) = add_parameters(&mut t, &joints, definitions);
        let variables = t.into_checked_variables().map_err(|m| SubsystemError::Other(format!("internal: {m}")))?;
        let names: Vec<&str> = joints.iter().map(|j| j.name()).collect();
        Ok(Self {
            name: format!("interface {}", names.join(", ")),
            lens: variables.iter().map(Variable::len).collect(),
            variables,
            core,
            integrator,
            micro_step,
            time: Ticks::ZERO,
            phase: Phase::Instantiated,
            definitions,
            parameter_values,
            micro_steps: 0,
        })
    }

    /// The integrator it was built with.
    pub fn integrator(&self) -> MicroIntegrator {
        self.integrator
    }

    /// Number of clearance joints k.
    pub fn joint_count(&self) -> usize {
        each_core!(&self.core, m => m.joint_count())
    }

    /// The joints' names.
    pub fn joint_names(&self) -> Vec<String> {
        each_core!(&self.core, m => m.joints.iter().map(|j| j.name().to_string()).collect())
    }

    /// Adds `delta` (one number per interface coordinate) to the eccentricity rates while
    /// stepping — the process noise of a filter that tracks the interface from a measurement.
    pub fn perturb_rates(&mut self, delta: &[f64]) -> Result<(), SubsystemError> {
        self.phase.require("perturb_rates", &[Phase::Stepping])?;
        let n = each_core!(&self.core, m => m.eccentricity_rate.len());
        if delta.len() != n || delta.iter().any(|d| !d.is_finite()) {
            return Err(SubsystemError::BadArguments(format!(
                "perturb_rates takes {n} finite numbers, got {} ({:?})",
                delta.len(),
                delta.iter().find(|d| !d.is_finite())
            )));
        }
        let t = self.time.seconds();
        each_core!(&mut self.core, m => m.add_to_rates(t, delta));
        Ok(())
    }

    /// Joint `j`'s radial clearance \[m\] (resolved after `initialize`).
    pub fn radial_clearance(&self, j: usize) -> f64 {
        each_core!(&self.core, m => m.joints[j].radial_clearance())
    }

    /// The planar clearance joints (with their parameters resolved after `initialize`); `None`
    /// for spherical ones.
    pub fn planar_joints(&self) -> Option<&[ClearanceJoint]> {
        match &self.core {
            Core::C2(m) => Some(&m.joints),
            Core::C4(m) => Some(&m.joints),
            Core::C6(m) => Some(&m.joints),
            Core::C8(m) => Some(&m.joints),
            Core::C10(m) => Some(&m.joints),
            Core::C12(m) => Some(&m.joints),
            _ => None,
        }
    }

    /// The contacts' names: a joint's own name where it has one contact, its name and the
    /// contact's ("slider_guide corner 1") where it has several (a translational joint's
    /// corners), joint by joint.
    pub fn contact_names(&self) -> Vec<String> {
        fn names<J: MicroJoint>(joints: &[J]) -> Vec<String> {
            let mut out = Vec::new();
            for j in joints {
                for k in 0..J::CONTACTS {
                    out.push(if J::CONTACTS == 1 {
                        j.name().to_string()
                    } else {
                        format!("{} corner {}", j.name(), k + 1)
                    });
                }
            }
            out
        }
        each_core!(&self.core, m => names(&m.joints))
    }

    /// Contact `c`'s completed impacts (in the order of [`InterfaceSubsystem::contact_names`];
    /// joint j's where each joint has one contact).
    pub fn impacts(&self, c: usize) -> &[Impact] {
        each_core!(&self.core, m => &m.impacts[c])
    }

    /// Contact `c`'s impact still open at `t` (closed at `t` for reporting, exit time NaN).
    pub fn open_impacts(&self, c: usize, t: f64) -> Vec<Impact> {
        each_core!(&self.core, m => m.open_impacts(c, t))
    }

    /// The stacked eccentricities w (n) \[m\].
    pub fn eccentricity(&self) -> &[f64] {
        each_core!(&self.core, m => m.eccentricity.as_slice())
    }
}

/// The micro step of `integrator` in ticks (0 for DOPRI5), checked against what the joints need:
/// a bush damped in series needs RK4 at a step within its relaxation time, several contacts per
/// joint need RK4.
fn checked_micro_step<J: CoreJoint>(joints: &[J], integrator: MicroIntegrator) -> Result<Ticks, SubsystemError> {
    let micro_step = match integrator {
        MicroIntegrator::Rk4 { step } => Ticks::from_seconds(step)
            .map_err(|e| SubsystemError::BadValue { name: "micro_step".into(), problem: e.to_string() })?,
        MicroIntegrator::Dopri5(_) => Ticks(0),
    };
    if matches!(integrator, MicroIntegrator::Rk4 { .. }) && micro_step.0 <= 0 {
        return Err(SubsystemError::BadValue { name: "micro_step".into(), problem: "must be > 0".into() });
    }
    // A bush damped in series is a state integrated by the micro RK4 with the eccentricities:
    // its relaxation time c/k must not be shorter than the step (RK4 is stable for steps up
    // to 2.8 times the fastest time constant, (c + D)/(k + k_c) ≥ c/(k + k_c); with a contact
    // as stiff as the bush, c/k ≥ h keeps h under 2 of them).
    if let Some(j) = joints.iter().find(|j| j.damped_in_series()) {
        let tau = j.relaxation_time();
        match integrator {
            MicroIntegrator::Dopri5(_) => {
                return Err(SubsystemError::BadValue {
                    name: "micro integrator".into(),
                    problem: format!(
                        "clearance joint {:?} has a bush damped in series (c/k = {tau:.2e} s), a state the DOPRI5 \
                         micro integrator does not carry yet; use RK4",
                        j.name()
                    ),
                });
            }
            MicroIntegrator::Rk4 { step } if step > tau => {
                return Err(SubsystemError::BadValue {
                    name: "micro_step".into(),
                    problem: format!(
                        "{step:e} s is longer than the relaxation time c/k = {tau:.2e} s of the bush damped in series \
                         of clearance joint {:?}: RK4 would not be stable; give a micro step of at most {tau:.2e} s",
                        j.name()
                    ),
                });
            }
            MicroIntegrator::Rk4 { .. } => {}
        }
    }
    if J::CONTACTS > 1 && matches!(integrator, MicroIntegrator::Dopri5(_)) {
        return Err(SubsystemError::BadValue {
            name: "micro integrator".into(),
            problem: format!(
                "{} {:?} has {} contacts, whose events the DOPRI5 micro integrator does not locate yet; use RK4",
                J::KIND,
                joints[0].name(),
                J::CONTACTS
            ),
        });
    }
    Ok(micro_step)
}

/// The coupled terms the macro subsystem sets (inputs): M̃, f̃ and the friction loads' columns
/// with their rates (in mobility form where the joint asks for it), and the bodies' rates.
fn add_coupled_terms<J: CoreJoint>(t: &mut VariableTable, k: usize) {
    use Causality::Input;
    use Variability::Continuous as C;
    let (n, loads, rotations) = (k * J::COORDINATES, k * J::FRICTION_LOADS, k * J::ROTATIONS);
    let eye: Vec<f64> = (0..n * n).map(|i| if i / n == i % n { 1.0 } else { 0.0 }).collect();
    let map = per_joint_shape(loads, &[n]);
    let per_rotation = per_joint_shape(rotations, &[]);
    // The same slots in either form; the mobility form's terms are those of `model::Mobility`.
    let named: [(&str, &str, &str); 6] = if J::MOBILITY_FORM {
        [
            ("mobility", "1/kg", "interface mobility W = inverse of M~"),
            ("mobility_rate", "1/(kg.s)", "dW/dt"),
            ("free_acceleration", "m/s^2", "interface acceleration with f_c = 0 (W f~)"),
            ("free_acceleration_rate", "m/s^3", "its rate"),
            ("friction_mobility", "1/kg", "interface acceleration per unit friction load (W H)"),
            ("friction_mobility_rate", "1/(kg.s)", "its rate"),
        ]
    } else {
        [
            ("effective_mass", "kg", "effective mass M~ of the interface"),
            ("effective_mass_rate", "kg/s", "dM~/dt"),
            ("effective_force", "N", "effective force f~ on the journals"),
            ("effective_force_rate", "N/s", "df~/dt"),
            (
                "friction_moment_force",
                "1",
                "force on the journals equivalent to each friction load's moments, per unit load (M~ W_T)",
            ),
            ("friction_moment_force_rate", "1/s", "its rate"),
        ]
    };
    let slots: [(ValueReference, &[usize], &[f64]); 6] = [
        (vr::EFFECTIVE_MASS, &[n, n], &eye),
        (vr::EFFECTIVE_MASS_RATE, &[n, n], &[0.0]),
        (vr::EFFECTIVE_FORCE, &[n], &[0.0]),
        (vr::EFFECTIVE_FORCE_RATE, &[n], &[0.0]),
        (vr::FRICTION_MOMENT_FORCE, &map, &[0.0]),
        (vr::FRICTION_MOMENT_FORCE_RATE, &map, &[0.0]),
    ];
    for ((vr, shape, start), (name, unit, description)) in slots.into_iter().zip(named) {
        t.add_at(vr, name, Input, C, unit, description, shape, start);
    }
    lash_mech::subsystem::add_body_rates(
        t,
        [
            vr::JOURNAL_ANGULAR_VELOCITY,
            vr::JOURNAL_ANGULAR_ACCELERATION,
            vr::BEARING_ANGULAR_VELOCITY,
            vr::BEARING_ANGULAR_ACCELERATION,
        ],
        Input,
        &per_rotation,
    );
}

/// The micro subsystem's outputs: contact and friction loads, the eccentricities, each contact's
/// force and penetration, the counts.
fn add_outputs<J: CoreJoint>(t: &mut VariableTable, joints: &[J]) {
    use Causality::{Local, Output};
    use Variability::{Continuous as C, Discrete as D, Fixed};
    let k = joints.len();
    let (n, loads) = (k * J::COORDINATES, k * J::FRICTION_LOADS);
    let pj = per_joint_shape(k, &[]);
    let per_load = per_joint_shape(loads, &[]);
    t.add_at(vr::CONTACT_FORCE, "contact_force", Output, C, "N", "contact force f_c on the journal", &[n], &[0.0]);
    t.add_at(vr::CONTACT_IMPULSE, "contact_impulse", Output, C, "N.s", "integral of f_c since the start", &[n], &[0.0]);
    t.add_at(vr::NORMAL_FORCE, "normal_force", Output, C, "N", "normal contact force F_N", &pj, &[0.0]);
    t.add_at(vr::FRICTION_FORCE, "friction_force", Output, C, "N", "friction force F_T", &pj, &[0.0]);
    let load_description = if J::FRICTION_LOADS == 1 {
        "friction loads: each joint's friction force F_T"
    } else {
        "friction loads: each joint's n x F_T (world; the torques are R_J n x F_T on the journal's body and \
         -R_B n x F_T on the bearing's)"
    };
    t.add_at(vr::FRICTION_LOAD, "friction_load", Output, C, "N", load_description, &per_load, &[0.0]);
    t.add_at(
        vr::FRICTION_IMPULSE,
        "friction_impulse",
        Output,
        C,
        "N.s",
        "integral of the friction loads since the start",
        &per_load,
        &[0.0],
    );
    t.add_at(vr::ECCENTRICITY, "eccentricity", Output, C, "m", "journal centre minus bearing centre", &[n], &[0.0]);
    t.add_at(vr::ECCENTRICITY_RATE, "eccentricity_rate", Output, C, "m/s", "its rate", &[n], &[0.0]);
    t.add_at(vr::ECCENTRICITY_NORM, "eccentricity_norm", Output, C, "m", "|e|", &pj, &[0.0]);
    let clearances: Vec<f64> = joints.iter().map(|j| j.radial_clearance()).collect();
    let minus: Vec<f64> = clearances.iter().map(|c| -c).collect();
    t.add_at(vr::PENETRATION, "penetration", Output, C, "m", "|e| - c", &pj, &minus);
    t.add_at(vr::PENETRATION_RATE, "penetration_rate", Output, C, "m/s", "d(penetration)/dt", &pj, &[0.0]);
    t.add_at(vr::SLIP_VELOCITY, "slip_velocity", Output, C, "m/s", "relative tangential velocity", &pj, &[0.0]);
    t.add_at(vr::IMPACTS, "impacts", Output, D, "1", "completed impacts", &pj, &[0.0]);
    t.add_at(vr::IN_CONTACT, "in_contact", Output, D, "1", "1 in contact, 0 in free flight", &pj, &[0.0]);
    t.add_at(vr::RADIAL_CLEARANCE, "radial_clearance", Local, Fixed, "m", "c = R_B - R_J", &pj, &clearances);
    t.add_at(vr::CONTACT_FORCE_MAGNITUDE, "contact_force_magnitude", Output, C, "N", "|f_c|", &pj, &[0.0]);
    t.add_at(
        vr::MICRO_STEPS,
        "micro_steps",
        Output,
        D,
        "1",
        "micro steps taken since initialization (RK4: h / h_r per step; DOPRI5: accepted steps)",
        &[],
        &[0.0],
    );
    let per_contact = per_joint_shape(k * J::CONTACTS, &[]);
    let (force, penetration) = (vr::CONTACT_NORMAL_FORCE, vr::CONTACT_PENETRATION);
    t.add_at(force, "contact_normal_force", Output, C, "N", "each contact's F_N", &per_contact, &[0.0]);
    let minus_per_contact: Vec<f64> = minus.iter().flat_map(|&m| std::iter::repeat_n(m, J::CONTACTS)).collect();
    let description = "each contact's penetration";
    t.add_at(penetration, "contact_penetration", Output, C, "m", description, &per_contact, &minus_per_contact);
}

/// Each joint's definition's parameters as variables (named `joint.parameter` where there are
/// several joints): the definitions with the range of their values, and the values.
#[allow(clippy::type_complexity)]
fn add_parameters<J: CoreJoint>(
    t: &mut VariableTable,
    joints: &[J],
    definitions: Vec<ClearanceDefinition>,
) -> (Vec<(ClearanceDefinition, std::ops::Range<usize>)>, Vec<f64>) {
    let k = joints.len();
    let mut parameter_values = Vec::new();
    let mut ranges = Vec::with_capacity(definitions.len());
    for (joint, definition) in joints.iter().zip(definitions) {
        let from = parameter_values.len();
        for p in definition.parameters() {
            let name = if k > 1 { format!("{}.{}", joint.name(), p.name) } else { p.name.clone() };
            t.add(
                &name,
                Causality::Parameter,
                Variability::Fixed,
                p.unit,
                "clearance joint parameter (as in the scenario file)",
                &[],
                &[p.value],
            );
            parameter_values.push(p.value);
        }
        ranges.push((definition, from..parameter_values.len()));
    }
    (ranges, parameter_values)
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
        each_core!(&mut self.core, m => m.input_time = start.seconds());
        self.phase = Phase::Configured;
        Ok(())
    }

    fn initialize(&mut self) -> Result<(), SubsystemError> {
        self.phase.require("initialize", &[Phase::Configured])?;
        let mut resolved = Vec::with_capacity(self.definitions.len());
        for (definition, range) in &self.definitions {
            let d = definition.with_values(&self.parameter_values[range.clone()]).map_err(|problems| {
                SubsystemError::BadValue {
                    name: "parameters".into(),
                    problem: problems.0.iter().map(ToString::to_string).collect::<Vec<_>>().join("; "),
                }
            })?;
            resolved.push(d);
        }
        let t = self.time.seconds();
        let inside = each_core!(&mut self.core, m => apply_definitions(m, &resolved, t));
        if let Some(j) = inside {
            return Err(SubsystemError::BadValue {
                name: "eccentricity".into(),
                problem: format!(
                    "the initial eccentricity of clearance joint {:?} exceeds its radial clearance",
                    self.joint_names()[j]
                ),
            });
        }
        self.phase = Phase::Stepping;
        Ok(())
    }

    fn set_f64(&mut self, refs: &[ValueReference], values: &[f64]) -> Result<(), SubsystemError> {
        self.phase.require("set_f64", &[Phase::Configured, Phase::Stepping])?;
        // Everything is checked before anything is applied (no partial update on error).
        let mut inputs: [(ValueReference, usize, usize); 10] = [(0, 0, 0); 10];
        let mut input_count = 0;
        let mut parameters: Vec<(ValueReference, f64)> = Vec::new();
        let mut at = 0;
        for &r in refs {
            let len = *self.lens.get(r as usize).ok_or(SubsystemError::UnknownValueReference(r))?;
            let Some(v) = values.get(at..at + len) else {
                let n = element_count(&self.variables, refs)?;
                return Err(SubsystemError::BadArguments(format!("{} values for {} elements", values.len(), n)));
            };
            let name = || self.variables[r as usize].name.clone();
            if r >= vr::FIRST_PARAMETER {
                if self.phase != Phase::Configured {
                    return Err(SubsystemError::BadValue {
                        name: name(),
                        problem: "is a parameter (fixed): set it before initialization".into(),
                    });
                }
                if !v[0].is_finite() {
                    return Err(SubsystemError::BadValue { name: name(), problem: format!("{} is not finite", v[0]) });
                }
                parameters.push((r, v[0]));
            } else if r > vr::BEARING_ANGULAR_ACCELERATION {
                return Err(SubsystemError::BadValue { name: name(), problem: "is not an input".into() });
            } else if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
                return Err(SubsystemError::BadValue { name: name(), problem: format!("{bad} is not finite") });
            } else {
                if input_count == inputs.len() {
                    return Err(SubsystemError::BadArguments("an input given more than once".into()));
                }
                inputs[input_count] = (r, at, len);
                input_count += 1;
            }
            at += len;
        }
        if at != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {} elements", values.len(), at)));
        }
        let t = self.time.seconds();
        let first = self.phase == Phase::Stepping && self.micro_steps == 0;
        each_core!(&mut self.core, m => {
            for &(r, from, len) in &inputs[..input_count] {
                set_input(m, r, &values[from..from + len]);
            }
            m.input_time = t;
            // Bushings start at rest where they hold the first interface force (as the full
            // model starts deflected by its quasi-static load): no ringing from an unloaded start.
            if first {
                m.settle(t);
            }
        });
        for (r, v) in parameters {
            self.parameter_values[(r - vr::FIRST_PARAMETER) as usize] = v;
        }
        Ok(())
    }

    fn get_f64(&self, refs: &[ValueReference], values: &mut [f64]) -> Result<(), SubsystemError> {
        let mut count = 0;
        for &r in refs {
            count += *self.lens.get(r as usize).ok_or(SubsystemError::UnknownValueReference(r))?;
        }
        if count != values.len() {
            return Err(SubsystemError::BadArguments(format!("{} values for {} elements", values.len(), count)));
        }
        let (lens, parameters) = (&self.lens, &self.parameter_values);
        each_core!(&self.core, m => read(m, self.micro_steps, parameters, lens, refs, values));
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
        let result = match self.integrator {
            MicroIntegrator::Rk4 { .. } => {
                // Whole micro steps; a remainder (a communication step that is not a multiple) is
                // taken as one shorter step.
                let (steps, rest) = if h == self.micro_step {
                    (1, 0) // the master's usual call: no division
                } else {
                    (h.0 / self.micro_step.0, h.0 % self.micro_step.0)
                };
                self.micro_steps += (steps + i64::from(rest > 0)) as u64;
                let step = self.micro_step;
                each_core!(&mut self.core, m => rk4_steps(m, t, step, steps, rest)).map_err(|(t, e)| (t, e.to_string()))
            }
            MicroIntegrator::Dopri5(options) => {
                each_core!(&mut self.core, m => m.dopri5_step(&options, t.seconds(), h.seconds()))
                    .map(|steps| self.micro_steps += steps)
                    .map_err(|e| (t.seconds(), lash_core::error_chain(&e)))
            }
        };
        if let Err((t, message)) = result {
            self.phase = Phase::Failed;
            return Err(SubsystemError::Simulation { t, message });
        }
        self.time = Ticks(t.0 + h.0);
        Ok(StepOutcome::Completed)
    }

    /// RK4 at its own micro step: the steps are taken in one loop over the model, each flagged
    /// one's outputs read from it directly (the same arithmetic as one `do_step` and `get_f64`
    /// per step: results are bit-identical). Otherwise one step at a time.
    fn do_steps(&mut self, t: Ticks, h: Ticks, record: &[bool], refs: &[ValueReference], rows: &mut [f64]) -> Steps {
        let fast = matches!(self.integrator, MicroIntegrator::Rk4 { .. })
            && h == self.micro_step
            && self.phase == Phase::Stepping
            && t == self.time;
        if !fast {
            return lash_core::subsystem::steps_one_by_one(self, t, h, record, refs, rows);
        }
        let width = match lash_core::subsystem::recorded_rows(&self.variables, record, refs, rows) {
            Ok(w) => w,
            Err(e) => return Steps { taken: 0, last: Err(e) },
        };
        let Self { core, lens, parameter_values, micro_steps, .. } = self;
        let context = (*micro_steps, &parameter_values[..], &lens[..]);
        let result = each_core!(core, m => rk4_recorded(m, t, h, record, context, refs, width, rows));
        match result {
            Ok(()) => {
                let taken = record.len();
                self.micro_steps += taken as u64;
                self.time = Ticks(t.0 + taken as i64 * h.0);
                Steps { taken, last: Ok(StepOutcome::Completed) }
            }
            Err((taken, t, e)) => {
                self.micro_steps += taken as u64 + 1;
                self.phase = Phase::Failed;
                Steps { taken, last: Err(SubsystemError::Simulation { t, message: e.to_string() }) }
            }
        }
    }

    fn time(&self) -> Ticks {
        self.time
    }

    fn save_state(&self) -> Result<SavedState, SubsystemError> {
        Ok(SavedState(Box::new((self.core.clone(), self.time, self.phase, self.micro_steps))))
    }

    fn restore_state(&mut self, state: &SavedState) -> Result<(), SubsystemError> {
        let (core, time, phase, micro_steps) = state
            .0
            .downcast_ref::<(Core, Ticks, Phase, u64)>()
            .ok_or_else(|| SubsystemError::Other("the saved state is not an interface subsystem's".into()))?;
        self.core = core.clone();
        self.time = *time;
        self.phase = *phase;
        self.micro_steps = *micro_steps;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lash_contact::{FrictionLaw, NormalForce};
    use lash_mech::{BodyId, Vec2};
    use nalgebra::Matrix2;

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
            bush_stiffness: f64::INFINITY,
            bush_damping: 0.0,
            film: None,
            in_contact: false,
            onset_velocity: 0.0,
        }
    }

    /// The loop `lash bench` times (`rk4_steps_as_in_a_run`: one joint's step out of line, two
    /// joints' inlined in the widest instruction set) leaves the model where as many plain
    /// `rk4_step` calls do, bit for bit, through impacts and settled contact.
    #[test]
    fn the_benchmarked_loop_is_the_plain_step() {
        fn check<const N: usize, const K: usize>(inputs: PlanarInputs<N, K>) {
            let joints: Vec<ClearanceJoint> =
                (0..K).map(|j| ClearanceJoint { name: format!("pin{j}"), ..joint() }).collect();
            let (mut a, mut b) =
                (PlanarInterfaceModel::<N, K>::new(joints.clone()), PlanarInterfaceModel::<N, K>::new(joints));
            a.inputs = inputs;
            b.inputs = inputs;
            let h = Ticks::from_seconds(1e-5).unwrap();
            let steps = 3000;
            rk4_steps_as_in_a_run(&mut a, Ticks::ZERO, h, steps).unwrap();
            for k in 0..steps {
                b.rk4_step(Ticks(k as i64 * h.0).seconds(), h.seconds());
            }
            assert!(b.states.iter().any(|s| s.penetration > 0.0), "the journals reach the wall");
            assert_eq!(a.eccentricity, b.eccentricity);
            assert_eq!(a.eccentricity_rate, b.eccentricity_rate);
        }
        let mut one = PlanarInputs::<2, 1> {
            effective_mass: Matrix2::new(0.33, 0.01, 0.01, 0.21),
            effective_force: nalgebra::Vector2::new(-900.0, 300.0),
            ..Default::default()
        };
        one.journal_angular_velocity[0] = 523.6;
        check(one);
        #[rustfmt::skip]
        let two = PlanarInputs::<4, 2> {
            effective_mass: nalgebra::Matrix4::new(
                0.33, 0.01, 0.05, 0.0, 0.01, 0.21, 0.0, 0.04, 0.05, 0.0, 0.40, 0.02, 0.0, 0.04, 0.02, 0.25,
            ),
            effective_force: nalgebra::Vector4::new(-900.0, 300.0, 700.0, -500.0),
            ..Default::default()
        };
        check(two);
    }

    fn ready(integrator: MicroIntegrator) -> InterfaceSubsystem {
        let mut s = InterfaceSubsystem::new(vec![joint()], integrator).unwrap();
        s.setup(Ticks::ZERO, None).unwrap();
        s.initialize().unwrap();
        s
    }

    /// Twelve micro subsystems stepped together — eight of one laws' kind in lanes, four of
    /// another kind (too few for a group) one by one — give each one's rows, outputs and time as
    /// it gives them stepped alone, bit for bit, through intervals with impacts.
    #[test]
    fn subsystems_stepped_together_equal_each_stepped_alone() {
        let make = |l: usize| {
            let mut j = joint();
            j.bearing_radius += 2e-5 * l as f64;
            // (A velocity floor that keeps grazing impacts from stiffening the damping.)
            j.law = NormalForce::Hysteresis { stiffness: 1e10, exponent: 1.5, chi: 0.2, floor: 1e-2 };
            if l % 3 == 1 {
                j.friction = FrictionLaw::Ambrosio { coefficient: 0.1, v0: 1e-4, v1: 1e-3 };
            }
            let mut s = InterfaceSubsystem::new(vec![j], MicroIntegrator::Rk4 { step: 1e-5 }).unwrap();
            s.setup(Ticks::ZERO, None).unwrap();
            s.initialize().unwrap();
            s
        };
        let (mut together, mut alone): (Vec<_>, Vec<_>) = ((0..12).map(make).collect(), (0..12).map(make).collect());
        let outputs: Vec<ValueReference> = together[0]
            .variables()
            .iter()
            .filter(|v| v.causality == Causality::Output)
            .map(|v| v.value_reference)
            .collect();
        let width = element_count(together[0].variables(), &outputs).unwrap();
        let inputs: Vec<ValueReference> = (vr::EFFECTIVE_MASS..=vr::BEARING_ANGULAR_ACCELERATION).collect();
        let h = Ticks::from_seconds(1e-5).unwrap();
        let record: Vec<bool> = (0..100).map(|i| i % 10 == 9).collect();
        for k in 0..40 {
            let t = Ticks(k * 100 * h.0);
            for (l, (a, b)) in together.iter_mut().zip(alone.iter_mut()).enumerate() {
                let angle = 0.4 * k as f64 + l as f64;
                let magnitude = if (k / 5) % 3 == 2 { -600.0 } else { 900.0 + 40.0 * l as f64 };
                #[rustfmt::skip]
                let values = [
                    0.33, 0.01, 0.01, 0.21, // M̃
                    2.0, 0.1, 0.1, -1.0, // dM̃/dt
                    magnitude * angle.cos(), magnitude * angle.sin(), // f̃
                    -2e4 * angle.sin(), 2e4 * angle.cos(), // df̃/dt
                    -0.5, 0.2, 0.01, 0.0, // H, dH/dt
                    523.6, 100.0, -10.0, 0.0, // ω and ω̇ of journal and bearing
                ];
                // (A run that blew up refuses inputs, alone as together.)
                assert_eq!(a.set_f64(&inputs, &values).is_ok(), b.set_f64(&inputs, &values).is_ok(), "{l}");
            }
            let mut rows_together = vec![vec![0.0; 10 * width]; 12];
            let mut subs: Vec<&mut InterfaceSubsystem> = together.iter_mut().collect();
            let mut outs: Vec<&mut [f64]> = rows_together.iter_mut().map(|r| &mut r[..]).collect();
            let steps = do_steps_together(&mut subs, t, h, &record, &outputs, &mut outs);
            for (l, b) in alone.iter_mut().enumerate() {
                let mut rows = vec![0.0; 10 * width];
                let expected = b.do_steps(t, h, &record, &outputs, &mut rows);
                assert_eq!((steps[l].taken, steps[l].last.is_ok()), (expected.taken, expected.last.is_ok()), "{l}");
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&rows_together[l]), bits(&rows), "interval {k}, subsystem {l}");
            }
        }
        for (a, b) in together.iter().zip(&alone) {
            let (mut x, mut y) = (vec![0.0; width], vec![0.0; width]);
            a.get_f64(&outputs, &mut x).unwrap();
            b.get_f64(&outputs, &mut y).unwrap();
            assert_eq!(
                x.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                y.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
            );
            assert_eq!(a.time(), b.time());
        }
        let impacts = |s: &InterfaceSubsystem| match &s.core {
            Core::C2(m) => m.impacts[0].len(),
            _ => 0,
        };
        assert!(alone.iter().map(impacts).sum::<usize>() >= 12, "the inputs should make impacts");
        let failed = together.iter().filter(|s| s.phase == Phase::Failed).count();
        assert!(failed <= 2, "{failed} of the runs blew up: the comparison should be of running ones");
    }

    #[test]
    fn parameters_are_set_before_initialization_only_and_checked_there() {
        let definition = lash_contact::ClearanceDefinition {
            journal_radius: 0.0099,
            bearing_radius: 0.01,
            contact: lash_contact::ContactLaw::Hertz { stiffness: Some(1e10), exponent: 1.5 },
            friction: FrictionLaw::Coulomb { coefficient: 0.1 },
            journal_material: lash_contact::Material::STEEL,
            bearing_material: lash_contact::Material::STEEL,
            film: None,
        };
        let mut s = InterfaceSubsystem::with_definitions(
            vec![joint()],
            MicroIntegrator::Rk4 { step: 1e-5 },
            vec![definition.clone()],
        )
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
        assert_eq!(s.planar_joints().unwrap()[0].friction, FrictionLaw::Coulomb { coefficient: 0.3 });
        assert_eq!(s.planar_joints().unwrap()[0].law, NormalForce::Power { stiffness: 1e10, exponent: 1.5 });
        // Fixed after initialization.
        let e = s.set_f64(&[mu], &[0.2]).unwrap_err().to_string();
        assert!(e.contains("friction.coefficient") && e.contains("before initialization"), "{e}");
        // A bad value is named at initialization.
        let mut s =
            InterfaceSubsystem::with_definitions(vec![joint()], MicroIntegrator::Rk4 { step: 1e-5 }, vec![definition])
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
        let mut values = [0.0; 20];
        values[..4].copy_from_slice(&[m[(0, 0)], m[(0, 1)], m[(1, 0)], m[(1, 1)]]);
        values[8..10].copy_from_slice(f.as_slice());
        values[10..12].copy_from_slice(fd.as_slice());
        s.set_f64(&(0..10).collect::<Vec<_>>(), &values).unwrap();
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
        let mut fresh = InterfaceSubsystem::new(vec![joint()], MicroIntegrator::Rk4 { step: 1e-5 }).unwrap();
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
        assert!(InterfaceSubsystem::new(vec![joint()], MicroIntegrator::Rk4 { step: 0.0 }).is_err());
        assert!(InterfaceSubsystem::new(vec![joint()], MicroIntegrator::Rk4 { step: f64::NAN }).is_err());
    }

    #[test]
    fn matrix_inputs_read_back_in_the_row_major_layout_they_were_set_in() {
        // Two joints: M~ is 4×4 and H = M~ W_T is 4×2 (not square: rows and columns cannot be
        // swapped unnoticed).
        let mut second = joint();
        second.name = "second".into();
        let mut s = InterfaceSubsystem::new(vec![joint(), second], MicroIntegrator::Rk4 { step: 1e-5 }).unwrap();
        s.setup(Ticks::ZERO, None).unwrap();
        s.initialize().unwrap();
        let mass: Vec<f64> = (0..16).map(|i| i as f64 + 0.5).collect();
        let map: Vec<f64> = (0..8).map(|i| 10.0 * i as f64 - 3.0).collect();
        s.set_f64(&[vr::EFFECTIVE_MASS, vr::FRICTION_MOMENT_FORCE_RATE], &[mass.clone(), map.clone()].concat())
            .unwrap();
        let mut back = vec![0.0; 24];
        s.get_f64(&[vr::EFFECTIVE_MASS, vr::FRICTION_MOMENT_FORCE_RATE], &mut back).unwrap();
        assert_eq!(back, [mass, map].concat());
        each_core!(&s.core, m => {
            assert_eq!(m.inputs.effective_mass.shape(), (4, 4));
            assert_eq!(m.inputs.effective_mass[(1, 0)], 4.5); // row 1, column 0 = element 4
            assert_eq!(m.inputs.friction_moment_force_rate[(3, 0)], 57.0); // row 3, column 0 = element 6
        });
    }

    #[test]
    fn steps_in_one_call_equal_steps_one_at_a_time_bit_for_bit() {
        // An impact, then a failure (a force that drives the journal through the bearing): the
        // batched path and the provided loop of do_step + get_f64 give the same rows, the same
        // count of completed steps and the same error.
        let h = Ticks::from_seconds(1e-5).unwrap();
        let refs = [vr::CONTACT_FORCE, vr::FRICTION_LOAD, vr::ECCENTRICITY_NORM, vr::MICRO_STEPS];
        let width = 5;
        let record: Vec<bool> = (0..300).map(|i| i % 3 != 1).collect();
        let flagged = record.iter().filter(|&&r| r).count();
        let run = |batched: bool, force: f64| {
            let mut s = ready(MicroIntegrator::Rk4 { step: 1e-5 });
            s.set_f64(&[vr::EFFECTIVE_MASS, vr::EFFECTIVE_FORCE], &[0.1, 0.0, 0.0, 0.1, force, 0.0]).unwrap();
            let mut rows = vec![0.0; flagged * width];
            let steps = if batched {
                s.do_steps(Ticks::ZERO, h, &record, &refs, &mut rows)
            } else {
                lash_core::subsystem::steps_one_by_one(&mut s, Ticks::ZERO, h, &record, &refs, &mut rows)
            };
            (steps.taken, steps.last.map_err(|e| e.to_string()), rows, s.time(), s.impacts(0).len())
        };
        let (taken, last, rows, time, impacts) = run(true, 5000.0);
        assert_eq!((taken, &last, time), (300, &Ok(StepOutcome::Completed), Ticks(300 * h.0)));
        assert!(impacts >= 1);
        assert_eq!(rows[width - 1], 1.0, "micro_steps after the first step");
        let again = run(false, 5000.0);
        assert_eq!((again.0, &again.1, again.3, again.4), (taken, &last, time, impacts));
        assert!(rows.iter().zip(&again.2).all(|(a, b)| a.to_bits() == b.to_bits()));
        let (taken, last, rows, ..) = run(true, 5e9);
        let again = run(false, 5e9);
        assert!(taken < 300 && last.as_ref().is_err_and(|e| e.contains("penetration")), "{taken} {last:?}");
        assert_eq!((again.0, &again.1), (taken, &last));
        assert!(rows.iter().zip(&again.2).all(|(a, b)| a.to_bits() == b.to_bits()));
    }

    #[test]
    fn restoring_a_saved_state_replays_the_same_impact_bit_for_bit() {
        for integrator in [
            MicroIntegrator::Rk4 { step: 1e-6 },
            MicroIntegrator::Dopri5(AdaptiveOptions {
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
            assert!(s.impacts(0).len() + s.open_impacts(0, 0.0).len() >= 1, "{integrator:?}: an impact");
            s.restore_state(&saved).unwrap();
            t = t_saved;
            let again = advance(&mut s, &mut t, 40);
            assert!(first.iter().zip(&again).all(|(a, b)| a.to_bits() == b.to_bits()), "{integrator:?}");
        }
    }
}

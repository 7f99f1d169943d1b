//! Sampling of the output channels, shared by the full and the reduced model: every sample fills
//! all channel values from (q, q̇, q̈, λ, contact states), updates the statistics and hands the
//! selected columns to the sink.

use crate::run::{ChannelStats, ClearanceSummary, Sink};
use lash_contact::{Impact, SlotState};
use lash_core::BoxError;
use lash_full_model::FullModel;
use lash_mech::{BodyId, Mechanism, Vec2, driver_torque, kinematics, point_kinematics};
use lash_scenario::channels::{Channel, Source};
use std::collections::BTreeMap;

/// Quantity `quantity` (fx, fy, |f|, |d|) of the `k`-th bushing among the mechanism's loads.
fn bushing_value(mech: &Mechanism, q: &[f64], qd: &[f64], k: usize, quantity: u8) -> f64 {
    let mut bushings = mech.loads.iter().filter_map(|l| match l {
        lash_mech::Load::Bushing { body_i, point_i, body_j, point_j, stiffness, damping, curve } => {
            Some((*body_i, *point_i, *body_j, *point_j, (*stiffness, curve.as_ref()), *damping))
        }
        _ => None,
    });
    let Some((bi, pi, bj, pj, spring, c)) = bushings.nth(k) else { return f64::NAN };
    let (pose_i, pose_j) = (lash_mech::Pose::of(bi, q, qd), lash_mech::Pose::of(bj, q, qd));
    let (s, _, _) = lash_mech::bushing_state(&pose_i, pi, &pose_j, pj, spring, c);
    [s.force.x, s.force.y, s.force.norm(), s.deflection.norm()][quantity as usize]
}

/// Quantity `quantity` of a guide's channels ([`lash_scenario::channels::GUIDE_QUANTITIES`]).
fn guide_value(state: &SlotState, quantity: u8) -> f64 {
    let f = state.force_on_block();
    match quantity {
        0 => f.x,
        1 => f.y,
        2 => state.offset,
        3 => state.tilt,
        4..=7 => state.corners[quantity as usize - 4].normal_force,
        _ => state.corners[quantity as usize - 8].penetration,
    }
}

/// Channel sampler with running statistics.
pub(crate) struct Recorder<'a> {
    sources: &'a [(Channel, Source)],
    selected: &'a [usize],
    sensors: Vec<(BodyId, Vec2)>,
    sensor_values: Vec<[f64; 6]>,
    values: Vec<f64>,
    row: Vec<f64>,
    stats: RunningStats,
    pub samples: u64,
    pub max_constraint_error: f64,
    max_eccentricity: Vec<f64>,
    sum_force: Vec<f64>,
    stresses: &'a [Option<std::sync::Arc<lash_bush::InterfaceStress>>],
}

impl<'a> Recorder<'a> {
    /// A recorder of `contacts` contacts (the full model's: one per clearance joint, four per
    /// guide).
    pub fn new(
        sources: &'a [(Channel, Source)],
        selected: &'a [usize],
        sensors: Vec<(BodyId, Vec2)>,
        contacts: usize,
    ) -> Self {
        Self {
            sources,
            selected,
            sensor_values: vec![[0.0; 6]; sensors.len()],
            sensors,
            values: vec![0.0; sources.len()],
            row: vec![0.0; selected.len() + 1],
            stats: RunningStats::new(sources.len()),
            samples: 0,
            max_constraint_error: 0.0,
            max_eccentricity: vec![0.0; contacts],
            sum_force: vec![0.0; contacts],
            stresses: &[],
        }
    }

    /// The interface-stress model of each clearance joint (for its `von_mises` channel).
    pub fn with_stresses(mut self, stresses: &'a [Option<std::sync::Arc<lash_bush::InterfaceStress>>]) -> Self {
        self.stresses = stresses;
        self
    }

    /// Records one sample of `model`, evaluated at (q, q̇): its solver holds the state's
    /// constraint terms, q̈ and λ.
    pub fn record(&mut self, t: f64, model: &FullModel, q: &[f64], qd: &[f64], sink: Sink<'_>) -> Result<(), BoxError> {
        let (mech, solver, contacts) = (&model.mechanism, &model.solver, &model.contacts);
        let qdd = &solver.accelerations;
        for (k, (body, point)) in self.sensors.iter().enumerate() {
            let p = point_kinematics(q, qd, qdd, *body, *point);
            self.sensor_values[k] =
                [p.position.x, p.position.y, p.velocity.x, p.velocity.y, p.acceleration.x, p.acceleration.y];
        }
        for (v, (_, src)) in self.values.iter_mut().zip(self.sources) {
            *v = match *src {
                Source::Sensor(k, quantity) => self.sensor_values[k][quantity as usize],
                Source::Clearance(k, quantity) => {
                    let c = &contacts[k];
                    [
                        c.force_on_journal.x,
                        c.force_on_journal.y,
                        c.force_on_journal.norm(),
                        c.normal_force,
                        c.friction_force,
                        c.eccentricity.x,
                        c.eccentricity.y,
                        c.eccentricity_norm,
                        c.penetration,
                        c.penetration_rate,
                        c.slip_velocity,
                    ][quantity as usize]
                }
                Source::DriverTorque(k) => driver_torque(mech, solver, k),
                Source::JointReaction(k, comp) => {
                    let r = kinematics::joint_reaction(mech, solver, k);
                    if comp == 0 { r.x } else { r.y }
                }
                Source::ConstraintError => solver.constraint_error(),
                Source::Bushing(k, quantity) => bushing_value(mech, q, qd, k, quantity),
                Source::InterfaceStress(k) => self
                    .stresses
                    .get(k)
                    .and_then(Option::as_ref)
                    .map_or(f64::NAN, |m| m.von_mises(contacts[k].normal_force)),
                Source::BodyPose(k, quantity) => lash_mech::Pose::coordinates(BodyId::Body(k), q)[quantity as usize],
                Source::Guide(k, quantity) => guide_value(&model.slot_contacts[k], quantity),
            };
        }
        for (k, c) in contacts.iter().enumerate() {
            self.max_eccentricity[k] = self.max_eccentricity[k].max(c.eccentricity_norm);
            self.sum_force[k] += c.force_on_journal.norm();
        }
        // A corner's "eccentricity" is its approach to its face from the centred block, δ + c.
        let corners = model.slots.iter().zip(&model.slot_contacts).flat_map(|(slot, state)| {
            state.corners.iter().map(move |c| (c.penetration + slot.clearance, c.force_on_block.norm()))
        });
        for (k, (approach, force)) in (contacts.len()..).zip(corners) {
            self.max_eccentricity[k] = self.max_eccentricity[k].max(approach);
            self.sum_force[k] += force;
        }
        self.max_constraint_error = self.max_constraint_error.max(solver.constraint_error());
        self.stats.add(&self.values);
        self.samples += 1;
        self.row[0] = t;
        for (r, &k) in self.row[1..].iter_mut().zip(self.selected) {
            *r = self.values[k];
        }
        sink(&self.row)
    }

    /// Every channel's value of the last sample.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Per-channel statistics.
    pub fn channel_stats(&self) -> BTreeMap<String, ChannelStats> {
        self.stats.channel_stats(self.sources.iter().map(|(c, _)| c), self.samples)
    }

    /// Summary of clearance joint `k` from its impacts (open ones included).
    pub fn clearance_summary(
        &self,
        k: usize,
        name: &str,
        radial_clearance: f64,
        impacts: Vec<Impact>,
        horizon: f64,
        period: Option<f64>,
    ) -> ClearanceSummary {
        ClearanceSummary::from_impacts(
            name.to_string(),
            radial_clearance,
            impacts,
            horizon,
            period,
            self.max_eccentricity[k],
            self.sum_force[k] / self.samples.max(1) as f64,
        )
    }
}

/// Running statistics of every channel (min, max, Σv, Σv²): the planar and spatial
/// runners' one accumulator, full and reduced. Kept as one array per statistic, so that adding a
/// sample is four passes the compiler vectorises (52 channels at every micro step of the spatial
/// reduced model: a tuple per channel cost ~22 instructions per channel and sample).
#[derive(Debug, Clone)]
pub(crate) struct RunningStats {
    min: Vec<f64>,
    max: Vec<f64>,
    sum: Vec<f64>,
    squares: Vec<f64>,
}

/// [`RunningStats::add_in`] compiled for the baseline, AVX2 and AVX-512 (`multiversion` detects
/// the CPU's features once and calls the widest copy).
#[multiversion::multiversion(targets("x86_64+avx512f+avx512vl+avx512dq", "x86_64+avx2"))]
fn add_dispatched(stats: &mut RunningStats, values: &[f64]) {
    stats.add_in(values)
}

impl RunningStats {
    /// No sample yet, `channels` channels.
    pub(crate) fn new(channels: usize) -> Self {
        Self {
            min: vec![f64::INFINITY; channels],
            max: vec![f64::NEG_INFINITY; channels],
            sum: vec![0.0; channels],
            squares: vec![0.0; channels],
        }
    }

    /// Adds one sample (one value per channel). With many channels, compiled for the baseline,
    /// AVX2 and AVX-512 (detected once): the same IEEE operations four or eight channels per
    /// instruction, so the same bits on any CPU.
    #[inline]
    pub(crate) fn add(&mut self, values: &[f64]) {
        if self.min.len() < 8 {
            return self.add_in(values);
        }
        add_dispatched(self, values)
    }

    /// [`RunningStats::add`] in the instruction set it was dispatched to.
    #[inline(always)]
    fn add_in(&mut self, values: &[f64]) {
        let n = self.min.len();
        let values = &values[..n];
        let (min, max) = (&mut self.min[..n], &mut self.max[..n]);
        for i in 0..n {
            min[i] = min[i].min(values[i]);
            max[i] = max[i].max(values[i]);
        }
        let (sum, squares) = (&mut self.sum[..n], &mut self.squares[..n]);
        for i in 0..n {
            sum[i] += values[i];
            squares[i] += values[i] * values[i];
        }
    }

    /// The statistics over `samples` added samples, by channel name.
    pub(crate) fn channel_stats<'a>(
        &self,
        channels: impl IntoIterator<Item = &'a Channel>,
        samples: u64,
    ) -> BTreeMap<String, ChannelStats> {
        let m = samples.max(1) as f64;
        channels
            .into_iter()
            .enumerate()
            .map(|(i, c)| {
                let (min, max) = (self.min[i], self.max[i]);
                (
                    c.name.clone(),
                    ChannelStats {
                        unit: c.unit,
                        min,
                        max,
                        max_abs: min.abs().max(max.abs()),
                        mean: self.sum[i] / m,
                        rms: (self.squares[i] / m).sqrt(),
                    },
                )
            })
            .collect()
    }
}

/// Adds to `recorded` (indices into `sources`) the eccentricity and force channels of the first
/// `joints` clearance joints, which a run's summary needs; `clearance` tells a source's joint and
/// quantity name when it is a clearance channel.
pub(crate) fn record_joint_summaries<S>(
    recorded: &mut Vec<usize>,
    sources: &[(Channel, S)],
    joints: usize,
    clearance: impl Fn(&S) -> Option<(usize, &'static str)>,
) {
    for j in 0..joints {
        for name in ["eccentricity", "force", "penetration"] {
            let k = sources
                .iter()
                .position(|(_, s)| clearance(s) == Some((j, name)))
                .expect("every clearance joint has its channels");
            if !recorded.contains(&k) {
                recorded.push(k);
            }
        }
    }
}

//! The flexible bush of a clearance joint, characterised by finite elements.
//!
//! A bush is an annulus a ≤ r ≤ b (bore a, outer radius b, length L) pressed into the bearing
//! body (its outer surface fixed) around a pin of radius R_pin < a. In plane strain, one FE model
//! (curved 9-node quadrilaterals, graded towards the bore and the loaded direction, [`mesh`],
//! [`fe`]) gives:
//!
//! * the **bonded-pin stiffness**: a rigid pin bonded to the bore, translated by U; the
//!   reaction F = k U. Checked against the closed form of an elastic annulus around a rigid
//!   inclusion, [`bonded_stiffness_closed_form`];
//! * the **Hertz-pressure stiffness as a function of the load**: the pin's Hertz line-contact
//!   pressure (half-width from the pin and bore radii and both materials, [`hertz`]) on the bore;
//!   the displacement that does work with it, u = ∫ p u_r ds / F', and k(F) = F / u;
//! * the **Kelvin–Voigt damping** of either shape: the viscous stress 2 η_s ė_dev + η_b tr(ė) I
//!   (shear and bulk viscosity) gives a damping matrix C = ∫ Bᵀ D_v B dA, reduced on the static
//!   shape φ of the load case: c = φᵀ C φ / u²;
//! * the **interface stress**: the largest von Mises stress of the FE field under the Hertz
//!   pressure against the half-space's (McEwen) — their ratio is the FE correction of the Hertz
//!   stress for this bush.
//!
//! The stiffness matrix is the same for every pressure load: it is assembled and factored
//! (symbolic and numeric) once, then solved for each load.

pub mod fe;
pub mod hertz;
pub mod mesh;

pub use fe::SolveError;
use fe::{Annulus, lame, plane_strain};
use hertz::LineContact;
use lash_core::Problems;
pub use mesh::{AnnulusMesh, MeshOptions};
use serde::{Deserialize, Serialize};

/// The bush's material: elastic and viscous.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BushMaterial {
    /// Young's modulus E \[Pa\].
    pub young_modulus: f64,
    /// Poisson's ratio ν [-].
    pub poisson_ratio: f64,
    /// Density ρ [kg/m³].
    pub density: f64,
    /// Shear viscosity η_s [Pa s].
    pub shear_viscosity: f64,
    /// Bulk viscosity η_b [Pa s].
    pub bulk_viscosity: f64,
}

impl BushMaterial {
    /// Tin bronze with the viscosities of the flexible-bush study (300 and 900 Pa s).
    pub const TIN_BRONZE: Self = Self {
        young_modulus: 110e9,
        poisson_ratio: 0.34,
        density: 8800.0,
        shear_viscosity: 300.0,
        bulk_viscosity: 900.0,
    };
}

/// An elastic material (the pin's).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Elastic {
    /// Young's modulus E \[Pa\].
    pub young_modulus: f64,
    /// Poisson's ratio ν [-].
    pub poisson_ratio: f64,
}

impl Elastic {
    /// Steel.
    pub const STEEL: Self = Self { young_modulus: 210e9, poisson_ratio: 0.3 };
}

fn steel() -> Elastic {
    Elastic::STEEL
}

/// A bush and the pin in it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BushSpec {
    /// Pin (journal) radius R_pin \[m\].
    pub pin_radius: f64,
    /// Bore radius a \[m\] (a − R_pin is the radial clearance).
    pub inner_radius: f64,
    /// Outer radius b \[m\] (fixed in the bearing body).
    pub outer_radius: f64,
    /// Length L along the pin \[m\].
    pub length: f64,
    /// The bush's material.
    pub material: BushMaterial,
    /// The pin's material (steel unless given).
    #[serde(default = "steel")]
    pub pin_material: Elastic,
    /// The FE mesh (the converged one unless given).
    #[serde(default)]
    pub mesh: MeshOptions,
}

impl BushSpec {
    /// The flexible bush of the crank–slider study read in millimetres: pin 10 mm, bore 11 mm,
    /// outer 20 mm, 32 mm long, tin bronze.
    pub fn study() -> Self {
        Self {
            pin_radius: 0.010,
            inner_radius: 0.011,
            outer_radius: 0.020,
            length: 0.032,
            material: BushMaterial::TIN_BRONZE,
            pin_material: Elastic::STEEL,
            mesh: MeshOptions::default(),
        }
    }

    /// Every problem, each naming its field (under `prefix`, e.g. `bush.`).
    pub fn check(&self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        let positive = |p: &mut Problems, name: &str, v: f64, unit: &str| {
            if !(v > 0.0 && v.is_finite()) {
                p.push(format!("{prefix}{name}"), format!("must be > 0 {unit}, got {v}"));
            }
        };
        positive(&mut p, "pin_radius", self.pin_radius, "m");
        positive(&mut p, "inner_radius", self.inner_radius, "m");
        positive(&mut p, "outer_radius", self.outer_radius, "m");
        positive(&mut p, "length", self.length, "m");
        if self.inner_radius < self.pin_radius {
            p.push(
                format!("{prefix}inner_radius"),
                format!("the bore ({} m) must not be smaller than the pin ({} m)", self.inner_radius, self.pin_radius),
            );
        }
        if self.outer_radius <= self.inner_radius {
            p.push(
                format!("{prefix}outer_radius"),
                format!("must exceed the bore radius {} m, got {}", self.inner_radius, self.outer_radius),
            );
        }
        for (name, m) in [
            ("material", (self.material.young_modulus, self.material.poisson_ratio)),
            ("pin_material", (self.pin_material.young_modulus, self.pin_material.poisson_ratio)),
        ] {
            positive(&mut p, &format!("{name}.young_modulus"), m.0, "Pa");
            if !(m.1 > -1.0 && m.1 < 0.5) {
                p.push(format!("{prefix}{name}.poisson_ratio"), format!("must lie in (−1, 0.5), got {}", m.1));
            }
        }
        positive(&mut p, "material.density", self.material.density, "kg/m^3");
        for (name, v) in
            [("shear_viscosity", self.material.shear_viscosity), ("bulk_viscosity", self.material.bulk_viscosity)]
        {
            if !(v >= 0.0 && v.is_finite()) {
                p.push(format!("{prefix}material.{name}"), format!("must be ≥ 0 Pa s, got {v}"));
            }
        }
        self.mesh.check(&format!("{prefix}mesh."), &mut p);
        p
    }

    /// Lamé parameters (λ, μ) of the bush.
    pub fn lame(&self) -> (f64, f64) {
        lame(self.material.young_modulus, self.material.poisson_ratio)
    }

    /// The viscous constitutive matrix: λ_v = η_b − 2η_s/3, μ_v = η_s.
    pub fn viscous_matrix(&self) -> [[f64; 3]; 3] {
        let m = &self.material;
        plane_strain(m.bulk_viscosity - 2.0 * m.shear_viscosity / 3.0, m.shear_viscosity)
    }

    /// The Hertz contact of load `load` \[N\] over the bush length.
    pub fn hertz(&self, load: f64) -> LineContact {
        let radius = hertz::effective_radius(self.pin_radius, self.inner_radius);
        let modulus = hertz::effective_modulus(
            self.material.young_modulus,
            self.material.poisson_ratio,
            self.pin_material.young_modulus,
            self.pin_material.poisson_ratio,
        );
        LineContact::new(load / self.length, radius, modulus)
    }
}

/// Stiffness per unit length of an elastic annulus (shear modulus μ, Poisson's ratio ν, plane
/// strain, κ = 3 − 4ν) between a rigid bonded inclusion of radius a and a fixed outer surface at
/// b, for a translation of the inclusion:
/// k' = 2πμκ(1 + κ) / [κ² ln(b/a) − (b² − a²)/(b² + a²)].
pub fn bonded_stiffness_closed_form(mu: f64, poisson: f64, a: f64, b: f64) -> f64 {
    let kappa = 3.0 - 4.0 * poisson;
    2.0 * std::f64::consts::PI * mu * kappa * (1.0 + kappa)
        / (kappa * kappa * (b / a).ln() - (b * b - a * a) / (b * b + a * a))
}

/// The bonded-pin load case.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BondedPin {
    /// FE stiffness k = F/U over the bush length [N/m].
    pub stiffness: f64,
    /// The closed form over the bush length [N/m].
    pub stiffness_closed_form: f64,
    /// Kelvin–Voigt damping on the static shape [N s/m].
    pub damping: f64,
}

/// One Hertz-pressure load case.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PressureCase {
    /// Load F \[N\].
    pub load: f64,
    /// Contact half-width b \[m\].
    pub half_width: f64,
    /// Peak Hertz pressure p₀ \[Pa\].
    pub peak_pressure: f64,
    /// Work-conjugate displacement u = ∫ p u_r ds / F' \[m\].
    pub displacement: f64,
    /// Secant stiffness F / u [N/m].
    pub stiffness: f64,
    /// Kelvin–Voigt damping on the static shape [N s/m].
    pub damping: f64,
    /// Largest von Mises stress of the FE field \[Pa\].
    pub von_mises: f64,
    /// Its depth below the bore \[m\].
    pub von_mises_depth: f64,
    /// The half-space's (Hertz, McEwen) largest von Mises stress \[Pa\].
    pub von_mises_hertz: f64,
    /// FE correction of the Hertz stress: von_mises / von_mises_hertz.
    pub correction: f64,
}

/// The characterisation of a bush.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BushTable {
    /// The bonded-pin case.
    pub bonded: BondedPin,
    /// The pressure cases, one per load.
    pub pressure: Vec<PressureCase>,
    /// Elements of the mesh.
    pub elements: usize,
    /// Free degrees of freedom of the pressure cases.
    pub unknowns: usize,
}

/// The bonded-pin case of `spec` (checked first): the stiffness and damping of a bushing whose
/// bore fits its pin. Computed once per bush in a process (a run or a sweep builds the same
/// bushing many times).
pub fn bonded_pin(spec: &BushSpec) -> Result<BondedPin, SolveError> {
    static CACHE: std::sync::Mutex<Vec<(BushSpec, BondedPin)>> = std::sync::Mutex::new(Vec::new());
    let cached = |cache: &Vec<(BushSpec, BondedPin)>| cache.iter().find(|(s, _)| s == spec).map(|(_, b)| *b);
    if let Some(hit) = cached(&CACHE.lock().unwrap_or_else(|e| e.into_inner())) {
        return Ok(hit);
    }
    let problems = spec.check("");
    if !problems.is_empty() {
        return Err(SolveError(format!("the bush: {problems}")));
    }
    let b = bonded(spec, &AnnulusMesh::new(spec.inner_radius, spec.outer_radius, &spec.mesh))?;
    CACHE.lock().unwrap_or_else(|e| e.into_inner()).push((*spec, b));
    Ok(b)
}

/// The bonded pin translated by U along x on `mesh`.
fn bonded(spec: &BushSpec, mesh: &AnnulusMesh) -> Result<BondedPin, SolveError> {
    let (a, b, length) = (spec.inner_radius, spec.outer_radius, spec.length);
    let (lambda, mu) = spec.lame();
    let model = Annulus::new(mesh.clone(), plane_strain(lambda, mu), true)?;
    let translation = 1e-6;
    let per_ring = mesh.nodes_per_ring();
    let u = model.solve(&|n| if n < per_ring { [translation, 0.0] } else { [0.0; 2] }, &[]);
    let f = model.internal_forces(&u, 0..2);
    let reaction: f64 = f[..per_ring].iter().map(|v| v[0]).sum();
    Ok(BondedPin {
        stiffness: reaction / translation * length,
        stiffness_closed_form: bonded_stiffness_closed_form(mu, spec.material.poisson_ratio, a, b) * length,
        damping: model.quadratic_form(&u, &spec.viscous_matrix()) / (translation * translation) * length,
    })
}

/// Characterises `spec` (checked first) for the Hertz loads `loads` \[N\].
pub fn characterise(spec: &BushSpec, loads: &[f64]) -> Result<BushTable, SolveError> {
    let problems = spec.check("");
    if !problems.is_empty() {
        return Err(SolveError(format!("the bush: {problems}")));
    }
    if let Some(bad) = loads.iter().find(|f| !(**f > 0.0 && f.is_finite())) {
        return Err(SolveError(format!("loads must be > 0 N, got {bad}")));
    }
    let (a, b, length) = (spec.inner_radius, spec.outer_radius, spec.length);
    let (lambda, mu) = spec.lame();
    let d = plane_strain(lambda, mu);
    let viscous = spec.viscous_matrix();
    let mesh = AnnulusMesh::new(a, b, &spec.mesh);
    let elements = mesh.radial_elements() * mesh.angular_elements();
    let bonded = bonded(spec, &mesh)?;

    // Hertz pressure at θ = 0, bore free: one factorisation for every load.
    let model = Annulus::new(mesh, d, false)?;
    let (peak_per_p0, depth_per_b) = hertz::max_von_mises(spec.material.poisson_ratio);
    let mut pressure = Vec::with_capacity(loads.len());
    for &load in loads {
        let contact = spec.hertz(load);
        let forces = pressure_forces(&model.mesh, &contact, a);
        let u = model.solve(&|_| [0.0; 2], &forces);
        let work: f64 = forces.chunks(2).zip(&u).map(|(f, v)| f[0] * v[0] + f[1] * v[1]).sum();
        let displacement = work / contact.load_per_length;
        let (von_mises, at_radius) = largest_von_mises(&model, &u, &contact, a);
        let von_mises_hertz = peak_per_p0 * contact.peak_pressure;
        let _ = depth_per_b;
        pressure.push(PressureCase {
            load,
            half_width: contact.half_width,
            peak_pressure: contact.peak_pressure,
            displacement,
            stiffness: load / displacement,
            damping: model.quadratic_form(&u, &viscous) / (displacement * displacement) * length,
            von_mises,
            von_mises_depth: at_radius - a,
            von_mises_hertz,
            correction: von_mises / von_mises_hertz,
        });
    }
    Ok(BushTable { bonded, pressure, elements, unknowns: model.free_count() })
}

/// Consistent nodal forces (2 per node) of the Hertz pressure centred at θ = 0 on the bore (the
/// pin pushing the bush outward along +x), per unit length.
fn pressure_forces(mesh: &AnnulusMesh, contact: &LineContact, a: f64) -> Vec<f64> {
    let mut forces = vec![0.0; 2 * mesh.node_count()];
    let reach = contact.half_width / a;
    for j in 0..mesh.angular_elements() {
        let (_, _, t0, t1) = mesh.element_extent(0, j);
        let (lo, hi) = (t0.max(-reach), t1.min(reach));
        if hi <= lo {
            continue;
        }
        let nodes = mesh.element_nodes(0, j);
        for &(x, w) in &fe::GAUSS8 {
            let theta = lo + 0.5 * (hi - lo) * (1.0 + x);
            let weight = w * 0.5 * (hi - lo) * a;
            let p = contact.pressure(a * theta);
            let eta = 2.0 * (theta - t0) / (t1 - t0) - 1.0;
            let (shape, _) = fe::lagrange(eta);
            let (s, c) = theta.sin_cos();
            for (k, n) in shape.iter().enumerate() {
                let node = nodes[k];
                forces[2 * node] += weight * n * p * c;
                forces[2 * node + 1] += weight * n * p * s;
            }
        }
    }
    forces
}

/// The largest von Mises stress (plane strain: σ_z = λ (ε_x + ε_y)) on a 6 × 6 grid of points in
/// each element near the patch, and the radius where it sits.
fn largest_von_mises(model: &Annulus, u: &[[f64; 2]], contact: &LineContact, a: f64) -> (f64, f64) {
    let mesh = &model.mesh;
    let d = &model.d;
    let reach_r = a + 4.0 * contact.half_width;
    let reach_t = 4.0 * contact.half_width / a;
    let (mut best, mut at) = (0.0, a);
    for i in 0..mesh.radial_elements() {
        for j in 0..mesh.angular_elements() {
            let extent = mesh.element_extent(i, j);
            if extent.0 > reach_r || extent.3 < -reach_t || extent.2 > reach_t {
                continue;
            }
            let ue = model.element_displacements(i, j, u);
            for p in 0..6 {
                for q in 0..6 {
                    let (xi, eta) = (-1.0 + (2 * p + 1) as f64 / 6.0, -1.0 + (2 * q + 1) as f64 / 6.0);
                    let point = fe::point(extent, xi, eta);
                    let e = fe::strain(&point, &ue);
                    let sx = d[0][0] * e[0] + d[0][1] * e[1];
                    let sy = d[1][0] * e[0] + d[1][1] * e[1];
                    let txy = d[2][2] * e[2];
                    let sz = d[0][1] * (e[0] + e[1]);
                    let vm =
                        (0.5 * ((sx - sy).powi(2) + (sy - sz).powi(2) + (sz - sx).powi(2)) + 3.0 * txy * txy).sqrt();
                    if vm > best {
                        best = vm;
                        at = point.r;
                    }
                }
            }
        }
    }
    (best, at)
}

/// The loads of a bush table when a file gives none \[N\].
pub const DEFAULT_LOADS: [f64; 7] = [100.0, 300.0, 1e3, 3e3, 1e4, 3e4, 5e4];

fn default_loads() -> Vec<f64> {
    DEFAULT_LOADS.to_vec()
}

/// A bush file: `[bush]` (a [`BushSpec`]) and the Hertz loads of the table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BushFile {
    /// The bush.
    pub bush: BushSpec,
    /// Hertz loads \[N\] (the default set unless given).
    #[serde(default = "default_loads")]
    pub loads: Vec<f64>,
}

impl BushFile {
    /// The study's bush with the default loads.
    pub fn study() -> Self {
        Self { bush: BushSpec::study(), loads: default_loads() }
    }

    /// Parses and checks a bush file: every problem with its field path.
    pub fn parse(text: &str) -> Result<Self, Problems> {
        let file: Self = toml::from_str(text).map_err(|e| {
            let mut p = Problems::new();
            p.push("file", e.to_string().trim_end().replace('\n', " "));
            p
        })?;
        let mut problems = file.bush.check("bush.");
        for (k, f) in file.loads.iter().enumerate() {
            if !(*f > 0.0 && f.is_finite()) {
                problems.push(format!("loads[{k}]"), format!("must be > 0 N, got {f}"));
            }
        }
        if problems.is_empty() { Ok(file) } else { Err(problems) }
    }
}

/// The pin–bush interface stress as a function of the contact's normal force: the Hertz line
/// contact's largest von Mises stress (∝ p₀ ∝ √F) times the FE correction of the bush, the
/// correction interpolated linearly in ln F between the loads of the bush's table (held at the
/// table's ends outside it).
#[derive(Debug, Clone, PartialEq)]
pub struct InterfaceStress {
    spec: BushSpec,
    peak_per_p0: f64,
    loads: Vec<f64>,
    corrections: Vec<f64>,
}

impl InterfaceStress {
    /// The stress model of `spec`: its FE table at [`DEFAULT_LOADS`] (computed once per bush in a
    /// process).
    pub fn of(spec: &BushSpec) -> Result<Self, SolveError> {
        static CACHE: std::sync::Mutex<Vec<InterfaceStress>> = std::sync::Mutex::new(Vec::new());
        let cached = |cache: &Vec<InterfaceStress>| cache.iter().find(|m| m.spec == *spec).cloned();
        if let Some(hit) = cached(&CACHE.lock().unwrap_or_else(|e| e.into_inner())) {
            return Ok(hit);
        }
        let table = characterise(spec, &DEFAULT_LOADS)?;
        let model = Self {
            spec: *spec,
            peak_per_p0: hertz::max_von_mises(spec.material.poisson_ratio).0,
            loads: table.pressure.iter().map(|p| p.load).collect(),
            corrections: table.pressure.iter().map(|p| p.correction).collect(),
        };
        CACHE.lock().unwrap_or_else(|e| e.into_inner()).push(model.clone());
        Ok(model)
    }

    /// The FE correction at normal force `force` \[N\].
    pub fn correction(&self, force: f64) -> f64 {
        let (l, c) = (&self.loads, &self.corrections);
        if force <= l[0] {
            return c[0];
        }
        if force >= l[l.len() - 1] {
            return c[c.len() - 1];
        }
        let k = l.iter().position(|x| *x > force).expect("inside the table") - 1;
        let s = (force / l[k]).ln() / (l[k + 1] / l[k]).ln();
        c[k] + s * (c[k + 1] - c[k])
    }

    /// Largest von Mises stress at the interface \[Pa\] under normal force `force` \[N\] (0 without
    /// contact).
    pub fn von_mises(&self, force: f64) -> f64 {
        if !(force > 0.0) {
            return 0.0;
        }
        self.correction(force) * self.peak_per_p0 * self.spec.hertz(force).peak_pressure
    }
}

//! Eigensoftening: gradual, non-local failure of quasi-brittle material points.
//!
//! - Stage: damage. Registration name: `damage/eigensoftening`. Needs a `neighbour/*` system.
//! - eigensoftening-lme-mpm.md §2.3 and Appendix B (Algorithm 2). For a particle not yet
//!   cracking, the equivalent stress `σ_ε,p = Σ_{q∈B_ε, χ_q<1} m_q σ_q,I / Σ_{q∈B_ε} m_q`
//!   (eq. 15, σ_I the largest principal stress; in plane strain the larger in-plane one, the
//!   only ones that open a through-thickness crack). When it exceeds `f_t` the particle records
//!   its largest principal strain `ε_f` (the crack onset). Afterwards
//!   `χ = min(1, max(χ_prev, χ_law((ε_I − ε_f) h_ε)))`: the opening `w = (ε_I − ε_f) h_ε`
//!   (eq. 18) goes through the chosen softening law (eqs. 17, 19, 20). The internal force of
//!   the particle is scaled by `1 − χ` by the force transfer (eq. 16).
//! - Jacobi: every particle reads its neighbours' damage from before this update, so the
//!   result does not depend on particle order.
//! - `average: Intact` divides the sum by the mass of the intact neighbours only: the mean
//!   largest principal stress of the material that still carries stress, where eq. (15) and
//!   Algorithm 2 (line 8 adds every neighbour's mass) count a failed neighbour's mass with no
//!   stress. The published average is diluted beside a crack or a seeded notch (a notch one
//!   band wide fills about a third of a tip particle's neighbourhood), so a crack does not
//!   start at a notch's tip but where fewer failed particles are in reach. The paper's code
//!   (NL-PartSol) does as the paper writes, and so does `average: Published`, the default.
//!   Measured on the semicircular bending tests at 2 mm/s (SCENES.md, "Quasi-static
//!   loading"): at 60° the published average starts the crack 3-7 mm behind the tip and the
//!   peak is 404 N, the intact average 347 N, against the experiments' 316 ± 20 N.
//! - The sum of eq. (15) is skipped for an intact particle that is not stretched or whose
//!   neighbourhood cannot reach `f_t` (a bound from binned stresses, `damage::stress_reach`,
//!   that holds for the rounded sum too): in a body mostly below its strength the damage update
//!   costs little, and no result changes.
//! - Onset needs a tensile largest principal strain (ε_I > 0): the onset strain is also the
//!   "has cracked" flag of Algorithm 2 (`ε_f > 0`).
//! - Publishes `series.csv` columns `damaged_particles` (χ > 0), `failed_particles` (χ = 1)
//!   and `dissipated_energy`: the crack-band estimate `Σ_p V₀,p / h_ε · ∫₀^{w_p} σ dw`. Each
//!   particle's largest opening `w_p` is its `CrackOpening` (frames: `crack_opening`). The
//!   damage a scene seeds (a notch's `cracks`) is left out: it did not dissipate in the run.
//!
//! # Traction
//!
//! - `traction: Published` (the default, the paper's Algorithm 2): the opening is the whole
//!   principal strain past onset, `w = (ε_I − ε_f) h_ε`, and `χ = χ_law(w)` scales the
//!   still-growing elastic stress. The traction a cracking point carries is then
//!   `(1 − χ(w)) E ε`, not `σ(w)`: a crack dissipates `G_F (1 + E w_c / (3 h_ε f_t) +
//!   f_t h_ε / (E w_c))` per unit area with the linear law (the last term is the elastic energy
//!   at onset, which the damage releases), and the stress can overshoot `f_t` when
//!   `w_c / h_ε > f_t / E`.
//! - `traction: Cohesive`: the band's normal strain is split into an elastic part and a crack
//!   part, `ε = t / M + w / h_ε`, with `M = λ + 2μ` the normal modulus and one traction
//!   `t = σ(w)` (`SofteningLaw::cohesive_opening`). With `σ_I` the undamaged largest principal
//!   stress, `w` solves `σ(w) + M w / h_ε = σ_I` and `χ = 1 − σ(w) / σ_I`, so the force
//!   transfer's `(1 − χ) σ_I` is exactly the law's traction. The band's work is then
//!   `∫ t dε = [t² / 2M] + ∫ σ dw / h_ε`: its elastic energy comes back as the traction falls
//!   to zero, and it dissipates `G_F / h_ε` per unit volume, `G_F` per unit crack area. χ (and
//!   `w`) never decrease: unloading is secant, towards the origin. The scalar χ scales every
//!   stress component, as in the published scheme. The band must be narrower than the
//!   snap-back limit `M / max|σ'(w)|` (checked when the scene is built); a wider band cannot
//!   follow the law.

use super::softening::{SofteningLaw, SofteningShape};
use super::stress_reach::StressReach;
use fractum_engine::decomposition::{Owned, OwnedRows};
use fractum_engine::prelude::*;
use rayon::prelude::*;
use serde::Deserialize;

/// Registration of `damage/eigensoftening`.
pub const REGISTRATION: Registration = Registration {
    name: "damage/eigensoftening",
    summary: "eigensoftening (Algorithm 2): non-local onset at f_t, cohesive softening over a band h_ε",
    params: &[
        ParamDoc {
            name: "tensile_strength",
            ty: "f64",
            default: None,
            doc: "f_t (Pa)",
        },
        ParamDoc {
            name: "fracture_energy",
            ty: "f64",
            default: Some("none: give this or critical_opening"),
            doc: "G_F (J/m²); give this or critical_opening",
        },
        ParamDoc {
            name: "critical_opening",
            ty: "f64",
            default: Some("none: give this or fracture_energy"),
            doc: "w_c (m), converted to G_F through the law's shape",
        },
        ParamDoc {
            name: "band_width",
            ty: "f64",
            default: None,
            doc: "h_ε (m), typically 2-4 aggregate sizes",
        },
        ParamDoc {
            name: "softening",
            ty: "Linear | Exponential | Bilinear",
            default: Some("Linear"),
            doc: "shape of the cohesive law",
        },
        ParamDoc {
            name: "average",
            ty: "Published | Intact",
            default: Some("Published"),
            doc: "eq. (15)'s denominator: Published, every neighbour's mass (failed ones carry no stress); Intact, the intact neighbours' only",
        },
        ParamDoc {
            name: "traction",
            ty: "Published | Cohesive",
            default: Some("Published"),
            doc: "Published: eq. (16), (1 - chi) scales the growing elastic stress; Cohesive: the stress follows the law, G_F per crack area",
        },
    ],
    requires: &["neighbour/*"],
    install: generic_install!(install),
};

/// Parameters as written in the scene.
#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
struct RawParams {
    tensile_strength: f64,
    #[serde(default)]
    fracture_energy: Option<f64>,
    #[serde(default)]
    critical_opening: Option<f64>,
    band_width: f64,
    #[serde(default)]
    softening: SofteningShape,
    #[serde(default)]
    traction: Traction,
    #[serde(default)]
    average: Average,
}

/// Which neighbours' mass eq. (15) divides by (see the module docs).
#[derive(Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Average {
    /// Eq. (15) and Algorithm 2: every neighbour's mass; a failed neighbour carries no stress.
    #[default]
    Published,
    /// The intact neighbours' mass: the mean over the material that still carries stress.
    Intact,
}

/// Which traction a cracking point carries (see the module docs).
#[derive(Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Traction {
    /// Eq. (16) with Algorithm 2: `(1 − χ(w))` times the growing elastic stress.
    #[default]
    Published,
    /// The softening law's `σ(w)`, from an elastic/crack split of the band's strain.
    Cohesive,
}

/// Installed parameters of `damage/eigensoftening`.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct EigensofteningParams {
    /// The cohesive law (strength, fracture energy, shape).
    pub law: SofteningLaw,
    /// Band width h_ε.
    pub band_width: f64,
    /// Slots of the published columns: damaged, failed, dissipated energy.
    pub columns: [usize; 3],
    /// Which materials soften: the entry's `materials` (e.g. not a steel impactor).
    pub materials: MaterialFilter,
    /// The traction a cracking point carries.
    pub traction: Traction,
    /// Which neighbours' mass eq. (15) divides by.
    pub average: Average,
    /// Normal modulus `λ + 2μ` of each material, for `Traction::Cohesive`.
    pub normal_modulus: Vec<f64>,
    /// What the damage a scene seeds (a notch's `cracks`) counts in the crack-band estimate
    /// before the first step: it did not dissipate and the published column leaves it out.
    pub initial_dissipation: f64,
}

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let raw: RawParams = params.parse()?;
    params.require_positive("tensile_strength", raw.tensile_strength, "expected f_t > 0")?;
    params.require_positive("band_width", raw.band_width, "expected h_ε > 0")?;
    let ft = raw.tensile_strength;
    let fracture_energy = match (raw.fracture_energy, raw.critical_opening) {
        (Some(gf), None) => gf,
        (None, Some(wc)) => {
            let shape_factor = match raw.softening {
                SofteningShape::Linear => 2.0,
                SofteningShape::Exponential => 1000f64.ln(),
                SofteningShape::Bilinear => 3.6,
            };
            wc * ft / shape_factor
        }
        _ => {
            return Err(params.error(
                "",
                "give exactly one of `fracture_energy` and `critical_opening`",
            ));
        }
    };
    params.require_positive(
        "",
        fracture_energy,
        "expected a positive fracture energy (or critical opening)",
    )?;
    let materials = installer.materials().clone();
    let law = SofteningLaw {
        shape: raw.softening,
        tensile_strength: ft,
        fracture_energy,
    };
    let normal_modulus: Vec<f64> = installer
        .world()
        .resource::<Materials>()
        .0
        .iter()
        .map(|m| {
            let (lambda, mu) = m.lame();
            lambda + 2.0 * mu
        })
        .collect();
    if raw.traction == Traction::Cohesive {
        check_snap_back(installer, params, &law, raw.band_width, &normal_modulus)?;
    }
    installer.add_particle_component(CrackOpening(0.0));
    installer.add_frame_scalar::<CrackOpening>("crack_opening", |w| w.0);
    let initial_dissipation = seeded_dissipation(
        installer.world(),
        &materials,
        &law,
        raw.band_width,
        raw.traction,
    );
    let columns = [
        installer.add_owned_sum_column("damaged_particles"),
        installer.add_owned_sum_column("failed_particles"),
        installer.add_owned_sum_column("dissipated_energy"),
    ];
    installer.insert_resource(EigensofteningParams {
        law,
        band_width: raw.band_width,
        columns,
        materials,
        traction: raw.traction,
        average: raw.average,
        normal_modulus,
        initial_dissipation,
    });
    installer.add_systems(eigensoftening::<D>);
    Ok(())
}

/// The crack-band estimate `Σ V₀ / h_ε ∫₀^w σ dw` over the particles of `materials` as the scene
/// seeds them, with the opening the system itself would credit them (`Published`: the law's
/// opening at their χ; `Cohesive`: their `CrackOpening`, 0 before the first step).
fn seeded_dissipation(
    world: &World,
    materials: &MaterialFilter,
    law: &SofteningLaw,
    band_width: f64,
    traction: Traction,
) -> f64 {
    super::seeded_sum(world, materials, |entity, _, d| {
        let w = match traction {
            Traction::Published => law.opening(d),
            Traction::Cohesive => entity.get::<CrackOpening>().map_or(0.0, |o| o.0),
        };
        law.dissipated(w) / band_width
    })
}

/// `traction: Cohesive` needs a band narrower than the snap-back limit of every material the
/// entry softens.
fn check_snap_back(
    installer: &Installer,
    params: &Params,
    law: &SofteningLaw,
    band_width: f64,
    normal_modulus: &[f64],
) -> Result<(), SceneError> {
    let materials = installer.world().resource::<Materials>();
    for (m, material) in materials.0.iter().enumerate() {
        if !installer.materials().applies(MaterialId(m as u16)) {
            continue;
        }
        let limit = law.snap_back_band(normal_modulus[m]);
        if band_width > limit {
            return Err(params.error(
                "band_width",
                format!(
                    "with `traction: Cohesive` the band must be narrower than the snap-back \
                     limit (λ + 2μ) / max|dσ/dw| = {limit:e} m for material \"{}\"; a band of \
                     {band_width:e} m cannot follow the softening law and would fail at once",
                    material.name
                ),
            ));
        }
    }
    Ok(())
}

/// Equivalent stress of eq. (15) over the neighbours of a particle: intact neighbours' largest
/// principal stresses `principal` weighted by mass, over the mass of the whole neighbourhood
/// (`Average::Published`) or of its intact part (`Average::Intact`).
pub fn equivalent_stress(
    neighbours: &[u32],
    mass: &[Mass],
    principal: &[f64],
    damage: &[Damage],
    average: Average,
) -> f64 {
    let (mut weighted, mut total) = (0.0, 0.0);
    for &q in neighbours {
        let q = q as usize;
        let intact = damage[q].0 < 1.0;
        if intact || average == Average::Published {
            total += mass[q].0;
        }
        if intact {
            weighted += mass[q].0 * principal[q];
        }
    }
    if total > 0.0 { weighted / total } else { 0.0 }
}

/// One cracking particle's update under `Traction::Cohesive`: `(χ, w)` from the previous
/// values, the undamaged largest principal stress `trial` and the normal modulus (module docs).
pub fn soften_cohesive(
    previous: (f64, f64),
    trial: f64,
    law: &SofteningLaw,
    band_width: f64,
    normal_modulus: f64,
) -> (f64, f64) {
    let (chi, opening) = previous;
    let w = law.cohesive_opening(trial, normal_modulus, band_width, opening);
    if w >= law.critical_opening() {
        return (1.0, w);
    }
    let carried = if trial > 0.0 {
        (1.0 - law.stress(w) / trial).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (chi.max(carried), w)
}

/// One particle's update of Algorithm 2: `(χ, ε_f)` from the previous values.
pub fn soften(
    previous: (f64, f64),
    equivalent_stress: f64,
    principal_strain: f64,
    law: &SofteningLaw,
    band_width: f64,
) -> (f64, f64) {
    let (chi, onset) = previous;
    if chi == 0.0 && onset == 0.0 {
        let cracks = equivalent_stress > law.tensile_strength && principal_strain > 0.0;
        (0.0, if cracks { principal_strain } else { 0.0 })
    } else if chi < 1.0 && onset > 0.0 {
        let opening = (principal_strain - onset) * band_width;
        (law.damage(opening).max(chi).min(1.0), onset)
    } else {
        (chi, onset)
    }
}

type ParticleQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static Position<D>,
        &'static Mass,
        &'static MaterialId,
        &'static InitialVolume,
        &'static Stress<D>,
        &'static Strain<D>,
        &'static mut Damage,
        &'static mut DamageHistory,
        &'static mut CrackOpening,
    ),
    With<Particle>,
>;

/// What one particle's update reads: the law's parameters, the neighbourhoods and the bound
/// of where they can reach `f_t`, and the particles' state before the update (Jacobi).
struct ParticleUpdate<'a, D: Dim> {
    params: &'a EigensofteningParams,
    neighbourhoods: &'a Neighbourhoods,
    reach: &'a StressReach<D>,
    positions: &'a [Position<D>],
    mass: &'a [Mass],
    material: &'a [MaterialId],
    strain: &'a [Strain<D>],
    principal: &'a [f64],
    previous: &'a [Damage],
    history: &'a [DamageHistory],
    opening: &'a [CrackOpening],
}

impl<D: Dim> ParticleUpdate<'_, D> {
    /// Particle `p`'s new `(χ, onset strain, crack opening)`.
    fn soften(&self, p: usize) -> (f64, f64, f64) {
        let (params, law) = (self.params, &self.params.law);
        let (chi, onset, w) = (self.previous[p].0, self.history[p].0, self.opening[p].0);
        if !params.materials.applies(self.material[p]) {
            return (chi, onset, w);
        }
        let neighbours = if p < self.neighbourhoods.particle_count() {
            self.neighbourhoods.of(p)
        } else {
            &[]
        };
        let strain_1 = self.strain[p].0.largest_principal();
        // An intact particle whose neighbourhood cannot reach f_t, or that is not stretched,
        // stays intact: soften() would return the same without the sum.
        let intact = (chi, onset) == (0.0, 0.0);
        if intact
            && !(strain_1 > 0.0
                && self.reach.may_reach(
                    self.positions[p].0,
                    neighbours.len(),
                    law.tensile_strength,
                ))
        {
            return (chi, onset, w);
        }
        if params.traction == Traction::Cohesive && chi < 1.0 && onset > 0.0 {
            let modulus = params.normal_modulus[self.material[p].0 as usize];
            let (chi, w) =
                soften_cohesive((chi, w), self.principal[p], law, params.band_width, modulus);
            return (chi, onset, w);
        }
        let sigma = if intact {
            equivalent_stress(
                neighbours,
                self.mass,
                self.principal,
                self.previous,
                params.average,
            )
        } else {
            0.0
        };
        let (chi, onset) = soften((chi, onset), sigma, strain_1, law, params.band_width);
        let w = if onset > 0.0 && params.traction == Traction::Published {
            w.max((strain_1 - onset) * params.band_width)
                .min(law.critical_opening())
        } else {
            w
        };
        (chi, onset, w)
    }
}

/// Writes the updated state back and counts the damaged and failed particles and the energy
/// the law has dissipated (J, per scene thickness in 2D).
fn write_back(
    params: &EigensofteningParams,
    updated: Vec<(f64, f64, f64)>,
    (v0, owned): (&[InitialVolume], Owned),
    (damage, history, opening): (&mut [Damage], &mut [DamageHistory], &mut [CrackOpening]),
) -> (usize, usize, f64) {
    let law = &params.law;
    (damage.par_iter_mut())
        .zip(history.par_iter_mut())
        .zip(opening.par_iter_mut())
        .zip(&updated)
        .for_each(|(((chi, onset), w), new)| (chi.0, onset.0, w.0) = *new);
    // The counts and the energy on one thread, in particle order: the sum's rounding is the
    // same for any thread count.
    let (mut damaged, mut failed, mut dissipated) = (0usize, 0usize, 0.0);
    for (p, &(chi, _, w)) in updated.iter().enumerate() {
        // The columns count what this rank owns (every particle in one process).
        if !owned.particle(p) {
            continue;
        }
        if chi > 0.0 {
            damaged += 1;
            let w = match params.traction {
                Traction::Published => law.opening(chi),
                Traction::Cohesive => w,
            };
            dissipated += v0[p].0 / params.band_width * law.dissipated(w);
        }
        if chi >= 1.0 {
            failed += 1;
        }
    }
    (damaged, failed, dissipated)
}

/// The `damage/eigensoftening` system.
pub fn eigensoftening<D: Dim>(
    params: Res<EigensofteningParams>,
    neighbourhoods: Res<Neighbourhoods>,
    mut columns: ResMut<SeriesColumns>,
    owned: OwnedRows,
    mut reach: Local<StressReach<D>>,
    mut particles: ParticleQuery<D>,
) {
    let Some((positions, mass, material, v0, stress, strain, damage, history, opening)) =
        single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    let previous: &[Damage] = damage;
    // Each particle's largest principal stress, once, for all the neighbourhoods it is in.
    let principal: Vec<f64> = stress.par_iter().map(|s| s.0.largest_principal()).collect();
    // What each particle adds to its neighbours' sums, for the bound of where they can reach
    // f_t (a failed particle adds nothing).
    let contributed: Vec<f64> = (principal.par_iter())
        .zip(previous)
        .map(|(s, d)| if d.0 < 1.0 { *s } else { 0.0 })
        .collect();
    reach.refill(positions, &contributed, neighbourhoods.radius);
    let reach = &*reach;
    let step = ParticleUpdate {
        params: &params,
        neighbourhoods: &neighbourhoods,
        reach,
        positions,
        mass,
        material,
        strain,
        principal: &principal,
        previous,
        history,
        opening,
    };
    let updated: Vec<(f64, f64, f64)> = (0..mass.len())
        .into_par_iter()
        .map(|p| step.soften(p))
        .collect();
    let (damaged, failed, dissipated) = write_back(
        &params,
        updated,
        (v0, owned.get()),
        (damage, history, opening),
    );
    let [d, f, e] = params.columns;
    columns.values[d] = damaged as f64;
    columns.values[f] = failed as f64;
    columns.values[e] = dissipated - params.initial_dissipation;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `fractum systems` documents exactly the fields its parameters read.
    #[test]
    fn parameter_docs_match_the_parameters() {
        fractum_engine::testing::assert_documented::<RawParams>(&REGISTRATION);
    }
    use fractum_engine::testing::*;

    fn law() -> SofteningLaw {
        SofteningLaw {
            shape: SofteningShape::Linear,
            tensile_strength: 1.0,
            fracture_energy: 0.01,
        }
    }

    #[test]
    fn onset_records_the_strain_then_damage_follows_the_law_and_never_heals() {
        let (h, l) = (0.1, law());
        assert_eq!(soften((0.0, 0.0), 0.99, 1e-3, &l, h), (0.0, 0.0));
        let started = soften((0.0, 0.0), 1.01, 1e-3, &l, h);
        assert_eq!(started, (0.0, 1e-3));
        // w_c = 0.02; a strain 0.05 past onset opens w = 0.005: χ = 0.25.
        let grown = soften(started, 0.5, 1e-3 + 0.05, &l, h);
        assert!((grown.0 - 0.25).abs() < 1e-12);
        let unloaded = soften(grown, 0.0, 1e-3, &l, h);
        assert_eq!(unloaded.0, grown.0);
        assert_eq!(soften(grown, 0.0, 1.0, &l, h).0, 1.0);
    }

    #[test]
    fn cohesive_traction_is_the_law_and_never_heals() {
        // Linear law f_t = 1, w_c = 0.02; band 0.1, M = 10: snap-back limit 0.2.
        let (l, h, m) = (law(), 0.1, 10.0);
        let (chi, w) = soften_cohesive((0.0, 0.0), 0.9, &l, h, m);
        assert_eq!((chi, w), (0.0, 0.0));
        // σ(w) + 100 w = 1.2 with σ = 1 − 50 w: w = 0.004, traction 0.8 = (1 − χ) 1.2.
        let (chi, w) = soften_cohesive((0.0, 0.0), 1.2, &l, h, m);
        assert!((w - 0.004).abs() < 1e-12 && ((1.0 - chi) * 1.2 - 0.8).abs() < 1e-12);
        // Unloading to half the stress keeps χ and w (secant unloading).
        assert_eq!(soften_cohesive((chi, w), 0.6, &l, h, m), (chi, w));
        // Past g(w_c) = 2 the band is fully open.
        assert_eq!(soften_cohesive((chi, w), 2.5, &l, h, m).0, 1.0);
    }

    /// A tiny world with `damage/eigensoftening`'s resources: [`law`], band 0.1, the given
    /// traction and normal modulus, and the neighbour lists `rows`. Returns the column slots.
    fn softening_world<D: Dim>(
        traction: Traction,
        normal_modulus: f64,
        rows: &[Vec<u32>],
    ) -> (World, [usize; 3]) {
        let mut world = tiny_world::<D>(4, 0.25, 1e-3);
        let mut columns = SeriesColumns::default();
        let slots = [
            columns.declare("damaged_particles"),
            columns.declare("failed_particles"),
            columns.declare("dissipated_energy"),
        ];
        world.insert_resource(columns);
        world.insert_resource(EigensofteningParams {
            law: law(),
            band_width: 0.1,
            columns: slots,
            materials: MaterialFilter::all(),
            traction,
            average: Average::Published,
            normal_modulus: vec![normal_modulus],
            initial_dissipation: 0.0,
        });
        let mut neighbourhoods = Neighbourhoods::default();
        neighbourhoods.set_rows(rows, 0.5);
        world.insert_resource(neighbourhoods);
        (world, slots)
    }

    #[test]
    fn cohesive_system_scales_a_cracked_particle_to_the_law() {
        let (mut world, slots) = softening_world::<Two>(Traction::Cohesive, 10.0, &[vec![0]]);
        // A particle that cracked earlier (onset strain 0.1) now at σ_I = 1.2.
        let p = spawn_particle(&mut world, DVec2::splat(0.5), DVec2::ZERO, 1.0, 0.01);
        world.entity_mut(p).insert(CrackOpening(0.0));
        world.get_mut::<DamageHistory>(p).unwrap().0 = 0.1;
        world.get_mut::<Stress<Two>>(p).unwrap().0.xx = 1.2;
        world.get_mut::<Strain<Two>>(p).unwrap().0.xx = 0.12;
        run_system(&mut world, eigensoftening::<Two>);
        let chi = particle_values::<Damage>(&mut world)[0].0;
        let w = particle_values::<CrackOpening>(&mut world)[0].0;
        assert!((w - 0.004).abs() < 1e-12);
        assert!(((1.0 - chi) * 1.2 - 0.8).abs() < 1e-12);
        // Dissipated: V₀/h ∫₀ʷ σ dw = 0.01 / 0.1 · (0.004 − 25 · 0.004²).
        let dissipated = world.resource::<SeriesColumns>().values[slots[2]];
        assert!((dissipated - 0.1 * (0.004 - 25.0 * 0.004 * 0.004)).abs() < 1e-15);
    }

    #[test]
    fn failed_neighbours_carry_mass_but_no_stress() {
        let mass = [Mass(1.0), Mass(1.0)];
        let principal = [2.0, 4.0];
        let intact = [Damage(0.0), Damage(0.0)];
        let failed = [Damage(0.0), Damage(1.0)];
        let published = Average::Published;
        assert_eq!(
            equivalent_stress(&[0, 1], &mass, &principal, &intact, published),
            3.0
        );
        assert_eq!(
            equivalent_stress(&[0, 1], &mass, &principal, &failed, published),
            1.0
        );
    }

    /// Beside a notch, the intact average is the mean over the intact neighbours; the
    /// published one is diluted by the notch's mass. With no failed neighbour they agree.
    #[test]
    fn the_intact_average_leaves_failed_neighbours_out_of_the_mass() {
        let mass = [Mass(1.0), Mass(2.0), Mass(1.0)];
        let principal = [3.0, 6.0, 9.0];
        let notch = [Damage(0.0), Damage(0.0), Damage(1.0)];
        let (published, intact) = (Average::Published, Average::Intact);
        let row = [0, 1, 2];
        assert_eq!(
            equivalent_stress(&row, &mass, &principal, &notch, published),
            3.75
        );
        assert_eq!(
            equivalent_stress(&row, &mass, &principal, &notch, intact),
            5.0
        );
        let none = [Damage(0.0); 3];
        assert_eq!(
            equivalent_stress(&row, &mass, &principal, &none, published),
            equivalent_stress(&row, &mass, &principal, &none, intact)
        );
        let all = [Damage(1.0); 3];
        assert_eq!(
            equivalent_stress(&row, &mass, &principal, &all, intact),
            0.0
        );
    }

    /// Three particles; 0 and 1 are neighbours. `tension(s)` is a stress whose largest principal
    /// value is `s`.
    fn cracks_overstressed<D: Dim>(tension: impl Fn(f64) -> D::Sym)
    where
        D::Vector: SpaceVector,
    {
        let (mut world, _) =
            softening_world::<D>(Traction::Published, 1.0, &[vec![0, 1], vec![0, 1], vec![2]]);
        for (k, s) in [(0, 1.5), (1, 1.0), (2, 0.5)] {
            let x = D::Vector::from_fn(|a| if a == 0 { 0.1 + 0.2 * k as f64 } else { 0.5 });
            let p = spawn_particle(&mut world, x, D::Vector::ZERO, 1.0, 0.01);
            world.entity_mut(p).insert(CrackOpening(0.0));
            world.get_mut::<Stress<D>>(p).unwrap().0 = tension(s);
            world.get_mut::<Strain<D>>(p).unwrap().0 = tension(1e-3);
        }
        run_system(&mut world, eigensoftening::<D>);
        let onset = particle_values::<DamageHistory>(&mut world);
        // Particles 0 and 1 average 1.25 > f_t and record their principal strain; particle 2
        // alone has 0.5.
        let expected = [1e-3, 1e-3, 0.0];
        for (h, e) in onset.iter().zip(expected) {
            assert!((h.0 - e).abs() < 1e-18, "{onset:?}");
        }
        assert!(
            particle_values::<Damage>(&mut world)
                .iter()
                .all(|d| d.0 == 0.0)
        );
    }

    #[test]
    fn system_cracks_the_particles_whose_neighbourhood_is_overstressed() {
        cracks_overstressed::<Two>(|s| SymTensor2 {
            xx: s,
            ..SymTensor2::ZERO
        });
        // In 3D along a skew direction: every component s/3 is s n ⊗ n with n = (1, 1, 1)/√3,
        // principal values (s, 0, 0).
        cracks_overstressed::<Three>(|s| SymTensor3 {
            xx: s / 3.0,
            yy: s / 3.0,
            zz: s / 3.0,
            xy: s / 3.0,
            yz: s / 3.0,
            xz: s / 3.0,
        });
    }

    /// A particle at a notch's tip: its neighbour 1 carries 1.5, neighbour 2 is failed. The
    /// published average, (1.0 + 1.5) / 3, stays below f_t = 1; the intact one, 1.25, cracks it.
    #[test]
    fn system_cracks_a_notch_tip_only_with_the_intact_average() {
        for (average, onset) in [(Average::Published, 0.0), (Average::Intact, 1e-3)] {
            let rows = [vec![0, 1, 2], vec![0, 1], vec![0, 2]];
            let (mut world, _) = softening_world::<Two>(Traction::Published, 1.0, &rows);
            world.resource_mut::<EigensofteningParams>().average = average;
            for (k, (s, d)) in [(1.0, 0.0), (1.5, 0.0), (2.0, 1.0)].into_iter().enumerate() {
                let x = DVec2::new(0.1 + 0.2 * k as f64, 0.5);
                let p = spawn_particle(&mut world, x, DVec2::ZERO, 1.0, 0.01);
                world.entity_mut(p).insert((CrackOpening(0.0), Damage(d)));
                let tension = |s| SymTensor2 {
                    xx: s,
                    ..SymTensor2::ZERO
                };
                world.get_mut::<Stress<Two>>(p).unwrap().0 = tension(s);
                world.get_mut::<Strain<Two>>(p).unwrap().0 = tension(1e-3);
            }
            run_system(&mut world, eigensoftening::<Two>);
            let tip = particle_values::<DamageHistory>(&mut world)[0].0;
            assert_eq!(tip, onset, "{average:?}");
        }
    }
}

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
//! - The sum of eq. (15) is skipped for an intact particle that is not stretched or whose
//!   neighbourhood cannot reach `f_t` (a bound from binned stresses, `damage::stress_reach`,
//!   that holds for the rounded sum too): in a body mostly below its strength the damage update
//!   costs little, and no result changes.
//! - Onset needs a tensile largest principal strain (ε_I > 0): the onset strain is also the
//!   "has cracked" flag of Algorithm 2 (`ε_f > 0`).
//! - Publishes `series.csv` columns `damaged_particles` (χ > 0), `failed_particles` (χ = 1)
//!   and `dissipated_energy`: the crack-band estimate `Σ_p V₀,p / h_ε · ∫₀^{w(χ_p)} σ dw`.

use super::softening::{SofteningLaw, SofteningShape};
use super::stress_reach::StressReach;
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
            default: None,
            doc: "G_F (J/m²); give this or critical_opening",
        },
        ParamDoc {
            name: "critical_opening",
            ty: "f64",
            default: None,
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
    ],
    requires: &["neighbour/*"],
    install,
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
}

fn install(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let raw: RawParams = params.parse()?;
    if !(raw.tensile_strength.is_finite() && raw.tensile_strength > 0.0) {
        return Err(params.error("tensile_strength", "expected f_t > 0"));
    }
    if !(raw.band_width.is_finite() && raw.band_width > 0.0) {
        return Err(params.error("band_width", "expected h_ε > 0"));
    }
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
    if !(fracture_energy.is_finite() && fracture_energy > 0.0) {
        return Err(params.error(
            "",
            "expected a positive fracture energy (or critical opening)",
        ));
    }
    let materials = installer.materials().clone();
    let columns = [
        installer.add_series_column("damaged_particles"),
        installer.add_series_column("failed_particles"),
        installer.add_series_column("dissipated_energy"),
    ];
    installer.insert_resource(EigensofteningParams {
        law: SofteningLaw {
            shape: raw.softening,
            tensile_strength: ft,
            fracture_energy,
        },
        band_width: raw.band_width,
        columns,
        materials,
    });
    with_dim!(installer.dimension(), D => installer.add_systems(eigensoftening::<D>));
    Ok(())
}

/// Equivalent stress of eq. (15) over the neighbours of a particle: intact neighbours' largest
/// principal stresses `principal` weighted by mass, over the mass of the whole neighbourhood.
pub fn equivalent_stress(
    neighbours: &[u32],
    mass: &[Mass],
    principal: &[f64],
    damage: &[Damage],
) -> f64 {
    let (mut weighted, mut total) = (0.0, 0.0);
    for &q in neighbours {
        let q = q as usize;
        total += mass[q].0;
        if damage[q].0 < 1.0 {
            weighted += mass[q].0 * principal[q];
        }
    }
    if total > 0.0 { weighted / total } else { 0.0 }
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
    ),
    With<Particle>,
>;

/// The `damage/eigensoftening` system.
pub fn eigensoftening<D: Dim>(
    params: Res<EigensofteningParams>,
    neighbourhoods: Res<Neighbourhoods>,
    mut columns: ResMut<SeriesColumns>,
    mut reach: Local<StressReach<D>>,
    mut particles: ParticleQuery<D>,
) {
    let Some((positions, mass, material, v0, stress, strain, mut damage, mut history)) =
        single_table(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    let (damage, history): (&mut [Damage], &mut [DamageHistory]) = (&mut damage, &mut history);
    let law = params.law;
    let previous: &[Damage] = damage;
    // Each particle's largest principal stress, once, for all the neighbourhoods it is in.
    let principal: Vec<f64> = stress.par_iter().map(|s| s.0.largest_principal()).collect();
    // What each particle adds to its neighbours' sums, for the bound of where they can reach
    // f_t (a failed particle adds nothing).
    let contributed: Vec<f64> = principal
        .iter()
        .zip(previous)
        .map(|(s, d)| if d.0 < 1.0 { *s } else { 0.0 })
        .collect();
    reach.refill(positions, &contributed, neighbourhoods.radius);
    let reach = &*reach;
    let updated: Vec<(f64, f64)> = (0..mass.len())
        .into_par_iter()
        .map(|p| {
            let state = (previous[p].0, history[p].0);
            if !params.materials.applies(material[p]) {
                return state;
            }
            let neighbours = if p < neighbourhoods.particle_count() {
                neighbourhoods.of(p)
            } else {
                &[]
            };
            let strain_1 = strain[p].0.largest_principal();
            // An intact particle whose neighbourhood cannot reach f_t, or that is not
            // stretched, stays intact: soften() would return the same without the sum.
            let intact = state == (0.0, 0.0);
            if intact
                && !(strain_1 > 0.0
                    && reach.may_reach(positions[p].0, neighbours.len(), law.tensile_strength))
            {
                return state;
            }
            let sigma = if intact {
                equivalent_stress(neighbours, mass, &principal, previous)
            } else {
                0.0
            };
            soften(state, sigma, strain_1, &law, params.band_width)
        })
        .collect();
    let (mut damaged, mut failed, mut dissipated) = (0usize, 0usize, 0.0);
    for (p, (chi, onset)) in updated.into_iter().enumerate() {
        damage[p].0 = chi;
        history[p].0 = onset;
        if chi > 0.0 {
            damaged += 1;
            dissipated += v0[p].0 / params.band_width * law.dissipated(law.opening(chi));
        }
        if chi >= 1.0 {
            failed += 1;
        }
    }
    let [d, f, e] = params.columns;
    columns.values[d] = damaged as f64;
    columns.values[f] = failed as f64;
    columns.values[e] = dissipated;
}

#[cfg(test)]
mod tests {
    use super::*;
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
    fn failed_neighbours_carry_mass_but_no_stress() {
        let mass = [Mass(1.0), Mass(1.0)];
        let principal = [2.0, 4.0];
        assert_eq!(
            equivalent_stress(&[0, 1], &mass, &principal, &[Damage(0.0), Damage(0.0)]),
            3.0
        );
        assert_eq!(
            equivalent_stress(&[0, 1], &mass, &principal, &[Damage(0.0), Damage(1.0)]),
            1.0
        );
    }

    /// Three particles; 0 and 1 are neighbours. `tension(s)` is a stress whose largest principal
    /// value is `s`.
    fn cracks_overstressed<D: Dim>(tension: impl Fn(f64) -> D::Sym)
    where
        D::Vector: SpaceVector,
    {
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
        });
        let mut neighbourhoods = Neighbourhoods::default();
        neighbourhoods.set_rows(&[vec![0, 1], vec![0, 1], vec![2]], 0.5);
        world.insert_resource(neighbourhoods);
        for (k, s) in [(0, 1.5), (1, 1.0), (2, 0.5)] {
            let x = D::Vector::from_fn(|a| if a == 0 { 0.1 + 0.2 * k as f64 } else { 0.5 });
            let p = spawn_particle(&mut world, x, D::Vector::ZERO, 1.0, 0.01);
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
}

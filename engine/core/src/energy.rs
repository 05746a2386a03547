//! The energy account of a run: the work the loads do on the system, so that `series.csv` can
//! close the balance `W_ext = ΔK + ΔU + D + R` (kinetic, stored, dissipated by damage and by a
//! shock viscosity, and the residual R, the energy the numerical scheme itself dissipates or
//! creates).
//!
//! The engine's `account_work` system runs after every step (after the post-step stage and its
//! check) and adds the step's work:
//! - prescribed-velocity regions: the region's reaction (the force the boundary exerts on the
//!   body) times its prescribed displacement over the step, `R · (u(t + Δt) − u(t))` with `u`
//!   the exact integral of the velocity table; held components of fixed and roller regions do
//!   not move and do no work;
//! - the body force: `b · Δ(Σ m x)`, the exact change of the potential `−Σ m b·x` (the body
//!   force is uniform);
//! - loads on particles: `Σ f · v Δt` with the velocities at the end of the step.
//!
//! `series.csv` gets `external_work` (accumulated since the start) and `energy_residual`
//! `= W_ext − (E − E₀) − D`, with `E` the total (kinetic + stored) energy and `D` the sum of the
//! damage systems' `dissipated_energy` column and the shock viscosity's `viscous_dissipation`,
//! where the pipeline has them.
//!
//! A total energy above the work done, `W_ext − (E − E₀) < 0`, is energy the scheme created.
//! An explicit scheme that creates energy is usually on its way to a blow-up (a time step too
//! long for the stiffness it meets, or the cell-crossing of the linear tents under a steep
//! stress), long before any value turns non-finite; [`EnergyWatch`] follows the series rows and
//! records when the created energy passes [`CREATION_WARNING`] of the energy in play, so that
//! the run can say so while it goes. It leaves the damage laws' `dissipated_energy` out of its
//! balance: dissipation cannot be negative, so what it sees created is created, whatever the
//! accuracy of those accounts.

use crate::boundary::{BoundaryConditions, Reactions};
use crate::components::{ExternalForce, Mass, Particle, Position, Velocity};
use crate::dim::{Dim, VectorOps};
use crate::resources::{BodyForce, SimClock};
use bevy_ecs::prelude::*;

/// The work done on the system since the start, and the state it was measured from.
#[derive(Resource, Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EnergyAccount {
    /// Work of the loads since the start (J; per scene thickness in 2D).
    pub external_work: f64,
    /// Total (kinetic + stored) energy at the start.
    pub initial_energy: f64,
    /// `Σ m x` after the previous step, per axis.
    first_moment: [f64; 3],
}

impl EnergyAccount {
    /// An account starting from total energy `initial_energy` and first moment of mass
    /// `first_moment` (`Σ m x`).
    pub fn new(initial_energy: f64, first_moment: [f64; 3]) -> Self {
        Self {
            external_work: 0.0,
            initial_energy,
            first_moment,
        }
    }
}

/// Particles per block of the energy account's sums: blocks are summed in parallel, each in
/// particle order, and their sums added in block order, so the account is the same bits for any
/// thread count.
pub const SUM_BLOCK: usize = 4096;

/// `Σ m x` of the particles, per axis (zero beyond the dimension), and `Σ f · v` where the
/// forces are given: over fixed blocks in parallel ([`SUM_BLOCK`]). With `owned` (a rank of a
/// distributed run), only the rows it marks count.
pub fn moment_and_power<D: Dim>(
    masses: &[Mass],
    positions: &[Position<D>],
    velocities: &[Velocity<D>],
    forces: Option<&[ExternalForce<D>]>,
    owned: Option<&[bool]>,
) -> ([f64; 3], f64) {
    use rayon::prelude::*;
    let count = masses.len();
    let blocks: Vec<([f64; 3], f64)> = (0..count.div_ceil(SUM_BLOCK))
        .into_par_iter()
        .map(|block| {
            let mut moment = [0.0; 3];
            let mut power = 0.0;
            for p in block * SUM_BLOCK..((block + 1) * SUM_BLOCK).min(count) {
                if owned.is_some_and(|o| !o.get(p).copied().unwrap_or(false)) {
                    continue;
                }
                for (a, s) in moment.iter_mut().enumerate().take(D::N) {
                    *s += masses[p].0 * positions[p].0[a];
                }
                if let Some(forces) = forces {
                    power += forces[p].0.dot(velocities[p].0);
                }
            }
            (moment, power)
        })
        .collect();
    blocks
        .into_iter()
        .fold(([0.0; 3], 0.0), |(mut moment, power), (m, p)| {
            for (s, m) in moment.iter_mut().zip(m) {
                *s += m;
            }
            (moment, power + p)
        })
}

/// `Σ m x` of the particles in `world`, per axis, summed as [`account_work`] sums it.
pub fn first_moment<D: Dim>(world: &mut bevy_ecs::world::World) -> [f64; 3] {
    let mut query = world.query_filtered::<(&Mass, &Position<D>, &Velocity<D>), With<Particle>>();
    let owned = world
        .get_resource::<crate::decomposition::Ownership>()
        .map(|o| o.particles.as_slice());
    crate::storage::single_table(query.contiguous_iter(world), "particles")
        .map_or([0.0; 3], |(m, x, v)| {
            moment_and_power(m, x, v, None, owned).0
        })
}

/// The work of prescribed-velocity regions over a step from `time` to `time + dt`.
pub fn boundary_work<D: Dim>(
    bcs: &BoundaryConditions,
    reactions: &Reactions<D>,
    time: f64,
    dt: f64,
) -> f64 {
    bcs.regions
        .iter()
        .zip(&reactions.0)
        .map(|(region, reaction)| {
            (0..D::N)
                .map(|a| {
                    region.velocity[a].as_ref().map_or(0.0, |f| {
                        reaction[a] * (f.integral(time + dt) - f.integral(time))
                    })
                })
                .sum::<f64>()
        })
        .sum()
}

type WorkQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static Mass,
        &'static Position<D>,
        &'static Velocity<D>,
        &'static ExternalForce<D>,
    ),
    With<Particle>,
>;

/// Energy held by a contact potential (`contact/penalty`'s overlapping particle pairs), as the
/// contact system left it at its last step: stored energy like the particles' strain energy,
/// which the totals ([`crate::diagnostics::Totals::contact_energy`]) add to the total energy so
/// that the balance closes while bodies press on each other. Absent (zero) without such a
/// system.
#[derive(
    Resource, Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize,
)]
pub struct ContactPotential(pub f64);

crate::checkpoint_keys! { ContactPotential => "engine/contact_potential" }

/// Adds the work of the step just taken to the [`EnergyAccount`] (sums over fixed blocks, so the
/// same bits for any thread count).
pub fn account_work<D: Dim>(
    clock: Res<SimClock>,
    body_force: Res<BodyForce<D>>,
    bcs: Res<BoundaryConditions>,
    reactions: Res<Reactions<D>>,
    particles: WorkQuery<D>,
    ownership: Option<Res<crate::decomposition::Ownership>>,
    mut account: ResMut<EnergyAccount>,
) {
    // One pass over the particles for both sums. A rank of a distributed run accounts the
    // particles it owned during the step: the ranks' moments add up to the whole run's, now
    // and at the previous step, so the ranks' works add up to the run's.
    let owned = ownership.as_deref().map(|o| o.particles.as_slice());
    let (moment, power) = crate::storage::single_table(particles.contiguous_iter(), "particles")
        .map_or(([0.0; 3], 0.0), |(m, x, v, f)| {
            moment_and_power(m, x, v, Some(f), owned)
        });
    let b = body_force.0;
    let body: f64 = (0..D::N)
        .map(|a| b[a] * (moment[a] - account.first_moment[a]))
        .sum();
    let loads = power * clock.dt;
    account.external_work += boundary_work(&bcs, &reactions, clock.time, clock.dt) + body + loads;
    account.first_moment = moment;
}

/// The fraction of the energy in play (the largest of the initial energy, the total energy and
/// the work done so far) that the scheme may create before [`EnergyWatch`] reports it. Well below
/// the energy creation that precedes a blow-up (tens of percent within a few hundred steps),
/// above the few percent a sound run can create where a stiff contact first closes (the
/// Brazilian disk's platens: 2-3%, which then stays).
pub const CREATION_WARNING: f64 = 0.05;

/// The strain whose elastic energy, over every particle, is the least energy in play that the
/// [`EnergyWatch`] judges creation against: `½ Σ E V₀ ε²` with `ε` this strain. Below it the
/// energy in play is round-off (a body at rest, a load not yet ramped up: a kilogram at 10⁻¹⁷ m/s
/// carries 10⁻³⁴ J), and a fraction of it means nothing; a body strained by 10⁻⁶ is still far
/// from any load a fracture run applies (rock fails near 10⁻⁴, steel near 10⁻³).
pub const ROUND_OFF_STRAIN: f64 = 1.0e-6;

/// The floor of the [`EnergyWatch`]'s energy in play, from each particle's initial volume and
/// Young's modulus: `½ Σ E V₀ ε²` with `ε` = [`ROUND_OFF_STRAIN`].
pub fn energy_floor(particles: impl Iterator<Item = (f64, f64)>) -> f64 {
    let elastic: f64 = particles
        .map(|(volume, modulus)| modulus * volume)
        .filter(|e| e.is_finite())
        .sum();
    0.5 * elastic * ROUND_OFF_STRAIN * ROUND_OFF_STRAIN
}

/// Energy the scheme had created at one series row.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EnergyCreation {
    /// Step of the row.
    pub step: u64,
    /// Simulated time of the row (s).
    pub time: f64,
    /// Energy created, `(E − E₀) − W_ext` (J; per scene thickness in 2D).
    pub created: f64,
    /// `created` over the energy in play.
    pub fraction: f64,
}

/// Follows the energy balance of the series rows for energy the scheme creates (a resource the
/// run loop updates at every row, and a front end may read to warn while the run goes on).
#[derive(Resource, Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EnergyWatch {
    /// The energy in play: the largest initial energy, total energy or work done seen so far,
    /// and never less than the floor the watch started from ([`EnergyWatch::with_floor`]).
    pub scale: f64,
    /// The first row at which the created energy passed [`CREATION_WARNING`] of the scale.
    pub first: Option<EnergyCreation>,
    /// The row with the largest created fraction, once `first` is set.
    pub worst: Option<EnergyCreation>,
}

impl EnergyWatch {
    /// A watch that judges creation against no less than `floor` J ([`energy_floor`]).
    pub fn with_floor(floor: f64) -> Self {
        Self {
            scale: floor.max(0.0),
            ..Self::default()
        }
    }

    /// Takes in one series row: the step, time, total energy, initial energy, work done and
    /// the balance `W_ext − (E − E₀)` (negative: energy created). Returns true when this row
    /// is the first past the warning level.
    pub fn observe(
        &mut self,
        step: u64,
        time: f64,
        total_energy: f64,
        initial_energy: f64,
        work: f64,
        balance: f64,
    ) -> bool {
        for e in [total_energy, initial_energy, work] {
            if e.is_finite() {
                self.scale = self.scale.max(e);
            }
        }
        if !(balance < 0.0 && self.scale > 0.0) {
            return false;
        }
        let row = EnergyCreation {
            step,
            time,
            created: -balance,
            fraction: -balance / self.scale,
        };
        let first = self.first.is_none() && row.fraction > CREATION_WARNING;
        if first {
            self.first = Some(row);
        }
        if self.first.is_some() && self.worst.is_none_or(|w| row.fraction > w.fraction) {
            self.worst = Some(row);
        }
        first
    }
}

/// The energy account of the latest series row, as the end-of-run summary reports it:
/// `W_ext = ΔE + D + R` (J; per scene thickness in 2D).
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct EnergyBalance {
    /// The time of the row (s).
    pub time: f64,
    /// `W_ext`, the work of the loads since the start.
    pub external_work: f64,
    /// `ΔE`, the change of the total (kinetic + stored) energy since the start.
    pub energy_change: f64,
    /// `D`, what the pipeline's laws report they dissipated (`dissipated_energy`,
    /// `viscous_dissipation`).
    pub dissipated: f64,
    /// `R = W_ext − ΔE − D`, what the numerical scheme dissipated (created, if negative).
    pub residual: f64,
    /// The energy in play ([`EnergyWatch::scale`]) the residual is judged against.
    pub scale: f64,
}

impl EnergyBalance {
    /// The residual as a fraction of the energy in play (0 when nothing is in play).
    pub fn residual_fraction(&self) -> f64 {
        if self.scale > 0.0 {
            self.residual / self.scale
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boundary::{BoundaryRegion, PiecewiseLinear};
    use crate::dim::Two;
    use crate::testing::*;
    use glam::DVec2;

    /// A falling particle under gravity, a pulled region and a pushed particle, one step.
    #[test]
    fn the_step_adds_the_work_of_every_load() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.1);
        world.insert_resource(BodyForce::<Two>(DVec2::new(0.0, -10.0)));
        let p = spawn_particle(
            &mut world,
            DVec2::new(0.5, 0.5),
            DVec2::new(1.0, 0.0),
            2.0,
            0.1,
        );
        world.get_mut::<ExternalForce<Two>>(p).unwrap().0 = DVec2::new(3.0, 0.0);
        world.insert_resource(EnergyAccount::new(0.0, [1.0, 1.0, 0.0]));
        // The particle then drops 0.05 m during the step.
        world.get_mut::<Position<Two>>(p).unwrap().0 = DVec2::new(0.6, 0.45);
        let region = BoundaryRegion {
            name: "pulled".into(),
            nodes: vec![0],
            velocity: [Some(PiecewiseLinear::constant(2.0)), None, None],
        };
        world.insert_resource(BoundaryConditions {
            regions: vec![region],
            measured_nodes: None,
        });
        world.insert_resource(Reactions::<Two>(vec![DVec2::new(5.0, 7.0)]));
        run_system(&mut world, account_work::<Two>);
        let work = world.resource::<EnergyAccount>().external_work;
        // Gravity: m g Δy = 2 × 10 × 0.05 = 1; the load: 3 × 1 × 0.1 = 0.3; the region: 5 × 0.2.
        assert!((work - 2.3).abs() < 1e-12, "{work}");
    }

    #[test]
    fn the_watch_reports_creation_past_five_percent_of_the_energy_in_play_once() {
        let mut watch = EnergyWatch::default();
        // Dissipation and 4% created: quiet.
        assert!(!watch.observe(10, 1.0, 9.0, 10.0, 0.0, 1.0));
        assert!(!watch.observe(20, 2.0, 10.4, 10.0, 0.0, -0.4));
        assert_eq!(watch.first, None);
        // Work done raises the scale to 20.5: 1.25 J created is 6.1%.
        assert!(watch.observe(30, 3.0, 20.5, 10.0, 20.0, -1.25));
        let first = watch.first.unwrap();
        assert_eq!((first.step, first.created), (30, 1.25));
        assert!((first.fraction - 1.25 / 20.5).abs() < 1e-15);
        // Reported once; the worst row is followed.
        assert!(!watch.observe(40, 4.0, 25.0, 10.0, 20.0, -5.0));
        assert!(!watch.observe(50, 5.0, 22.0, 10.0, 20.0, -2.0));
        assert_eq!(watch.first.unwrap().step, 30);
        assert_eq!(watch.worst.unwrap().step, 40);
        // A non-finite row does not poison the scale.
        assert!(!watch.observe(60, 6.0, f64::NAN, 10.0, f64::INFINITY, f64::NAN));
        assert_eq!(watch.scale, 25.0);
    }

    /// A body at rest whose round-off creates 10⁻³⁴ J on 10⁻³⁶ J in play is not a warning
    /// (without the floor it read as 5000% created); the same body once loaded still is.
    #[test]
    fn round_off_on_a_body_at_rest_is_not_created_energy() {
        // 1 m² of steel: the floor is ½ × 2e11 × 1 × 1e-12 = 0.1 J.
        let floor = energy_floor([(0.5, 2.0e11), (0.5, 2.0e11)].into_iter());
        assert!((floor - 0.1).abs() < 1e-15, "{floor}");
        let mut watch = EnergyWatch::with_floor(floor);
        assert!(!watch.observe(1, 1e-6, 5.1e-34, 1e-36, 0.0, -5.0e-34));
        assert_eq!(watch.first, None);
        assert!(watch.observe(900, 1e-3, 12.0, 1e-36, 10.0, -2.0));
        assert_eq!(watch.first.unwrap().step, 900);
    }
}

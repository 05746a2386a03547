//! Series rows: the energies, momentum and probe values of one `series.csv` row, and what the
//! `Force` probes remember between rows.

use super::{OutputPlan, ProbeKind};
use crate::boundary::{BoundaryConditions, Reactions};
use crate::components::{BodyId, Mass, Particle, ParticleId, Position, Velocity};
use crate::diagnostics::{Totals, totals};
use crate::dim::{Dim, Dimension, VectorOps};
use crate::resources::SimClock;
use crate::with_dim;
use bevy_ecs::prelude::*;

/// The values of one `series.csv` row after the step column.
pub fn series_row(world: &mut World, plan: &OutputPlan) -> Vec<f64> {
    with_dim!(plan.dimension, D => series_row_of::<D>(world, plan))
}

/// The value of one probe, one entry per axis.
fn probe_value<D: Dim>(
    world: &mut World,
    slot: usize,
    probe: &ProbeKind,
    totals: &Totals,
) -> D::Vector {
    let time = world.resource::<SimClock>().time;
    match probe {
        ProbeKind::Reaction { index, .. } => world
            .resource::<Reactions<D>>()
            .0
            .get(*index)
            .copied()
            .unwrap_or_default(),
        ProbeKind::CentreOfMassVelocity => {
            let v = totals.centre_of_mass_velocity();
            D::Vector::from_fn(|a| v[a])
        }
        ProbeKind::Force { index, .. } => {
            let mut query =
                world.query_filtered::<(&BodyId, &Mass, &Velocity<D>), With<Particle>>();
            let momentum = query
                .iter(world)
                .filter(|(b, _, _)| b.0 == *index)
                .fold(D::Vector::ZERO, |p, (_, m, v)| p + v.0 * m.0);
            let mut memory = world.get_resource_or_init::<ForceProbeMemory>();
            memory
                .mean_force(
                    slot,
                    time,
                    std::array::from_fn(|a| if a < D::N { momentum[a] } else { 0.0 }),
                )
                .map_or(D::Vector::ZERO, |f| D::Vector::from_fn(|a| f[a]))
        }
        ProbeKind::Track {
            particle,
            reference,
            ..
        } => {
            let displacement = |tracked: &Option<(Entity, [f64; 3])>| -> D::Vector {
                let at = tracked.and_then(|(p, origin)| {
                    world
                        .get::<Position<D>>(p)
                        .map(|x| D::Vector::from_fn(|a| x.0[a] - origin[a]))
                });
                at.unwrap_or(D::Vector::splat(f64::NAN))
            };
            let moved = displacement(particle);
            match reference {
                Some(_) => moved - displacement(reference),
                None => moved,
            }
        }
        ProbeKind::Displacement { index, .. } => {
            let region = &world.resource::<BoundaryConditions>().regions[*index];
            D::Vector::from_fn(|a| {
                region.velocity[a]
                    .as_ref()
                    .map_or(0.0, |f| f.integral(time))
            })
        }
    }
}

/// The particle with the largest kinetic energy (or the first whose energy is not finite), for
/// a message about energy that overflowed.
pub fn largest_energy_particle(world: &mut World) -> String {
    let dimension = *world.resource::<Dimension>();
    with_dim!(dimension, D => {
        let mut query =
            world.query_filtered::<(&ParticleId, &Mass, &Velocity<D>), With<Particle>>();
        let worst = query
            .iter(world)
            .map(|(id, m, v)| (id.0, 0.5 * m.0 * v.0.dot(v.0), v.0.to_3d()))
            .max_by(|a, b| {
                let key = |e: f64| if e.is_finite() { e } else { f64::INFINITY };
                key(a.1).total_cmp(&key(b.1))
            });
        match worst {
            Some((id, energy, v)) => format!(
                "particle {id} has velocity {:?} m/s and kinetic energy {energy:e} J",
                &v[..D::N]
            ),
            None => "no particle is left".to_string(),
        }
    })
}

/// Whether entry `i` of a series row (time first) must be finite: all but a `Track` probe's,
/// which is NaN by design once its particle has left the grid.
pub fn must_be_finite(plan: &OutputPlan, i: usize) -> bool {
    let axes = plan.dimension.count();
    let probes_start = 4 + axes;
    match i.checked_sub(probes_start).map(|k| k / axes) {
        Some(probe) if probe < plan.probes.len() => {
            !matches!(plan.probes[probe], ProbeKind::Track { .. })
        }
        _ => true,
    }
}

/// What the `Force` probes remember between series rows, per probe slot.
#[derive(Resource, Default, Debug, serde::Serialize, serde::Deserialize)]
pub struct ForceProbeMemory(Vec<Option<ForceProbeRow>>);

/// One `Force` probe's last row.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
struct ForceProbeRow {
    time: f64,
    momentum: [f64; 3],
    reported: Option<[f64; 3]>,
}

impl ForceProbeMemory {
    /// The mean net force `(P − P₀)/(t − t₀)` on a body over the interval since the previous
    /// row, from its momentum `P` now; `None` at the first row (no interval yet, reported as
    /// zero). A second row at the same time repeats the first row's value.
    pub fn mean_force(&mut self, slot: usize, time: f64, momentum: [f64; 3]) -> Option<[f64; 3]> {
        if self.0.len() <= slot {
            self.0.resize(slot + 1, None);
        }
        let force = match self.0[slot] {
            Some(row) if row.time == time => return row.reported,
            Some(row) => Some(std::array::from_fn(|a| {
                (momentum[a] - row.momentum[a]) / (time - row.time)
            })),
            None => None,
        };
        self.0[slot] = Some(ForceProbeRow {
            time,
            momentum,
            reported: force,
        });
        force
    }
}

fn series_row_of<D: Dim>(world: &mut World, plan: &OutputPlan) -> Vec<f64> {
    let t = totals(world);
    let time = world.resource::<SimClock>().time;
    let mut row = vec![time, t.kinetic_energy, t.strain_energy, t.total_energy()];
    row.extend_from_slice(&t.momentum[..D::N]);
    for (slot, probe) in plan.probes.iter().enumerate() {
        let value = probe_value::<D>(world, slot, probe, &t);
        row.extend((0..D::N).map(|a| value[a]));
    }
    let mut dissipated = 0.0;
    if let Some(extra) = world.get_resource::<crate::series::SeriesColumns>() {
        row.extend(
            plan.system_columns
                .iter()
                .map(|name| extra.value(name).unwrap_or(f64::NAN)),
        );
        dissipated = extra.value("dissipated_energy").unwrap_or(0.0);
    }
    let (work, initial) = world
        .get_resource::<crate::energy::EnergyAccount>()
        .map_or((f64::NAN, f64::NAN), |a| {
            (a.external_work, a.initial_energy)
        });
    row.push(work);
    row.push(work - (t.total_energy() - initial) - dissipated);
    row
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The force probe reports the mean force over each interval between rows, nothing at the
    /// first row, and repeats itself when asked twice at one time.
    #[test]
    fn force_probes_report_the_momentum_rate_between_rows() {
        let mut memory = ForceProbeMemory::default();
        assert_eq!(memory.mean_force(1, 0.0, [1.0, 2.0, 0.0]), None);
        let force = memory.mean_force(1, 0.5, [2.0, 1.0, 0.0]).unwrap();
        assert_eq!(force, [2.0, -2.0, 0.0]);
        assert_eq!(memory.mean_force(1, 0.5, [9.0, 9.0, 9.0]), Some(force));
        assert_eq!(
            memory.mean_force(1, 1.5, [3.0, 1.0, 0.0]),
            Some([1.0, 0.0, 0.0])
        );
        assert_eq!(memory.mean_force(0, 1.5, [3.0, 1.0, 0.0]), None);
    }
}

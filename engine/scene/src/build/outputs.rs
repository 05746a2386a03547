//! The world builder's output plan: which particle each `Track` probe follows, each probe
//! resolved to a region or a body, and the frame fields a pipeline can write.

use super::WorldBuilder;
use crate::SceneError;
use crate::format::Probe;
use crate::seed::Seeds;
use bevy_ecs::prelude::World;
use fractum_engine::dim::{Dim, VectorOps};
use fractum_io::output::{OutputPlan, ProbeKind};

/// The particle a `Track` probe follows: its id and its position at the start (x, y, z).
pub(super) type TrackedParticle = Option<(u32, [f64; 3])>;

impl<D: Dim> WorldBuilder<'_, D> {
    /// For each probe, the particle a `Track` probe follows and the one it is relative to, from
    /// the seeds of every body: the particle nearest its point, by id (particles take ids in
    /// seed order), the lowest id of the nearest on a tie.
    pub(super) fn tracked_particles(
        &self,
        seeds: &[Seeds<D>],
    ) -> Result<Vec<[TrackedParticle; 2]>, SceneError> {
        let first_ids: Vec<u32> = seeds
            .iter()
            .scan(0u32, |next, body| {
                let first = *next;
                *next = next.saturating_add(body.len() as u32);
                Some(first)
            })
            .collect();
        let nearest = |body: usize, at: D::Vector| -> TrackedParticle {
            let found = seeds[body]
                .iter()
                .enumerate()
                .map(|(k, (x, _))| (k, *x, (*x - at).length()))
                .min_by(|a, b| a.2.total_cmp(&b.2).then(a.0.cmp(&b.0)));
            found.map(|(k, x, _)| {
                let start = std::array::from_fn(|a| if a < D::N { x[a] } else { 0.0 });
                (first_ids[body] + k as u32, start)
            })
        };
        let mut tracked = Vec::new();
        for (k, probe) in self.spec.output.probes.iter().enumerate() {
            tracked.push(match probe {
                Probe::Track {
                    body,
                    at,
                    relative_to,
                    ..
                } => {
                    let at = D::Vector::from_fn(|a| at.0[a]);
                    let reference = match relative_to {
                        Some(other) => nearest(self.spec.body_index(other, k)?, at),
                        None => None,
                    };
                    [nearest(self.spec.body_index(body, k)?, at), reference]
                }
                _ => [None, None],
            });
        }
        Ok(tracked)
    }

    /// Each probe resolved, and what to write when.
    pub(super) fn output_plan(
        &self,
        tracked: Vec<[TrackedParticle; 2]>,
    ) -> Result<OutputPlan, SceneError> {
        let mut probes = Vec::new();
        for (k, probe) in self.spec.output.probes.iter().enumerate() {
            probes.push(match probe {
                Probe::Reaction(name) => ProbeKind::Reaction {
                    name: name.clone(),
                    index: self.spec.region_index(name, k)?,
                },
                Probe::CentreOfMassVelocity => ProbeKind::CentreOfMassVelocity,
                Probe::Force(name) => ProbeKind::Force {
                    name: name.clone(),
                    index: self.spec.body_index(name, k)? as u16,
                },
                Probe::Displacement(name) => ProbeKind::Displacement {
                    name: name.clone(),
                    index: self.spec.region_index(name, k)?,
                },
                Probe::Track { name, .. } => {
                    let [particle, reference] = tracked[k];
                    ProbeKind::Track {
                        name: name.clone(),
                        particle,
                        reference,
                    }
                }
            });
        }
        Ok(OutputPlan {
            dimension: D::DIMENSION,
            vtu_every: self.spec.output.vtu_every,
            grid_every: self.spec.output.grid_every,
            csv_every: self.spec.output.csv_every,
            probes,
            last_good_frame: self.spec.output.last_good_frame,
            system_columns: Vec::new(),
            compression: self.spec.output.compression,
            frame_fields: self.spec.output.fields.clone(),
            kinetic_fraction: self.spec.quasi_static.is_some(),
        })
    }

    /// Every name in `output.fields` is an array a particle frame of this pipeline has.
    pub(super) fn check_frame_fields(&self, world: &World) -> Result<(), SceneError> {
        let Some(fields) = &self.spec.output.fields else {
            return Ok(());
        };
        let mut known: Vec<&str> = fractum_io::output::ENGINE_FRAME_FIELDS.to_vec();
        if let Some(columns) = world.get_resource::<fractum_io::output::FrameColumns>() {
            known.extend(columns.names());
        }
        if world.contains_resource::<fractum_engine::fields::FieldsAssigned>() {
            known.push("velocity_field");
        }
        for (i, name) in fields.iter().enumerate() {
            let field = format!("output.fields[{i}]");
            if fields[..i].contains(name) {
                return Err(self
                    .spec
                    .source
                    .error(&field, format!("{name:?} is listed twice")));
            }
            if !known.contains(&name.as_str()) {
                return Err(self.spec.source.error(
                    &field,
                    format!(
                        "no frame field {name:?} in this pipeline (positions are always \
                         written); expected one of: {}",
                        known.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }
}

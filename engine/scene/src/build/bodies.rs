//! The world builder's nodes and particles: each body's particles spawned from its seeds with
//! the components the pipeline gives them, their shares of the body's loads, and the strength
//! scales a point file gives.

use super::WorldBuilder;
use super::ranks::RankPlan;
use crate::SceneError;
use crate::seed::Seeds;
use crate::seeder::Seeder;
use crate::spec::Body;
use bevy_ecs::prelude::World;
use fractum_engine::boundary::PiecewiseLinear;
use fractum_engine::components::{NodeBundle, ParticleBundle};
use fractum_engine::dim::{Dim, VectorOps};
use fractum_engine::loads::{LoadShare, ParticleLoads};
use fractum_engine::registry::templates::TemplateSet;
use fractum_engine::resources::Grid;

impl<D: Dim> WorldBuilder<'_, D> {
    /// Spawns each body's particles from its seeds; returns each body's count and the
    /// particles' shares of the loads.
    pub(super) fn spawn_bodies(
        &self,
        world: &mut World,
        templates: &TemplateSet,
        seeds: Vec<Seeds<D>>,
        plan: Option<&RankPlan>,
    ) -> Result<(Vec<usize>, ParticleLoads<D>), SceneError> {
        let mut counts = Vec::new();
        let mut next_id: u32 = 0;
        let mut loads = ParticleLoads::<D>::default();
        for ((b, body), seeded) in self.spec.bodies.iter().enumerate().zip(seeds) {
            let mut bundles = Seeder::new(&self.spec).particles(b, body, seeded, &mut next_id)?;
            self.share_loads(b, body, &mut bundles, &mut loads)?;
            if let Some(plan) = plan {
                // Ids, load shares and strength scales are the whole body's; the rank keeps its
                // own.
                bundles.retain(|p| plan.holds(&self.spec.grid, p.position.0));
            }
            counts.push(bundles.len());
            let scales = strength_scales(body, &bundles);
            let entities = templates.spawn(world, bundles);
            for (k, scale) in scales {
                // Spawned with a scale of 1 (`probe::probe_pipeline`): set in place, in the
                // same table.
                if let Some(mut given) =
                    world.get_mut::<fractum_engine::components::StrengthScale>(entities[k])
                {
                    given.0 = scale;
                }
            }
        }
        Ok((counts, loads))
    }

    /// Gives each particle that carries an affine velocity (an advection with `transfer: Apic`)
    /// the gradient of its body's initial velocity there as its `C_p`, so that the first
    /// particle-to-grid transfer hands the nodes the body's velocity field, not the particles'
    /// velocities averaged (a PIC step, which cost a spinning sphere 2.6% of its energy). Zero
    /// where a point file gave the particle its velocity (a value, not a field).
    pub(super) fn start_affine_velocities(&self, world: &mut World) {
        use fractum_engine::components::{AffineVelocity, BodyId, Position};
        let mut particles = world.query::<(&BodyId, &Position<D>, &mut AffineVelocity<D>)>();
        for (body, position, mut affine) in particles.iter_mut(world) {
            let Some(body) = self.spec.bodies.get(body.0 as usize) else {
                continue;
            };
            let x = position.0;
            let given = body
                .shape
                .point_set()
                .and_then(|set| set.attributes(x.to_3d().into()))
                .is_some_and(|a| a.velocity.is_some());
            if !given {
                affine.0 = body.velocity.gradient_at(x);
            }
        }
    }

    /// Gives each particle of `body` its share of the first of the body's loads that covers it.
    fn share_loads(
        &self,
        b: usize,
        body: &Body<D>,
        bundles: &mut [ParticleBundle<D>],
        loads: &mut ParticleLoads<D>,
    ) -> Result<(), SceneError> {
        if body.loads.is_empty() {
            return Ok(());
        }
        let first = loads.0.len();
        if first + body.loads.len() >= LoadShare::NONE as usize {
            return Err(self.spec.source.error("bodies", "more than 65534 loads"));
        }
        let mut volumes = vec![0.0; body.loads.len()];
        for p in bundles.iter_mut() {
            let x = p.position.0.to_3d().into();
            let covering = body
                .loads
                .iter()
                .position(|l| l.region.as_ref().is_none_or(|r| r.contains(x)));
            if let Some(k) = covering {
                volumes[k] += p.volume.0;
                p.load = LoadShare {
                    load: (first + k) as u16,
                    share: p.volume.0,
                };
            }
        }
        for (k, load) in body.loads.iter().enumerate() {
            if volumes[k] == 0.0 {
                return Err(self.spec.source.error(
                    &format!("bodies[{b}].loads[{k}].region"),
                    "no particle of the body lies in this region",
                ));
            }
            let ramp = if load.ramp.is_empty() {
                PiecewiseLinear::constant(1.0)
            } else {
                PiecewiseLinear::new(load.ramp.clone()).map_err(|e| {
                    self.spec
                        .source
                        .error(&format!("bodies[{b}].loads[{k}].ramp"), e)
                })?
            };
            loads.0.push((load.total, ramp));
        }
        for p in bundles
            .iter_mut()
            .filter(|p| p.load.load != LoadShare::NONE)
        {
            p.load.share /= volumes[p.load.load as usize - first];
        }
        Ok(())
    }
}

/// The strength scale a point file gives each of `bundles`, by index, when it has a
/// `strength_scale` column.
fn strength_scales<D: Dim>(body: &Body<D>, bundles: &[ParticleBundle<D>]) -> Vec<(usize, f64)> {
    let Some(set) = body.shape.point_set().filter(|s| s.has_strength_scale()) else {
        return Vec::new();
    };
    bundles
        .iter()
        .enumerate()
        .filter_map(|(k, p)| {
            let given = set.attributes(p.position.0.to_3d().into())?;
            Some((k, given.strength_scale?))
        })
        .collect()
}

/// Spawns a node for each of `grid`'s, with the components of `templates`.
pub(super) fn spawn_nodes<D: Dim>(world: &mut World, grid: &Grid<D>, templates: &TemplateSet) {
    let nodes: Vec<NodeBundle<D>> = (0..grid.node_count())
        .map(|i| NodeBundle::new(i as u32, grid.node_position(i)))
        .collect();
    templates.spawn(world, nodes);
}

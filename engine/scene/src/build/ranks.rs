//! The world builder for one rank of a distributed run: the rank's slabs and halo, the
//! particles and nodes it owns, what rebuilds its world when the slabs are re-cut, and the
//! pipelines a rank cannot run.

use super::WorldBuilder;
use crate::SceneError;
use crate::estimate::{Estimator, PipelineProbe};
use crate::seed::Seeds;
use crate::spec::Spec;
use bevy_ecs::prelude::{With, World};
use fractum_engine::decomposition::{Layout, Ownership, RankRebuild};
use fractum_engine::dim::Dim;
use fractum_engine::registry::Registry;
use fractum_engine::registry::templates::TemplateSet;
use fractum_engine::resources::Grid;
use fractum_engine::series::SeriesColumns;

/// Which rank a world is built for, and the slabs.
pub(super) struct RankPlan {
    pub(super) rank: usize,
    pub(super) layout: Layout,
    /// The run's particles, every rank's.
    pub(super) total: u64,
}

impl RankPlan {
    /// Whether the rank holds a particle at `x` (in its slab or its halo).
    pub(super) fn holds<D: Dim>(&self, grid: &Grid<D>, x: D::Vector) -> bool {
        let layer = grid.clamped_axis_cell(self.layout.axis, x[self.layout.axis]);
        self.layout.held(self.rank).contains(&layer)
    }
}

impl<D: Dim> WorldBuilder<'_, D> {
    /// The slabs of `ranks` ranks, with halos as deep as the pipeline's step reaches.
    pub(super) fn rank_plan(
        &self,
        seeds: &[Seeds<D>],
        probe: &PipelineProbe,
        rank: usize,
        ranks: usize,
        layout: Option<Layout>,
    ) -> Result<RankPlan, SceneError> {
        if probe.reach.support.is_none() {
            return Err(self.spec.source.error(
                "pipeline",
                "no basis system of this pipeline declares its support radius \
                 (Installer::declare_support_radius), so the halo a rank needs is unknown; run \
                 it as one process",
            ));
        }
        let layout = match layout {
            Some(layout) => layout,
            None => {
                let estimator = self.estimator();
                estimator.layout(estimator.slabs(seeds, ranks)?.slabs, probe)
            }
        };
        Ok(RankPlan {
            rank,
            layout,
            total: seeds.iter().map(Vec::len).sum::<usize>() as u64,
        })
    }

    /// Makes `world`, built for a rank, a rank's world: the particle templates that particles
    /// arriving from other ranks are spawned with. Refuses a pipeline
    /// that carries state from step to step outside its particles and their rows (a running
    /// total), which a rank cannot yet split between ranks.
    pub(super) fn distribute(
        &self,
        world: &mut World,
        templates: TemplateSet,
    ) -> Result<(), SceneError> {
        let engine_state = {
            let mut engine = World::new();
            fractum_io::checkpoint::carry_engine_state::<D>(&mut engine);
            let mut names = engine
                .resource::<fractum_io::checkpoint::CheckpointState>()
                .resource_names();
            // The first step with a split node, which each rank records at the nodes it owns.
            names.push(<fractum_engine::fields::FieldSplits as fractum_io::checkpoint::State>::KEY);
            names
        };
        let state = world
            .get_resource::<fractum_io::checkpoint::CheckpointState>()
            .cloned()
            .unwrap_or_default();
        let carried = state.resource_names();
        // State kept by particle row travels with the particles; other state cannot yet.
        if let Some(own) = carried.iter().find(|n| {
            !engine_state.contains(n) && !state.is_row_resource(n) && !state.is_rank_resource(n)
        }) {
            return Err(self.spec.source.error(
                "pipeline",
                format!(
                    "a system of this pipeline carries \"{own}\" from step to step, which a \
                     distributed run cannot yet split between ranks; run it as one process"
                ),
            ));
        }
        if let Some(column) = world
            .get_resource::<SeriesColumns>()
            .and_then(SeriesColumns::not_summed_over_ranks)
        {
            return Err(self.spec.source.error(
                "pipeline",
                format!(
                    "a system of this pipeline publishes the series column \"{column}\" as \
                     something other than a sum over the particles a rank owns, which a \
                     distributed run cannot yet add up over ranks; run it as one process"
                ),
            ));
        }
        world.insert_resource(fractum_engine::registry::templates::RankParticles(
            templates,
        ));
        Ok(())
    }

    /// What the rank of `plan` owns of the particles spawned in `world`, and of the nodes.
    pub(super) fn ownership(&self, world: &mut World, plan: &RankPlan) -> Ownership {
        let axis = plan.layout.axis;
        let node_layers =
            (0..self.spec.grid.node_count()).map(|n| self.spec.grid.node_lattice(n)[axis]);
        let mut ownership = Ownership::new(plan.layout.clone(), plan.rank, plan.total, node_layers);
        let mut query = world
            .query_filtered::<&fractum_engine::components::Position<D>, With<fractum_engine::components::Particle>>();
        let layers: Vec<usize> = query
            .iter(world)
            .map(|x| self.spec.grid.clamped_axis_cell(axis, x.0[axis]))
            .collect();
        ownership.mark(layers.into_iter());
        ownership
    }
}

/// What rebuilds the world of rank `rank` of `spec` for other slabs: the spec as the scene
/// gave it, with the nodes a rank reaches from the probed pipeline's support.
pub(super) fn rank_rebuild<D: Dim>(
    spec: Spec<D>,
    registry: Registry,
    rank: usize,
    probe: &PipelineProbe,
) -> RankRebuild {
    let reach = Estimator::new(&spec).node_reach(probe);
    RankRebuild::new(reach, move |layout: &Layout| {
        let built = spec
            .clone()
            .build_rank_on(&registry, rank, layout.clone())
            .map_err(|e| e.to_string())?;
        Ok(built.simulation)
    })
}

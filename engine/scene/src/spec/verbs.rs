//! What a spec is checked and built by, and the names it resolves. A [`Spec`] is data: each
//! verb hands it to the phase that does the work (the validator, the checks, the estimator,
//! the world builder), so that the phases can be read, tested and changed apart.

use super::{Built, Spec};
use crate::build::WorldBuilder;
use crate::build::probe::seeded_and_probed;
use crate::check::{Checks, quoted};
use crate::estimate::{Estimate, Estimator};
use crate::validate::Validator;
use crate::{SceneError, SceneFile};
use fractum_engine::decomposition::Layout;
use fractum_engine::dim::Dim;
use fractum_engine::registry::Registry;

/// What a spec is checked and built by: each verb hands the spec to the phase that does it
/// (`validate/`, `check.rs`, `estimate.rs`, `build/`).
impl<D: Dim> Spec<D> {
    /// Reads a scene file of this dimension into a spec: the file's values validated, each error
    /// at the file's line and column.
    pub fn from_file(file: &SceneFile) -> Result<Self, SceneError> {
        Validator::<D>::new(file.source()).spec(&file.scene)
    }

    /// Checks every value of the spec against the others; the first problem is the error.
    pub fn check(&self) -> Result<(), SceneError> {
        Checks::new(self).all()
    }

    /// The memory the scene would need, from the bodies' seeds and what the pipeline of
    /// `registry` declares, and for `ranks` ranks each rank's slab and share
    /// (`fractum check --estimate`). Nothing is spawned.
    pub fn estimate(
        self,
        registry: &Registry,
        ranks: Option<usize>,
    ) -> Result<Estimate, SceneError> {
        let probed = seeded_and_probed(&self, registry, ranks.unwrap_or(1))?;
        Estimator::new(&self).estimate(probed, ranks)
    }

    /// Checks the spec, builds the world and the step schedule with systems from `registry`,
    /// and checks what only the built world can tell. The memory the scene needs is estimated
    /// from counts (the grid, the seeds, what the pipeline gives each entity and declares)
    /// before any entity is spawned.
    pub fn build(self, registry: &Registry) -> Result<Built, SceneError> {
        WorldBuilder::new(self, registry).build(None)
    }

    /// [`Spec::build`] for rank `rank` of a distributed run of `ranks`: the world holds the
    /// particles of the rank's slab and its halo ([`fractum_engine::decomposition::Ownership`]), and is
    /// stepped with [`fractum_io::run::distributed::step`]. Every rank builds the same slabs from the
    /// same seeds.
    pub fn build_rank(
        self,
        registry: &Registry,
        rank: usize,
        ranks: usize,
    ) -> Result<Built, SceneError> {
        WorldBuilder::new(self, registry).build(Some((rank, ranks, None)))
    }

    /// [`Spec::build_rank`] on the slabs of `layout` rather than a cut of the seeds: a world
    /// for slabs that were re-cut during the run (a resume, a rebalance), holding the particles
    /// it spawns from the seeds in its slab and halo and the nodes they reach. The run's
    /// particles are then put into it ([`fractum_io::run::distributed`]).
    pub fn build_rank_on(
        self,
        registry: &Registry,
        rank: usize,
        layout: Layout,
    ) -> Result<Built, SceneError> {
        let ranks = layout.slabs.len();
        WorldBuilder::new(self, registry).build(Some((rank, ranks, Some(layout))))
    }
}

/// Names resolved: the index a material, region or body name has in the spec.
impl<D: Dim> Spec<D> {
    /// Index of the material named `name`, or an error at `field` listing the known ones.
    pub(crate) fn material_index(&self, name: &str, field: &str) -> Result<usize, SceneError> {
        let names = self.materials.iter().map(|m| Some(m.name.as_str()));
        self.index_of_name(names, name, field, "unknown material", "the scene defines")
    }

    /// The position of `name` among `names`, or an error at `field`:
    /// `{missing} "name"; {listing}: "a", "b"` (unnamed entries are not listed).
    fn index_of_name<'a>(
        &self,
        names: impl Iterator<Item = Option<&'a str>> + Clone,
        name: &str,
        field: &str,
        missing: &str,
        listing: &str,
    ) -> Result<usize, SceneError> {
        names.clone().position(|n| n == Some(name)).ok_or_else(|| {
            let known = quoted(names.clone().flatten());
            let guess = fractum_engine::text::suggest::did_you_mean(name, names.flatten());
            self.source.error(
                field,
                format!("{missing} \"{name}\"; {listing}: {known}{guess}"),
            )
        })
    }

    /// Index of the boundary region named `name`, or an error at probe `probe`.
    pub(crate) fn region_index(&self, name: &str, probe: usize) -> Result<usize, SceneError> {
        let names = self.boundaries.iter().map(|r| Some(r.name.as_str()));
        let field = format!("output.probes[{probe}]");
        self.index_of_name(
            names,
            name,
            &field,
            "no boundary region named",
            "the scene defines",
        )
    }

    /// Index of the body named `name`, or an error at probe `probe`.
    pub(crate) fn body_index(&self, name: &str, probe: usize) -> Result<usize, SceneError> {
        let names = self.bodies.iter().map(|b| b.name.as_deref());
        let field = format!("output.probes[{probe}]");
        self.index_of_name(names, name, &field, "no body named", "the named bodies are")
    }
}

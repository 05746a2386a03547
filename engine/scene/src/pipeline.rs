//! Installing a scene's pipeline: the registrations chosen and checked (known, listed once,
//! required stages filled, companions present), the entries' material filters, and each entry's
//! installer run in stage order.

use super::spec::{PipelineEntry, PipelineSummary, Spec};
use super::{SceneError, Source};
use bevy_ecs::prelude::World;
use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule};
use fractum_engine::capability::{Bystander, Capabilities};
use fractum_engine::dim::Dim;
use fractum_engine::registry::{
    Installer, MaterialFilter, PipelineEntrySet, Registration, Registry,
};
use fractum_engine::stage::Stage;

/// Installs the pipeline of one spec.
pub(crate) struct PipelineBuilder<'s, D: Dim> {
    spec: &'s Spec<D>,
}

impl<'s, D: Dim> PipelineBuilder<'s, D> {
    /// The pipeline builder of `spec`.
    pub(crate) fn new(spec: &'s Spec<D>) -> Self {
        Self { spec }
    }

    /// Where errors about pipeline entry `k` point: its place in the file when it is the
    /// entry written there, otherwise nowhere in particular.
    pub(super) fn entry_source(&self, entry: &PipelineEntry) -> Source {
        if entry.in_source {
            self.spec.source.clone()
        } else {
            Source::code(self.spec.source.name())
        }
    }

    /// Installs the chosen systems into `schedule` and `world`, in stage order. The components
    /// installers give every particle or node are left held (`registry/pending.rs`); the caller
    /// inserts them.
    pub(crate) fn install(
        &self,
        registry: &Registry,
        schedule: &mut Schedule,
        world: &mut World,
    ) -> Result<PipelineSummary, SceneError> {
        let chosen = self.chosen_systems(registry)?;
        let mut summary = PipelineSummary::default();
        for stage in Stage::ORDER {
            let names: Vec<String> = chosen
                .iter()
                .filter(|(_, r)| r.stage() == Some(stage))
                .map(|(_, r)| r.name.to_string())
                .collect();
            if !names.is_empty() {
                summary.by_stage.push((stage, names));
            }
        }
        let names: Vec<&'static str> = chosen.iter().map(|(_, r)| r.name).collect();
        let filters = chosen
            .iter()
            .map(|&(k, registration)| self.entry_filter(k, registration))
            .collect::<Result<Vec<_>, _>>()?;
        // Installed in stage order (the scene's order within a stage), so an installer can read
        // what the stages before it published: a grid law reads the predictor's integration, a
        // damage law the stress system's capabilities.
        let mut order: Vec<usize> = (0..chosen.len()).collect();
        order.sort_by_key(|&c| chosen[c].1.stage());
        for c in order {
            let ((k, registration), filter) = (&chosen[c], &filters[c]);
            let entry = &self.spec.pipeline[*k];
            let source = self.entry_source(entry);
            let params = source.params(entry.params.as_deref(), format!("pipeline[{k}].params"));
            let stage = registration.stage().unwrap_or(Stage::PostStep);
            params.check_declared(registration)?;
            let mut installer = Installer::new(stage, schedule, world)
                .with_pipeline(names.clone())
                .for_entry(*k, filter.clone());
            (registration.install)(&mut installer, &params)?;
        }
        // Entries of one stage run in the order the scene lists them.
        for (a, (ka, ra)) in chosen.iter().enumerate() {
            if let Some((kb, _)) = chosen[a + 1..]
                .iter()
                .find(|(_, rb)| rb.stage() == ra.stage())
            {
                schedule.configure_sets(PipelineEntrySet(*ka).before(PipelineEntrySet(*kb)));
            }
        }
        self.check_material_coverage(&chosen, &filters, world)?;
        Ok(summary)
    }

    /// The installed entries' [`MaterialFilter`]s, checked: no material shared by two entries
    /// of the stress or the damage stage, and a stress system for every material a body uses.
    /// Checked once the entries have installed, so that an entry that said it changes none of
    /// its stage's outputs ([`Bystander`], a shock viscosity) is passed by.
    fn check_material_coverage(
        &self,
        chosen: &[(usize, &Registration)],
        filters: &[MaterialFilter],
        world: &World,
    ) -> Result<(), SceneError> {
        let capabilities = world.get_resource::<Capabilities>();
        let bystander =
            |c: usize| capabilities.is_some_and(|k| k.provides::<Bystander>(chosen[c].0));
        for stage in [Stage::Stress, Stage::Damage] {
            let entries: Vec<usize> = (0..chosen.len())
                .filter(|&c| chosen[c].1.stage() == Some(stage) && !bystander(c))
                .collect();
            self.check_coverage(stage, &entries, chosen, filters)?;
        }
        Ok(())
    }

    /// The filter of entry `k`: all materials without `materials`, else the named ones, which
    /// must exist, on a stress or damage entry.
    fn entry_filter(
        &self,
        k: usize,
        registration: &Registration,
    ) -> Result<MaterialFilter, SceneError> {
        let entry = &self.spec.pipeline[k];
        let source = self.entry_source(entry);
        let field = format!("pipeline[{k}].materials");
        let Some(names) = &entry.materials else {
            return Ok(MaterialFilter::all());
        };
        if !matches!(registration.stage(), Some(Stage::Stress | Stage::Damage)) {
            return Err(source.error(
                &field,
                format!(
                    "`materials` limits stress and damage systems only; {} is not one",
                    registration.name
                ),
            ));
        }
        if names.is_empty() {
            return Err(source.error(&field, "expected at least one material name"));
        }
        let mut mask = vec![false; self.spec.materials.len()];
        for (j, name) in names.iter().enumerate() {
            let Some(i) = self.spec.materials.iter().position(|m| &m.name == name) else {
                let known: Vec<String> = self
                    .spec
                    .materials
                    .iter()
                    .map(|m| format!("\"{}\"", m.name))
                    .collect();
                return Err(source.error(
                    &format!("{field}[{j}]"),
                    format!(
                        "unknown material \"{name}\"; the scene defines: {}",
                        known.join(", ")
                    ),
                ));
            };
            mask[i] = true;
        }
        Ok(MaterialFilter::only(mask))
    }

    /// No material a body uses is claimed by two of `entries` (of `stage`), and, for the
    /// stress stage, each is claimed by one (checked only when some entry is limited).
    fn check_coverage(
        &self,
        stage: Stage,
        entries: &[usize],
        chosen: &[(usize, &Registration)],
        filters: &[MaterialFilter],
    ) -> Result<(), SceneError> {
        if entries.iter().all(|&c| filters[c].is_all()) {
            return Ok(());
        }
        let used = (0..self.spec.materials.len()).filter(|&i| {
            self.spec
                .bodies
                .iter()
                .any(|b| b.material == self.spec.materials[i].name)
        });
        for i in used {
            let id = fractum_engine::components::MaterialId(i as u16);
            let covering: Vec<usize> = entries
                .iter()
                .copied()
                .filter(|&c| filters[c].applies(id))
                .collect();
            let name = &self.spec.materials[i].name;
            if covering.len() > 1 {
                let (k, registration) = chosen[covering[1]];
                return Err(self.entry_source(&self.spec.pipeline[k]).error(
                    &format!("pipeline[{k}].materials"),
                    format!(
                        "{} and {} both apply to material \"{name}\"; give the {} systems \
                         disjoint `materials` lists",
                        chosen[covering[0]].1.name,
                        registration.name,
                        stage.name()
                    ),
                ));
            }
            if covering.is_empty() && stage == Stage::Stress {
                let (k, _) = chosen[entries[0]];
                return Err(self.entry_source(&self.spec.pipeline[k]).error(
                    &format!("pipeline[{k}].materials"),
                    format!(
                        "no stress system applies to material \"{name}\"; add it to the \
                         `materials` of a stress entry"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The registration of every entry, checked: known, listed once, required stages filled,
    /// partners present.
    fn chosen_systems<'r>(
        &self,
        registry: &'r Registry,
    ) -> Result<Vec<(usize, &'r Registration)>, SceneError> {
        let mut chosen: Vec<(usize, &Registration)> = Vec::new();
        for (k, entry) in self.spec.pipeline.iter().enumerate() {
            let field = format!("pipeline[{k}].system");
            let source = self.entry_source(entry);
            let Some(registration) = registry.get(&entry.system) else {
                return Err(source.error(
                    &field,
                    format!(
                        "unknown system \"{}\"{}; known systems: {}",
                        entry.system,
                        fractum_engine::text::suggest::did_you_mean(
                            &entry.system,
                            registry.names().iter().copied()
                        ),
                        registry.names().join(", ")
                    ),
                ));
            };
            if chosen.iter().any(|(_, r)| r.name == registration.name) {
                return Err(source.error(
                    &field,
                    format!("system \"{}\" is listed twice", entry.system),
                ));
            }
            chosen.push((k, registration));
        }
        for stage in Stage::REQUIRED {
            if !chosen.iter().any(|(_, r)| r.stage() == Some(stage)) {
                let options: Vec<_> = registry
                    .iter()
                    .filter(|r| r.stage() == Some(stage))
                    .map(|r| r.name)
                    .collect();
                return Err(self.spec.source.error(
                    "pipeline",
                    format!(
                        "the pipeline has no system for the required stage `{stage}`; add one of: {}",
                        options.join(", ")
                    ),
                ));
            }
        }
        for (k, registration) in &chosen {
            for needed in registration.requires {
                // `stage/*` asks for any system of that stage.
                let satisfied = match needed.strip_suffix("/*") {
                    Some(stage) => chosen
                        .iter()
                        .any(|(_, r)| r.stage().is_some_and(|s| s.name() == stage)),
                    None => chosen.iter().any(|(_, r)| r.name == *needed),
                };
                if !satisfied {
                    let source = self.entry_source(&self.spec.pipeline[*k]);
                    return Err(source.error(
                        &format!("pipeline[{k}].system"),
                        format!(
                            "system \"{}\" needs {} in the pipeline",
                            registration.name,
                            match needed.strip_suffix("/*") {
                                Some(stage) => format!("a `{stage}` system"),
                                None => format!("\"{needed}\""),
                            }
                        ),
                    ));
                }
            }
        }
        Ok(chosen)
    }
}

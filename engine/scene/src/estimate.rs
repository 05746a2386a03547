//! A scene's memory from counts, before anything is spawned: the bodies' seeds, and what the
//! pipeline gives each entity and declares per particle, read off an install on a world with
//! no node and a sample of particles. `build` holds it against what the process may use
//! before spawning; `fractum check --estimate` prints it ([`Spec::estimate`]).

use super::SceneError;
use super::budget::{self, MemoryEstimate};
use super::seed::Seeds;
use super::spec::{Body, Spec};
use bevy_ecs::prelude::World;
use fractum_engine::decomposition;
use fractum_engine::dim::{Dim, VectorOps};
use fractum_engine::loads::ParticleLoads;
use fractum_engine::registry::Registry;
use fractum_engine::registry::templates::ComponentTemplates;
use fractum_engine::resources::Grid;
use fractum_engine::simulation::step_schedule;

/// What a pipeline installed on a sample of particles tells of the scene's memory.
pub(super) struct PipelineProbe {
    /// The components it gives every particle and node.
    pub(super) templates: ComponentTemplates,
    /// The storage it declares per particle.
    pub(super) declared: budget::ParticleMemory,
    /// How far a step reaches, for a distributed run's halo.
    pub(super) reach: fractum_engine::decomposition::StepReach,
}

/// A scene's memory estimate from counts, before anything is spawned
/// ([`Spec::estimate`]).
#[derive(Clone, Debug)]
pub struct Estimate {
    /// The scene's name.
    pub source: String,
    /// Grid nodes.
    pub nodes: usize,
    /// Each body's name and seeded particle count.
    pub bodies: Vec<(String, usize)>,
    /// The estimate's parts.
    pub estimate: budget::MemoryEstimate,
    /// What the process may use.
    pub available: budget::Available,
    /// The refusal, where the estimate does not fit.
    pub refusal: Option<String>,
    /// The slabs of a distributed run, when asked for.
    pub slabs: Option<RankSlabs>,
}

/// The slabs a distributed run would own, with their bounds.
#[derive(Clone, Debug)]
pub struct RankSlabs {
    /// The cut.
    pub slabs: decomposition::Slabs,
    /// Each slab's lower and upper coordinate along the axis, metres.
    pub bounds: Vec<(f64, f64)>,
    /// Cell layers of ghost particles on each side of a slab, as deep as a step reaches.
    pub halo: usize,
    /// Each rank's particles with its ghosts, the nodes they reach, and the bytes it needs
    /// (those nodes and particles, the pipeline's storage for them, the working buffers).
    pub held: Vec<(u64, usize, f64)>,
}

impl<D: Dim> Spec<D> {
    /// The memory estimate of the scene, from counts alone (nothing is spawned), with what
    /// the process may use: `fractum check --estimate` prints it. Fails on what fails a
    /// build before spawning (a bad spec, a body with no particle, an install error), and on
    /// a scene too large to seed.
    ///
    /// With `ranks`, also the slabs a distributed run of that many ranks would own
    /// ([`fractum_engine::decomposition`]).
    pub fn estimate(
        self,
        registry: &Registry,
        ranks: Option<usize>,
    ) -> Result<Estimate, SceneError> {
        let (available, seeds, probe) = self.seeded_and_probed(registry, ranks.unwrap_or(1))?;
        let estimate = self.estimate_from_counts(&seeds, &probe);
        let slabs = match ranks {
            Some(ranks) => Some(self.rank_slabs(&seeds, &probe, ranks)?),
            None => None,
        };
        Ok(Estimate {
            slabs,
            source: self.source.name().to_string(),
            nodes: self.grid.node_count(),
            bodies: self
                .bodies
                .iter()
                .zip(&seeds)
                .enumerate()
                .map(|(b, (body, seeded))| {
                    (
                        body.name.clone().unwrap_or(format!("body {b}")),
                        seeded.len(),
                    )
                })
                .collect(),
            refusal: estimate.refusal(available),
            estimate,
            available,
        })
    }

    /// What `build` and [`Spec::estimate`] do before anything is spawned: the spec checked,
    /// the memory the process may use, a bound from the bodies' boxes held against it, the
    /// bodies seeded and the pipeline probed.
    pub(super) fn seeded_and_probed(
        &self,
        registry: &Registry,
        ranks: usize,
    ) -> Result<(budget::Available, Vec<Seeds<D>>, PipelineProbe), SceneError> {
        self.check()?;
        let available = budget::available_memory();
        self.check_memory_before_seeding(available, ranks)?;
        let seeds = self.seed_bodies()?;
        let probe = self.probe_pipeline(registry, &seeds)?;
        Ok((available, seeds, probe))
    }

    /// The pipeline installed on a world with the scene's resources, no node and a sample of
    /// particles ([`Spec::sample_seeds`]): what it gives every particle and node, and the
    /// storage it declares per particle. Installers read a mean particles-per-cell from all
    /// the seeds ([`budget::SeedDensity`]).
    pub(super) fn probe_pipeline(
        &self,
        registry: &Registry,
        seeds: &[Seeds<D>],
    ) -> Result<PipelineProbe, SceneError> {
        let mut world = World::new();
        let mut next_id = 0;
        for ((b, body), seeded) in self.bodies.iter().enumerate().zip(seeds) {
            let sample = self.sample_seeds(b, body, seeded)?;
            world.spawn_batch(self.body_particles(b, body, sample, &mut next_id)?);
        }
        self.insert_scene_resources(&mut world, ParticleLoads::<D>::default())?;
        world.insert_resource(self.seed_density(seeds));
        let mut schedule = step_schedule();
        self.install_pipeline(registry, &mut schedule, &mut world)?;
        let mut templates = world
            .remove_resource::<ComponentTemplates>()
            .unwrap_or_default();
        if !self.scaled_bodies().is_empty() {
            // Every particle carries a strength scale, 1 where no file gives one, so that all
            // of them share one table (and so do those that arrive at a rank later).
            templates
                .particles
                .record(&fractum_engine::components::StrengthScale(1.0));
        }
        Ok(PipelineProbe {
            templates,
            declared: world
                .remove_resource::<budget::ParticleMemory>()
                .unwrap_or_default(),
            reach: world
                .remove_resource::<fractum_engine::decomposition::StepReach>()
                .unwrap_or_default(),
        })
    }

    /// The bodies whose particle file gives a `strength_scale` column, by index.
    pub(super) fn scaled_bodies(&self) -> Vec<u16> {
        (self.bodies.iter().enumerate())
            .filter(|(_, body)| {
                body.shape
                    .point_set()
                    .is_some_and(|s| s.has_strength_scale())
            })
            .map(|(b, _)| b as u16)
            .collect()
    }

    /// The mean number of particles per cell of the smallest width over every seed.
    pub(super) fn seed_density(&self, seeds: &[Seeds<D>]) -> budget::SeedDensity {
        let (count, volume) = seeds
            .iter()
            .flatten()
            .fold((0.0, 0.0), |(n, v), &(_, vol)| (n + 1.0, v + vol));
        let cell = self.grid.spacing.powi(D::N as i32) * self.thickness_factor();
        budget::SeedDensity(if count == 0.0 || volume <= 0.0 {
            0.0
        } else {
            cell / (volume / count)
        })
    }

    /// A 2D scene's thickness (seeded volumes carry it), 1 in 3D.
    pub(super) fn thickness_factor(&self) -> f64 {
        if D::N == 2 { self.thickness } else { 1.0 }
    }

    /// The seeds of `body` a pipeline's install sees in the memory estimate's probe: the first
    /// of each material, undamaged and damaged, so that what installers check of the
    /// particles (their contact groups, materials, seeded damage) holds as in the real build.
    pub(super) fn sample_seeds(
        &self,
        b: usize,
        body: &Body<D>,
        seeded: &[(D::Vector, f64)],
    ) -> Result<Vec<(D::Vector, f64)>, SceneError> {
        let state = self.seed_state(b, body)?;
        let mut kinds: Vec<(usize, bool)> = Vec::new();
        let mut sample = Vec::new();
        for &(x, volume) in seeded {
            let (material, _, damage) = state(x);
            let kind = (material, damage > 0.0);
            if !kinds.contains(&kind) {
                kinds.push(kind);
                sample.push((x, volume));
            }
        }
        Ok(sample)
    }

    /// The slabs of `ranks` ranks: the seeds counted per cell layer along the axis on which
    /// they spread furthest, cut by [`decomposition::cut_slabs`]; with each rank's slab
    /// bounds in metres.
    pub(super) fn slabs(&self, seeds: &[Seeds<D>], ranks: usize) -> Result<RankSlabs, SceneError> {
        let mut low = [f64::INFINITY; 3];
        let mut high = [f64::NEG_INFINITY; 3];
        for &(x, _) in seeds.iter().flatten() {
            let x = x.to_3d();
            for a in 0..D::N {
                low[a] = low[a].min(x[a]);
                high[a] = high[a].max(x[a]);
            }
        }
        let extent: Vec<f64> = (0..D::N).map(|a| high[a] - low[a]).collect();
        let axis = decomposition::longest_axis(&extent);
        let mut per_layer = vec![0u64; self.grid.cells[axis]];
        for &(x, _) in seeds.iter().flatten() {
            if let Some(layer) = self.grid.axis_cell(axis, x[axis]) {
                per_layer[layer] += 1;
            }
        }
        let slabs = decomposition::cut_slabs(axis, &per_layer, ranks)
            .map_err(|e| self.source.error("grid.spacing", e))?;
        let bounds = slabs
            .layers
            .iter()
            .map(|r| {
                (
                    self.grid.coordinate(axis, r.start),
                    self.grid.coordinate(axis, r.end),
                )
            })
            .collect();
        Ok(RankSlabs {
            slabs,
            bounds,
            halo: 0,
            held: Vec::new(),
        })
    }

    /// [`Spec::slabs`] with each rank's halo, held particles and memory.
    fn rank_slabs(
        &self,
        seeds: &[Seeds<D>],
        probe: &PipelineProbe,
        ranks: usize,
    ) -> Result<RankSlabs, SceneError> {
        let mut slabs = self.slabs(seeds, ranks)?;
        let layout = self.layout(slabs.slabs.clone(), probe);
        slabs.halo = layout.halo;
        slabs.held = (0..ranks)
            .map(|rank| {
                let held = self.rank_seeds(seeds, &layout, rank);
                let count = held.iter().map(Vec::len).sum::<usize>() as u64;
                let nodes = self.rank_grid(&layout, rank, probe).node_count();
                let bytes = self.estimate_with_nodes(&held, probe, nodes).total();
                (count, nodes, bytes)
            })
            .collect();
        Ok(slabs)
    }

    /// The slabs with halos as deep as the probed pipeline's step reaches.
    pub(super) fn layout(
        &self,
        slabs: decomposition::Slabs,
        probe: &PipelineProbe,
    ) -> decomposition::Layout {
        let narrowest = (0..self.grid.cells[slabs.axis])
            .map(|i| self.grid.cell_width(slabs.axis, i))
            .fold(f64::INFINITY, f64::min);
        decomposition::Layout {
            axis: slabs.axis,
            slabs: slabs.layers,
            halo: probe.reach.halo_layers(narrowest),
        }
    }

    /// Node layers beyond a rank's held cell layers that its particles reach: the basis's
    /// support, a step's motion (less than a cell) and a layer for the cut.
    pub(super) fn node_reach(&self, probe: &PipelineProbe) -> usize {
        let support = probe.reach.support.unwrap_or(self.grid.spacing);
        (support / self.grid.spacing).ceil() as usize + 2
    }

    /// The part of the grid rank `rank` of `layout` holds ([`decomposition::rank_grid`]).
    pub(super) fn rank_grid(
        &self,
        layout: &decomposition::Layout,
        rank: usize,
        probe: &PipelineProbe,
    ) -> Grid<D> {
        decomposition::rank_grid(&self.grid, layout, rank, self.node_reach(probe))
    }

    /// The seeds rank `rank` of `layout` holds: those of its slab and its halo.
    pub(super) fn rank_seeds(
        &self,
        seeds: &[Seeds<D>],
        layout: &decomposition::Layout,
        rank: usize,
    ) -> Vec<Seeds<D>> {
        seeds
            .iter()
            .map(|body| {
                body.iter()
                    .copied()
                    .filter(|&(x, _)| {
                        let layer = self.grid.clamped_axis_cell(layout.axis, x[layout.axis]);
                        layout.held(rank).contains(&layer)
                    })
                    .collect()
            })
            .collect()
    }

    /// The memory the scene will need, from counts: its nodes and seeded particles, each with
    /// the engine's bundle and the components the pipeline gives it, the storage the pipeline
    /// declared per particle, and the working buffers of a step.
    pub(super) fn estimate_from_counts(
        &self,
        seeds: &[Seeds<D>],
        probe: &PipelineProbe,
    ) -> MemoryEstimate {
        self.estimate_with_nodes(seeds, probe, self.grid.node_count())
    }

    /// [`Spec::estimate_from_counts`] for a world holding `nodes` of the grid's nodes.
    fn estimate_with_nodes(
        &self,
        seeds: &[Seeds<D>],
        probe: &PipelineProbe,
        nodes: usize,
    ) -> MemoryEstimate {
        let particles = seeds.iter().map(Vec::len).sum::<usize>() as f64;
        let nodes = nodes as f64;
        let mut estimate = MemoryEstimate::default();
        estimate.add(
            format!("{} grid nodes", budget::describe_count(nodes)),
            nodes * (budget::node_bytes::<D>() + probe.templates.nodes.bytes() as f64),
        );
        estimate.add(
            format!("{} particles", budget::describe_count(particles)),
            particles * (budget::particle_bytes::<D>() + probe.templates.particles.bytes() as f64),
        );
        for (_, what, bytes) in &probe.declared.0 {
            estimate.add(what.clone(), particles * bytes);
        }
        estimate.working = budget::WORKING_BUFFERS;
        estimate
    }

    /// Refuses a scene whose estimate from counts ([`Spec::estimate_from_counts`]) cannot fit
    /// in `available`, naming the field of its largest part; checked before anything is
    /// spawned. Returns what `fractum check` prints.
    pub(super) fn check_memory_from_counts(
        &self,
        seeds: &[Seeds<D>],
        probe: &PipelineProbe,
        available: budget::Available,
    ) -> Result<budget::MemoryUse, SceneError> {
        let estimate = self.estimate_from_counts(seeds, probe);
        let Some(message) = estimate.refusal(available) else {
            return Ok(budget::MemoryUse {
                needed: estimate.total(),
                available,
            });
        };
        let particles = seeds.iter().map(Vec::len).sum::<usize>() as f64;
        let declared = probe
            .declared
            .0
            .iter()
            .map(|(field, _, bytes)| (field.clone(), particles * bytes));
        let mut largest = (
            "grid.spacing".to_string(),
            estimate.parts.first().map_or(0.0, |p| p.1),
        );
        let heaviest_body = seeds
            .iter()
            .enumerate()
            .max_by_key(|(_, s)| s.len())
            .map(|(b, _)| b);
        if let (Some(b), Some(part)) = (heaviest_body, estimate.parts.get(1)) {
            largest = largest_of(largest, (format!("bodies[{b}].particles_per_cell"), part.1));
        }
        for part in declared {
            largest = largest_of(largest, part);
        }
        Err(self.source.error(&largest.0, message))
    }
}

/// The larger part, the first on a tie.
fn largest_of(a: (String, f64), b: (String, f64)) -> (String, f64) {
    if b.1 > a.1 { b } else { a }
}

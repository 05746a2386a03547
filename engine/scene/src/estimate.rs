//! A scene's memory from counts, before anything is spawned: the bodies' seeds, and what the
//! pipeline gives each entity and declares per particle, read off an install on a world with
//! no node and a sample of particles (`build/probe.rs`). `build` holds it against what the
//! process may use before spawning; `fractum check --estimate` prints it ([`Spec::estimate`]).
//! The memory before seeding is bounded from the bodies' boxes.

use super::SceneError;
use super::budget::{self, MemoryEstimate};
use super::seed::Seeds;
use super::spec::Spec;
use fractum_engine::decomposition;
use fractum_engine::dim::{Dim, VectorOps};
use fractum_engine::registry::templates::ComponentTemplates;
use fractum_engine::resources::Grid;

/// What a pipeline installed on a sample of particles tells of the scene's memory.
pub(crate) struct PipelineProbe {
    /// The components it gives every particle and node.
    pub(crate) templates: ComponentTemplates,
    /// The storage it declares per particle.
    pub(crate) declared: budget::ParticleMemory,
    /// How far a step reaches, for a distributed run's halo.
    pub(crate) reach: fractum_engine::decomposition::StepReach,
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

/// The estimator of one spec: seeds, a probe of the pipeline, and the memory and slabs that
/// follow from them.
pub(crate) struct Estimator<'s, D: Dim> {
    spec: &'s Spec<D>,
}

/// What the estimator found before anything is spawned: the memory the process may use, each
/// body's seeds, and what the pipeline gives and declares.
pub(crate) struct Probed<D: Dim> {
    pub(crate) available: budget::Available,
    pub(crate) seeds: Vec<Seeds<D>>,
    pub(crate) probe: PipelineProbe,
}

impl<'s, D: Dim> Estimator<'s, D> {
    /// The estimator of `spec`.
    pub(crate) fn new(spec: &'s Spec<D>) -> Self {
        Self { spec }
    }

    /// The memory estimate of the scene, from counts alone (nothing is spawned), with what
    /// the process may use: `fractum check --estimate` prints it. Fails on what fails a
    /// build before spawning (a bad spec, a body with no particle, an install error), and on
    /// a scene too large to seed.
    ///
    /// With `ranks`, also the slabs a distributed run of that many ranks would own
    /// ([`fractum_engine::decomposition`]).
    pub(crate) fn estimate(
        &self,
        probed: Probed<D>,
        ranks: Option<usize>,
    ) -> Result<Estimate, SceneError> {
        let Probed {
            available,
            seeds,
            probe,
        } = probed;
        let estimate = self.estimate_from_counts(&seeds, &probe);
        let slabs = match ranks {
            Some(ranks) => Some(self.rank_slabs(&seeds, &probe, ranks)?),
            None => None,
        };
        Ok(Estimate {
            slabs,
            source: self.spec.source.name().to_string(),
            nodes: self.spec.grid.node_count(),
            bodies: self
                .spec
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

    /// The slabs of `ranks` ranks: the seeds counted per cell layer along the axis on which
    /// they spread furthest, cut by [`decomposition::cut_slabs`] with the grid's nodes per
    /// layer; with each rank's slab bounds in metres.
    pub(crate) fn slabs(&self, seeds: &[Seeds<D>], ranks: usize) -> Result<RankSlabs, SceneError> {
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
        let mut per_layer = vec![0u64; self.spec.grid.cells[axis]];
        for &(x, _) in seeds.iter().flatten() {
            if let Some(layer) = self.spec.grid.axis_cell(axis, x[axis]) {
                per_layer[layer] += 1;
            }
        }
        let nodes = self.spec.grid.nodes_per_layer(axis);
        let slabs = decomposition::cut_slabs(axis, &per_layer, nodes, ranks)
            .map_err(|e| self.spec.source.error("grid.spacing", e))?;
        let bounds = slabs
            .layers
            .iter()
            .map(|r| {
                (
                    self.spec.grid.coordinate(axis, r.start),
                    self.spec.grid.coordinate(axis, r.end),
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
    pub(crate) fn layout(
        &self,
        slabs: decomposition::Slabs,
        probe: &PipelineProbe,
    ) -> decomposition::Layout {
        let narrowest = (0..self.spec.grid.cells[slabs.axis])
            .map(|i| self.spec.grid.cell_width(slabs.axis, i))
            .fold(f64::INFINITY, f64::min);
        decomposition::Layout {
            axis: slabs.axis,
            slabs: slabs.layers,
            halo: probe.reach.halo_layers(narrowest),
        }
    }

    /// Node layers beyond a rank's held cell layers that its particles reach: the basis's
    /// support, a step's motion (less than a cell) and a layer for the cut.
    pub(crate) fn node_reach(&self, probe: &PipelineProbe) -> usize {
        let support = probe.reach.support.unwrap_or(self.spec.grid.spacing);
        (support / self.spec.grid.spacing).ceil() as usize + 2
    }

    /// The part of the grid rank `rank` of `layout` holds ([`decomposition::rank_grid`]).
    pub(crate) fn rank_grid(
        &self,
        layout: &decomposition::Layout,
        rank: usize,
        probe: &PipelineProbe,
    ) -> Grid<D> {
        decomposition::rank_grid(&self.spec.grid, layout, rank, self.node_reach(probe))
    }

    /// The seeds rank `rank` of `layout` holds: those of its slab and its halo.
    pub(crate) fn rank_seeds(
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
                        let layer = self
                            .spec
                            .grid
                            .clamped_axis_cell(layout.axis, x[layout.axis]);
                        layout.held(rank).contains(&layer)
                    })
                    .collect()
            })
            .collect()
    }

    /// The memory the scene will need, from counts: its nodes and seeded particles, each with
    /// the engine's bundle and the components the pipeline gives it, the storage the pipeline
    /// declared per particle, and the working buffers of a step.
    pub(crate) fn estimate_from_counts(
        &self,
        seeds: &[Seeds<D>],
        probe: &PipelineProbe,
    ) -> MemoryEstimate {
        self.estimate_with_nodes(seeds, probe, self.spec.grid.node_count())
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
    pub(crate) fn check_memory_from_counts(
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
        Err(self.spec.source.error(&largest.0, message))
    }

    /// Refuses a grid or bodies that cannot fit in `available` before any particle is seeded:
    /// the nodes, and each body's particles bounded by its bounding box's cells (at the
    /// smallest cell width) times the particles per cell. A cheap bound, so that a mistaken
    /// spacing is refused before its seeds fill the memory. A rank of `ranks` holds only the
    /// nodes its particles reach, a share of at least `1/ranks` for the most loaded; it seeds
    /// every body to find its own particles.
    pub(crate) fn check_memory_before_seeding(
        &self,
        available: budget::Available,
        ranks: usize,
    ) -> Result<(), SceneError> {
        let nodes = (0..D::N)
            .map(|a| (self.spec.grid.cells[a] + 1) as f64)
            .product::<f64>()
            / ranks.max(1) as f64;
        let share = if ranks > 1 { " (a rank's share)" } else { "" };
        let mut estimate = MemoryEstimate::default();
        estimate.add(
            format!("{} grid nodes{share}", budget::describe_count(nodes)),
            nodes * budget::node_bytes::<D>(),
        );
        let (lo, hi) = (self.spec.grid.min.to_3d(), self.spec.grid.max().to_3d());
        let mut largest_body = (0, 0.0);
        for (b, body) in self.spec.bodies.iter().enumerate() {
            let (min, max) = body.shape.bounds();
            let cells: f64 = (0..D::N)
                .map(|a| {
                    let extent = (max[a].min(hi[a]) - min[a].max(lo[a])).max(0.0);
                    (extent / self.spec.grid.spacing).ceil() + 1.0
                })
                .product();
            let particles = body
                .shape
                .own_particle_bound(body.particles_per_cell)
                .unwrap_or(cells * f64::from(body.particles_per_cell).powi(D::N as i32));
            if particles > largest_body.1 {
                largest_body = (b, particles);
            }
            estimate.add(
                format!(
                    "up to {} particles of bodies[{b}]",
                    budget::describe_count(particles)
                ),
                particles * budget::particle_bytes::<D>(),
            );
        }
        match estimate.refusal(available) {
            None => Ok(()),
            Some(message) => {
                let node_bytes = estimate.parts[0].1;
                let field = if node_bytes >= largest_body.1 * budget::particle_bytes::<D>() {
                    "grid.spacing".to_string()
                } else {
                    format!("bodies[{}].particles_per_cell", largest_body.0)
                };
                Err(self.spec.source.error(&field, message))
            }
        }
    }
}

/// The larger part, the first on a tie.
fn largest_of(a: (String, f64), b: (String, f64)) -> (String, f64) {
    if b.1 > a.1 { b } else { a }
}

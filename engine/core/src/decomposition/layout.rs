//! What each rank of a distributed run holds: its slab of the grid's cell layers and a halo.
//!
//! **What a rank holds.** The particles of its slab (it *owns* them) and copies of every
//! particle within [`Layout::halo`] layers of the slab (*ghosts*), with the grid's nodes that
//! those particles reach ([`Layout::node_layers`]).
//! Each rank steps its particles, owned and ghost alike, with the scene's whole pipeline, in
//! the order of their global ids (`fractum_io::run::distributed::redistribute` keeps the rows sorted by id), so a node that
//! an owned particle's step reads sums the same entries in the same order as the single
//! process: an owned particle's state is the single process's, bit for bit. The halo is as
//! deep as the step's chain of particle–grid–particle transfers and particle neighbourhoods
//! reaches ([`StepReach`], declared by the systems' installers), plus one layer for the
//! particles a rank may take over after the step ([`StepReach::halo_layers`] says why that is
//! enough). Ghosts near the halo's outer face read nodes
//! that miss some of their particles, so what they compute is wrong, and no rank uses it: after
//! every step each particle's owner sends its state to every rank that holds it
//! (`fractum_io::run::distributed::redistribute`), which replaces every ghost and moves each particle that crossed into
//! another slab to its new owner.
//!
//! **Why recompute rather than sum nodes across ranks.** Summing each shared node's values
//! over ranks needs an exchange after every transfer of the step (mass and momentum, forces,
//! each contact field), with the sum's order fixed by hand to stay bitwise; recomputing the
//! halo needs one exchange per step and no system knows it is distributed. The price is the
//! halo's work, which the slabs' widths bound; `fractum check --estimate --ranks N` shows it.
//!
//! **What a rank checks.** The health checks look at owned particles and at nodes of the
//! slab's own layers ([`Ownership`]); the stable step is the least over ranks.

use bevy_ecs::prelude::Resource;
use std::ops::Range;

/// How far one step's update of a particle reaches, particle to particle, as the pipeline's
/// installers declare it: a distributed run's halo must be at least this deep.
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct StepReach {
    /// The basis's support radius along an axis (m): how far a particle's nodes lie from it.
    pub support: Option<f64>,
    /// Particle → grid → particle round trips in a step (a transfer to the nodes that later
    /// particles read back): each reaches twice the support.
    pub round_trips: u32,
    /// Other reaches (m), with the pipeline entry and what they are: a damage law's
    /// neighbourhood, a damage gradient's kernel.
    pub neighbourhoods: Vec<(String, f64)>,
}

impl StepReach {
    /// The distance (m) one step's update of a particle reads from.
    pub fn metres(&self) -> f64 {
        2.0 * self.support.unwrap_or(0.0) * self.round_trips as f64
            + self.neighbourhoods.iter().map(|(_, r)| r).sum::<f64>()
    }

    /// The halo in cell layers at least `h` wide: the reach in layers, and one more.
    ///
    /// Every particle an owned particle's step reads lies closer than the reach `R` at the
    /// start of the step (positions move only at its end), and two points closer than `R`
    /// along the slabs' axis are at most `⌈R/h⌉` layers apart, wherever they sit in their
    /// layers: so `⌈R/h⌉` layers make the owned particles exact. A rank also takes over the
    /// particles that began the step in the layer next to its slab and ended it inside (the
    /// stable step moves no particle a whole cell), whose steps must be exact as well: one
    /// layer more.
    pub fn halo_layers(&self, h: f64) -> usize {
        (self.metres() / h).ceil() as usize + 1
    }
}

/// The slabs of a distributed run and the depth of their halos.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Layout {
    /// The axis the slabs are stacked along.
    pub axis: usize,
    /// Each rank's cell layers, in rank order, covering `0..cells`.
    pub slabs: Vec<Range<usize>>,
    /// Layers of ghosts on each side of a slab.
    pub halo: usize,
}

impl Layout {
    /// The number of cell layers along the axis.
    pub fn cells(&self) -> usize {
        self.slabs.last().map_or(0, |s| s.end)
    }

    /// The rank whose slab holds `layer`.
    pub fn owner(&self, layer: usize) -> usize {
        self.slabs
            .partition_point(|s| s.end <= layer)
            .min(self.slabs.len() - 1)
    }

    /// The layers rank `rank` holds particles of: its slab and the halo, within the grid.
    pub fn held(&self, rank: usize) -> Range<usize> {
        let slab = &self.slabs[rank];
        slab.start.saturating_sub(self.halo)..(slab.end + self.halo).min(self.cells())
    }

    /// The node layers along the axis that rank `rank`'s particles reach: the nodes of its held
    /// cell layers and `reach` node layers more on each side, within the grid's `cells() + 1`.
    /// A rank's world holds these nodes only ([`crate::resources::Grid::window`]).
    pub fn node_layers(&self, rank: usize, reach: usize) -> Range<usize> {
        let held = self.held(rank);
        held.start.saturating_sub(reach)..(held.end + 1 + reach).min(self.cells() + 1)
    }

    /// The ranks that hold particles of `layer`, ascending.
    pub fn holders(&self, layer: usize) -> impl Iterator<Item = usize> + '_ {
        (0..self.slabs.len()).filter(move |&r| self.held(r).contains(&layer))
    }

    /// The ranks `rank` exchanges particles with: those whose slab meets its held layers or
    /// whose held layers meet its slab (the same relation seen from either side).
    pub fn peers(&self, rank: usize) -> Vec<usize> {
        let meets = |a: &Range<usize>, b: &Range<usize>| a.start < b.end && b.start < a.end;
        (0..self.slabs.len())
            .filter(|&r| {
                r != rank
                    && (meets(&self.held(rank), &self.slabs[r])
                        || meets(&self.held(r), &self.slabs[rank]))
            })
            .collect()
    }
}

/// What this rank owns: a resource of a rank's world in a distributed run. Serial worlds have
/// none, and own everything. A rank's checkpoint carries it.
#[derive(Resource, Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Ownership {
    /// This rank.
    pub rank: usize,
    /// The slabs and halos.
    pub layout: Layout,
    /// Per particle row: owned here (in this rank's slab when the step began).
    pub particles: Vec<bool>,
    /// Per particle row: within a layer of this rank's slab when the step began, so that its
    /// step here is exact and this rank may take it over if it ends the step in the slab.
    pub claimable: Vec<bool>,
    /// The particles of the whole run (every rank's owned ones).
    pub total: u64,
    /// Re-cut the slabs after a step when the most loaded rank holds more than this fraction
    /// over the mean of its own load (particles, and nodes at
    /// [`super::NODE_COST`]; `None`: never). 0.1 unless set.
    pub rebalance_above: Option<f64>,
    /// How far the most loaded rank was over the mean after the last step.
    pub imbalance: f64,
    /// How often the slabs were re-cut.
    pub rebalances: u64,
    /// How often a re-cut moved the nodes this rank holds, so that its world was built afresh
    /// for the new slabs (`fractum_io::run::distributed::step`).
    pub rebuilds: u64,
    /// Bytes this rank has sent to other ranks since the run began: each step's particles for
    /// their holders (`fractum_io::run::distributed::redistribute`).
    pub sent_bytes: u64,
    /// Per node index: owned here (on the lower face of one of this rank's cell layers, or
    /// the grid's last node layer for the last rank), so that each node counts on one rank.
    pub nodes: Vec<bool>,
    /// The slabs were re-cut after the last step, and the nodes this rank holds and owns are
    /// still the last step's: they follow the slabs when the next step begins
    /// (`fractum_io::run::distributed::step`).
    pub nodes_pending: bool,
    /// The particles this rank owned that left the grid in this step under
    /// `LeaveGrid::Remove` (id and position, x, y, z), no longer owned from the end of the
    /// step's advection ([`crate::health::mark_escaped_particles`]); the step's redistribution
    /// counts and drops them. Empty between steps.
    #[serde(skip)]
    pub escaped: Vec<(u32, [f64; 3])>,
}

impl Ownership {
    /// The ownership of rank `rank` of a run of `total` particles, with no particle marked yet
    /// ([`Ownership::mark`]); `node_layers` gives each node's lattice index along the axis, in
    /// node order.
    pub fn new(
        layout: Layout,
        rank: usize,
        total: u64,
        node_layers: impl Iterator<Item = usize>,
    ) -> Self {
        let mut ownership = Self {
            rank,
            layout,
            particles: Vec::new(),
            claimable: Vec::new(),
            total,
            rebalance_above: Some(0.1),
            imbalance: 0.0,
            rebalances: 0,
            rebuilds: 0,
            sent_bytes: 0,
            nodes: Vec::new(),
            nodes_pending: false,
            escaped: Vec::new(),
        };
        ownership.nodes = ownership.node_flags(node_layers);
        ownership
    }

    /// Whether each node is owned here, from its lattice index along the axis (`node_layers`,
    /// in node order).
    pub fn node_flags(&self, node_layers: impl Iterator<Item = usize>) -> Vec<bool> {
        let slab = self.layout.slabs[self.rank].clone();
        // Node layer `i` lies on the lower face of cell layer `i`: each node belongs to the
        // slab of the cell layer above it, and the grid's last node layer to the last slab.
        let last = slab.end == self.layout.cells();
        node_layers
            .map(|i| slab.contains(&i) || (last && i == slab.end))
            .collect()
    }

    /// Takes the slabs of `layout` (the same ranks and halo), with each node's lattice index
    /// along the axis from `node_layers`.
    pub fn relayout(&mut self, layout: Layout, node_layers: impl Iterator<Item = usize>) {
        let rebalances = self.rebalances + 1;
        let (above, total, sent) = (self.rebalance_above, self.total, self.sent_bytes);
        let rebuilds = self.rebuilds;
        *self = Self::new(layout, self.rank, total, node_layers);
        self.rebalance_above = above;
        self.rebalances = rebalances;
        self.rebuilds = rebuilds;
        self.sent_bytes = sent;
    }

    /// Marks each particle row from the layer it is in at the start of a step.
    pub fn mark(&mut self, layers: impl Iterator<Item = usize>) {
        let slab = self.layout.slabs[self.rank].clone();
        let near = slab.start.saturating_sub(1)..slab.end + 1;
        (self.particles, self.claimable) = layers
            .map(|layer| (slab.contains(&layer), near.contains(&layer)))
            .unzip();
    }

    /// Whether particle row `row` is owned here.
    pub fn owns_particle(&self, row: usize) -> bool {
        self.particles.get(row).copied().unwrap_or(false)
    }
}

/// Whether particle row `row` counts in this process's sums (energies, momentum, a damage
/// law's count): owned here in a distributed run (`ownership` given), every row otherwise.
pub fn counts_here(ownership: Option<&Ownership>, row: usize) -> bool {
    ownership.is_none_or(|o| o.owns_particle(row))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout() -> Layout {
        Layout {
            axis: 0,
            slabs: vec![0..4, 4..10, 10..12],
            halo: 3,
        }
    }

    #[test]
    fn a_layer_has_one_owner_and_is_held_by_the_ranks_within_a_halo_of_it() {
        let l = layout();
        let owners: Vec<usize> = (0..12).map(|k| l.owner(k)).collect();
        assert_eq!(owners, [0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 2, 2]);
        assert_eq!(l.held(0), 0..7);
        assert_eq!(l.held(1), 1..12);
        assert_eq!(l.held(2), 7..12);
        assert_eq!(l.holders(0).collect::<Vec<_>>(), [0]);
        assert_eq!(l.holders(6).collect::<Vec<_>>(), [0, 1]);
        assert_eq!(l.holders(8).collect::<Vec<_>>(), [1, 2]);
        assert_eq!(l.peers(0), [1]);
        assert_eq!(l.peers(1), [0, 2]);
        assert_eq!(l.peers(2), [1]);
        // The nodes of the held cell layers and two node layers more each way, within the
        // grid's 13 node layers; every rank's own nodes among them.
        assert_eq!(l.node_layers(0, 2), 0..10);
        assert_eq!(l.node_layers(1, 2), 0..13);
        assert_eq!(l.node_layers(2, 2), 5..13);
        for rank in 0..3 {
            let slab = &l.slabs[rank];
            let nodes = l.node_layers(rank, 0);
            assert!(nodes.start <= slab.start && nodes.end > slab.end, "{rank}");
        }
        // A halo wider than a slab reaches past the neighbour: ranks 0 and 2 meet.
        let wide = Layout { halo: 7, ..l };
        assert_eq!(wide.peers(0), [1, 2]);
        assert_eq!(wide.peers(2), [0, 1]);
    }

    #[test]
    fn each_node_and_particle_layer_is_owned_by_one_rank() {
        let l = layout();
        let owners: Vec<Vec<usize>> = (0..=12)
            .map(|i| {
                (0..3)
                    .filter(|&r| Ownership::new(l.clone(), r, 0, 0..=12).nodes[i])
                    .collect()
            })
            .collect();
        assert!(owners.iter().all(|o| o.len() == 1), "{owners:?}");
        assert_eq!(owners[4], [1]);
        assert_eq!(owners[12], [2]);
        let mut o = Ownership::new(l, 1, 0, 0..=12);
        o.mark([2, 3, 4, 9, 10, 11].into_iter());
        assert_eq!(o.particles, [false, false, true, true, false, false]);
        assert_eq!(o.claimable, [false, true, true, true, true, false]);
    }

    #[test]
    fn the_halo_covers_the_transfers_and_neighbourhoods_a_step_declares() {
        let reach = StepReach {
            support: Some(0.1),
            round_trips: 2,
            neighbourhoods: vec![("pipeline[4]".into(), 0.15)],
        };
        assert!((reach.metres() - 0.55).abs() < 1e-15);
        // 0.55 / 0.1 = 5.5 layers, six, plus the layer of the particles a rank takes over.
        assert_eq!(reach.halo_layers(0.1), 7);
        // A reach of whole layers needs no layer for the part of one.
        let two_layers = StepReach {
            support: Some(0.1),
            round_trips: 1,
            neighbourhoods: Vec::new(),
        };
        assert_eq!(two_layers.halo_layers(0.1), 3);
    }
}

//! How a scene divides over the ranks of a distributed run: one slab of cell layers per rank,
//! along the axis on which the particles spread furthest, cut at cell faces so that the rank
//! with the most work has as little as any such cut allows.
//!
//! A rank's work is counted as its particles and its nodes, a node at [`NODE_COST`] of a
//! particle: a rank holds every node of its cell layers, so a slab over empty space (the
//! region an impactor travels through) costs a step even with no particle in it. The cut is
//! the contiguous partition of the layers' loads that minimises its largest part: the least
//! bound `B` for which filling slabs greedily up to `B` needs no more slabs than ranks, found
//! by bisection on `B` (the greedy fill is optimal for a given bound). Slabs rather than
//! recursive bisection because a slab has two neighbours, whatever the rank count, which keeps
//! a first distributed step's exchanges to two per rank; the imbalance this reports tells when
//! a scene needs better.

mod layout;
mod owned;

pub use layout::{Layout, Ownership, StepReach, counts_here};
pub use owned::{Owned, OwnedRows};

use bevy_ecs::prelude::{Resource, World};

/// A value of the whole scene that a system needs and a rank cannot find alone, such as the
/// largest of a quantity over every particle: before each step for which `wanted` holds on any
/// rank (a rank whose world was built afresh for re-cut slabs wants it again), a distributed
/// run takes each rank's `local` maximum over what it owns, and gives the greatest over ranks
/// to every rank's world with `apply`
/// (`fractum_io::run::distributed::step`). One process never calls them: its system finds the
/// value over its own particles.
#[derive(Clone, Copy)]
pub struct RankMaximum {
    /// What the value is (one entry per name).
    pub name: &'static str,
    /// Whether the value is wanted before the coming step.
    pub wanted: fn(&World) -> bool,
    /// This rank's maximum over the particles or nodes it owns.
    pub local: fn(&mut World) -> f64,
    /// Gives the world the run's maximum.
    pub apply: fn(&mut World, f64),
}

/// The [`RankMaximum`]s the pipeline asked for (`Installer::add_rank_maximum`).
#[derive(Resource, Clone, Default)]
pub struct RankMaxima(pub Vec<RankMaximum>);

/// How a rank's world is built afresh for other slabs, a resource of a rank's world
/// (`Spec::build_rank` inserts it). A rank holds the nodes its particles reach
/// ([`rank_grid`]); when the slabs are re-cut and those nodes change,
/// `fractum_io::run::distributed::step` builds the rank's world for the new slabs from the scene
/// and moves the run's state into it, as a resume would. Every system then starts from a
/// world built for the nodes it holds, whatever it caches about them.
#[derive(Resource, Clone)]
pub struct RankRebuild {
    /// Node layers a rank holds beyond the nodes of its held cell layers, on each side.
    pub node_reach: usize,
    build: RankBuilder,
}

/// Builds the world of one rank of a scene for the slabs of a layout.
type RankBuilder =
    std::sync::Arc<dyn Fn(&Layout) -> Result<crate::Simulation, String> + Send + Sync + 'static>;

impl RankRebuild {
    /// A rebuild that holds `node_reach` node layers beyond the held cells and builds with
    /// `build`.
    pub fn new(
        node_reach: usize,
        build: impl Fn(&Layout) -> Result<crate::Simulation, String> + Send + Sync + 'static,
    ) -> Self {
        Self {
            node_reach,
            build: std::sync::Arc::new(build),
        }
    }

    /// The rank's simulation built from the scene for the slabs of `layout`.
    pub fn build(&self, layout: &Layout) -> Result<crate::Simulation, String> {
        (self.build)(layout)
    }
}

/// The part of `grid` that rank `rank` of `layout` holds: every node along the other axes, and
/// along the slabs' axis the node layers its held cell layers reach, with `node_reach` more
/// on each side ([`Layout::node_layers`]).
pub fn rank_grid<D: crate::dim::Dim>(
    grid: &crate::resources::Grid<D>,
    layout: &Layout,
    rank: usize,
    node_reach: usize,
) -> crate::resources::Grid<D> {
    use crate::dim::Lattice;
    let axis = layout.axis;
    let layers = layout.node_layers(rank, node_reach);
    let all = grid.nodes_per_axis();
    grid.whole().windowed(crate::resources::NodeWindow {
        first: D::Cell::from_fn(|a| if a == axis { layers.start } else { 0 }),
        counts: D::Cell::from_fn(|a| if a == axis { layers.len() } else { all[a] }),
    })
}

use std::ops::Range;

/// What a node costs a step, in particles: the weight that balances the two ranks' pipelines
/// of `kalthoff_winkler_dfg` (B-splines, DFG partitioning, frictional contact; callgrind, one
/// thread a rank: 124.7 and 124.1 M instructions a step at 0.5, 128.3 and 121.0 M at 0.25,
/// where the rank over the impactor and the empty space before it holds 7 500 nodes more;
/// docs/design/distributed.md, "Slabs cut by particles and nodes"). An empty node alone costs
/// less, measured by adding 50 layers of empty nodes to three shipped scenes and dividing the
/// instructions a step they add per node by those of a particle: 0.26 on
/// `kalthoff_winkler_dfg` (1 140 instructions a node, 4 440 a particle), 0.30 on
/// `brazilian_dfg` (GIMP, DFG: 1 150 and 3 780), 0.10 on `drop_weight_881` (LME with
/// eigensoftening: 750 and 7 400); a node that carries mass costs more (its fields, their
/// contact and the partition), which the balanced weight counts. A slab of layers with as many
/// particles and nodes as its neighbour's is cut the same at any weight: the weight moves only
/// cuts between regions of different density, as an impactor's.
pub const NODE_COST: f64 = 0.5;

/// The slabs' loads are counted in hundredths of a particle, so that [`NODE_COST`] times a
/// layer's nodes keeps two decimals in whole numbers.
const LOAD_UNIT: u64 = 100;

/// Each cell layer's load, in hundredths of a particle: its `particles` and its
/// `nodes_per_layer` nodes (every layer along a slab's axis has as many) at [`NODE_COST`].
pub fn layer_loads(particles: &[u64], nodes_per_layer: u64) -> Vec<u64> {
    let nodes = (nodes_per_layer as f64 * NODE_COST * LOAD_UNIT as f64).round() as u64;
    particles.iter().map(|&p| p * LOAD_UNIT + nodes).collect()
}

/// The slabs of a scene over its ranks.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Slabs {
    /// The axis the slabs are stacked along (0 = x).
    pub axis: usize,
    /// Each rank's cell layers along `axis`, in rank order, covering every layer.
    pub layers: Vec<Range<usize>>,
    /// Each rank's particles.
    pub particles: Vec<u64>,
    /// Each rank's load: its particles and its nodes at [`NODE_COST`], in hundredths of a
    /// particle ([`layer_loads`]).
    pub loads: Vec<u64>,
}

impl Slabs {
    /// How far the most loaded rank is above the mean: `max / mean − 1` of the loads (0 when
    /// balanced).
    pub fn imbalance(&self) -> f64 {
        imbalance(&self.loads)
    }
}

/// `max / mean − 1` of per-rank counts; 0 for no particles.
pub fn imbalance(counts: &[u64]) -> f64 {
    let total: u64 = counts.iter().sum();
    let Some(&most) = counts.iter().max() else {
        return 0.0;
    };
    if total == 0 {
        return 0.0;
    }
    most as f64 * counts.len() as f64 / total as f64 - 1.0
}

/// Cuts the cell layers along `axis` into `ranks` slabs of at least one layer each,
/// minimising the largest slab's load ([`layer_loads`] of `per_layer`, the particles in each
/// layer, and `nodes_per_layer`). Refused when there are fewer layers than ranks.
pub fn cut_slabs(
    axis: usize,
    per_layer: &[u64],
    nodes_per_layer: u64,
    ranks: usize,
) -> Result<Slabs, String> {
    if ranks == 0 {
        return Err("a run needs at least one rank".to_string());
    }
    if per_layer.len() < ranks {
        return Err(format!(
            "the grid has {} cell layers along the {} axis, fewer than the {ranks} ranks: a rank \
             owns at least one layer",
            per_layer.len(),
            ["x", "y", "z"][axis.min(2)]
        ));
    }
    let loads = layer_loads(per_layer, nodes_per_layer);
    let layers = cut_loads(&loads, ranks);
    let sums = |per_layer: &[u64]| -> Vec<u64> {
        (layers.iter())
            .map(|r| per_layer[r.clone()].iter().sum())
            .collect()
    };
    Ok(Slabs {
        axis,
        particles: sums(per_layer),
        loads: sums(&loads),
        layers,
    })
}

/// The contiguous cut of `loads` into `ranks` (at most `loads.len()`) non-empty slabs with the
/// least largest slab.
fn cut_loads(loads: &[u64], ranks: usize) -> Vec<Range<usize>> {
    let (mut low, mut high) = (
        loads.iter().copied().max().unwrap_or(0),
        loads.iter().sum::<u64>(),
    );
    while low < high {
        let bound = low + (high - low) / 2;
        if greedy_slabs(loads, bound).len() <= ranks {
            high = bound;
        } else {
            low = bound + 1;
        }
    }
    let mut layers = greedy_slabs(loads, low);
    // Fewer slabs than ranks: split slabs of several layers (no part grows) until each rank
    // has one, taking layers off the end of the widest.
    while layers.len() < ranks {
        let widest = (0..layers.len())
            .max_by_key(|&k| (layers[k].len(), std::cmp::Reverse(k)))
            .expect("at least one slab");
        let range = layers[widest].clone();
        let middle = range.start + range.len() / 2;
        layers[widest] = range.start..middle;
        layers.insert(widest + 1, middle..range.end);
    }
    layers
}

/// Slabs filled in order up to `bound` load each (a layer above `bound` alone makes one).
fn greedy_slabs(per_layer: &[u64], bound: u64) -> Vec<Range<usize>> {
    let mut slabs = Vec::new();
    let (mut start, mut load) = (0, 0u64);
    for (k, &count) in per_layer.iter().enumerate() {
        if k > start && load + count > bound {
            slabs.push(start..k);
            (start, load) = (k, 0);
        }
        load += count;
    }
    slabs.push(start..per_layer.len());
    slabs
}

/// The axis along which `extent` (the particles' bounding box, per axis) is longest; the
/// first on a tie.
pub fn longest_axis(extent: &[f64]) -> usize {
    (0..extent.len()).fold(0, |best, a| if extent[a] > extent[best] { a } else { best })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_uniform_body_is_cut_into_equal_slabs() {
        let slabs = cut_slabs(0, &[10; 12], 0, 4).unwrap();
        assert_eq!(slabs.layers, vec![0..3, 3..6, 6..9, 9..12]);
        assert_eq!(slabs.particles, vec![30; 4]);
        assert_eq!(slabs.imbalance(), 0.0);
    }

    #[test]
    fn empty_layers_go_to_the_outer_slabs_and_the_dense_part_is_shared() {
        // A body in the middle third of the grid.
        let mut per_layer = vec![0; 30];
        per_layer[10..20].fill(100);
        let slabs = cut_slabs(1, &per_layer, 0, 2).unwrap();
        assert_eq!(slabs.particles, vec![500, 500]);
        assert_eq!(slabs.layers[0].end, 15);
        assert_eq!(slabs.layers.last().unwrap().end, 30);
    }

    /// An impactor's layers (few particles, every node of the layer held) next to a target's
    /// (many particles): counted by particles alone the impactor's rank gets the empty nodes
    /// over the cut as well; with the nodes counted, layers of the target move to the other
    /// rank until the loads are as even as the layers allow.
    #[test]
    fn a_slab_over_empty_nodes_takes_fewer_particles() {
        let mut per_layer = vec![20u64; 40];
        per_layer[20..].fill(100);
        let by_particles = cut_slabs(0, &per_layer, 0, 2).unwrap();
        let by_load = cut_slabs(0, &per_layer, 100, 2).unwrap();
        assert_eq!(by_particles.layers, vec![0..28, 28..40]);
        assert_eq!(by_particles.particles, vec![1200, 1200]);
        // A layer of 100 nodes weighs 50 particles: loads 70 and 150 a layer, 4400 in all.
        assert_eq!(NODE_COST, 0.5);
        assert_eq!(by_load.layers, vec![0..25, 25..40]);
        assert_eq!(by_load.particles, vec![900, 1500]);
        assert_eq!(
            by_load.loads,
            vec![(900 + 25 * 50) * 100, (1500 + 15 * 50) * 100]
        );
        assert!(by_load.imbalance() < 0.05);
        let loads_of = |slabs: &Slabs| -> Vec<u64> {
            let loads = layer_loads(&per_layer, 100);
            (slabs.layers.iter())
                .map(|r| loads[r.clone()].iter().sum())
                .collect()
        };
        assert!(loads_of(&by_load).iter().max() < loads_of(&by_particles).iter().max());
    }

    #[test]
    fn a_layers_load_counts_its_nodes_at_the_node_cost() {
        assert_eq!(layer_loads(&[0, 3], 0), vec![0, 300]);
        let nodes = (4.0 * NODE_COST * 100.0).round() as u64;
        assert_eq!(layer_loads(&[0, 3], 4), vec![nodes, 300 + nodes]);
    }

    #[test]
    fn more_ranks_than_particles_still_give_every_rank_a_layer() {
        let slabs = cut_slabs(0, &[0, 0, 5, 0, 0, 0], 0, 4).unwrap();
        assert_eq!(slabs.layers.len(), 4);
        assert_eq!(slabs.particles.iter().sum::<u64>(), 5);
        assert!(slabs.layers.iter().all(|r| !r.is_empty()));
        assert_eq!(slabs.imbalance(), 3.0);
    }

    #[test]
    fn fewer_layers_than_ranks_are_refused() {
        let error = cut_slabs(2, &[1, 2, 3], 0, 4).unwrap_err();
        assert!(error.contains("3 cell layers along the z axis, fewer than the 4 ranks"));
        assert!(cut_slabs(0, &[1], 0, 0).is_err());
    }

    #[test]
    fn the_longest_axis_is_the_first_of_the_longest() {
        assert_eq!(longest_axis(&[1.0, 3.0, 3.0]), 1);
        assert_eq!(longest_axis(&[2.0, 1.0]), 0);
    }

    /// The least largest part over every way to cut `per_layer` into `ranks` non-empty
    /// contiguous slabs, by trying them all.
    fn best_by_search(per_layer: &[u64], ranks: usize) -> u64 {
        fn search(per_layer: &[u64], ranks: usize) -> u64 {
            if ranks == 1 {
                return per_layer.iter().sum();
            }
            (1..=per_layer.len() - (ranks - 1))
                .map(|first| {
                    let head: u64 = per_layer[..first].iter().sum();
                    head.max(search(&per_layer[first..], ranks - 1))
                })
                .min()
                .unwrap()
        }
        search(per_layer, ranks)
    }

    proptest! {
        #[test]
        fn the_cut_is_the_best_contiguous_one(
            per_layer in proptest::collection::vec(0u64..50, 1..10),
            ranks in 1usize..5,
            nodes in 0u64..40,
        ) {
            prop_assume!(ranks <= per_layer.len());
            let slabs = cut_slabs(0, &per_layer, nodes, ranks).unwrap();
            prop_assert_eq!(slabs.layers.len(), ranks);
            prop_assert_eq!(slabs.layers[0].start, 0);
            prop_assert_eq!(slabs.layers[ranks - 1].end, per_layer.len());
            for pair in slabs.layers.windows(2) {
                prop_assert_eq!(pair[0].end, pair[1].start);
                prop_assert!(!pair[0].is_empty());
            }
            let largest = *slabs.loads.iter().max().unwrap();
            let loads = layer_loads(&per_layer, nodes);
            prop_assert_eq!(largest, best_by_search(&loads, ranks));
            prop_assert_eq!(slabs.particles.iter().sum::<u64>(), per_layer.iter().sum::<u64>());
        }
    }
}

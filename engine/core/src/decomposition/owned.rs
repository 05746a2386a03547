//! The rows this process counts, for systems: every row in one process, the rows this rank owns
//! in a distributed run. A system that sums over particles or nodes (a series column, an energy,
//! a count) takes [`OwnedRows`] as a system parameter, or [`Owned::in_world`] in an exclusive
//! system, and never names [`Ownership`] or asks whether the run is distributed:
//!
//! ```
//! use fractum_engine::decomposition::OwnedRows;
//! use fractum_engine::prelude::*;
//! use fractum_engine::testing::*;
//!
//! #[derive(Resource, Default)]
//! struct TotalMass(f64);
//!
//! fn total_mass(masses: Query<&Mass, With<Particle>>, owned: OwnedRows, mut total: ResMut<TotalMass>) {
//!     // Each particle counts on one rank; in one process, every particle counts.
//!     total.0 = owned.particles(masses.iter()).map(|m| m.0).sum();
//! }
//!
//! let mut world = tiny_world::<Two>(2, 0.5, 1e-3);
//! spawn_particle(&mut world, DVec2::new(0.3, 0.6), DVec2::ZERO, 2.0, 0.25);
//! spawn_particle(&mut world, DVec2::new(0.7, 0.6), DVec2::ZERO, 3.0, 0.25);
//! world.init_resource::<TotalMass>();
//! run_system(&mut world, total_mass);
//! assert_eq!(world.resource::<TotalMass>().0, 5.0);
//! ```
//!
//! Particle rows are the order a query visits particles in (storage order), node indices
//! [`NodeIndex`](crate::components::NodeIndex) values.

use super::Ownership;
use bevy_ecs::prelude::{Res, World};
use bevy_ecs::system::SystemParam;

/// Which particle rows and node indices count in this process's sums: a plain value to hand to
/// a kernel. [`Owned::everything`] in one process.
#[derive(Clone, Copy, Debug, Default)]
pub struct Owned<'a> {
    ownership: Option<&'a Ownership>,
}

impl<'a> Owned<'a> {
    /// What the world's process counts: the rank's own rows in a distributed run, every row
    /// otherwise.
    pub fn in_world(world: &'a World) -> Self {
        Self {
            ownership: world.get_resource::<Ownership>(),
        }
    }

    /// Every row: what one process counts.
    pub fn everything() -> Self {
        Self { ownership: None }
    }

    /// Whether particle row `row` counts here.
    pub fn particle(self, row: usize) -> bool {
        self.ownership.is_none_or(|o| o.owns_particle(row))
    }

    /// Whether the node of index `index` counts here.
    pub fn node(self, index: usize) -> bool {
        self.ownership
            .is_none_or(|o| o.nodes.get(index).copied().unwrap_or(false))
    }

    /// The per-node flags of a distributed run (`true`: owned here), or `None` when every node
    /// counts, for kernels that index them in a hot loop.
    pub fn node_flags(self) -> Option<&'a [bool]> {
        self.ownership.map(|o| o.nodes.as_slice())
    }

    /// The items of a particle query (or any sequence in particle row order) whose rows count
    /// here.
    pub fn particles<I: IntoIterator>(self, items: I) -> impl Iterator<Item = I::Item> {
        items
            .into_iter()
            .enumerate()
            .filter(move |(row, _)| self.particle(*row))
            .map(|(_, item)| item)
    }

    /// Whether the process is one rank of several.
    pub fn is_distributed(self) -> bool {
        self.ownership.is_some()
    }
}

/// [`Owned`] as a system parameter.
#[derive(SystemParam)]
pub struct OwnedRows<'w> {
    ownership: Option<Res<'w, Ownership>>,
}

impl OwnedRows<'_> {
    /// The rows this process counts, as a value to hand to a kernel.
    pub fn get(&self) -> Owned<'_> {
        Owned {
            ownership: self.ownership.as_deref(),
        }
    }

    /// Whether particle row `row` counts here.
    pub fn particle(&self, row: usize) -> bool {
        self.get().particle(row)
    }

    /// Whether the node of index `index` counts here.
    pub fn node(&self, index: usize) -> bool {
        self.get().node(index)
    }

    /// The items of a particle query whose rows count here ([`Owned::particles`]).
    pub fn particles<I: IntoIterator>(&self, items: I) -> impl Iterator<Item = I::Item> {
        self.get().particles(items)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decomposition::Layout;

    fn rank_one_of_two() -> Ownership {
        let layout = Layout {
            axis: 0,
            slabs: vec![0..2, 2..4],
            halo: 1,
        };
        let mut ownership = Ownership::new(layout, 1, 3, [0, 1, 2, 3, 4].into_iter());
        ownership.particles = vec![false, true, true];
        ownership
    }

    #[test]
    fn one_process_counts_every_row_and_a_rank_its_own() {
        let serial = Owned::everything();
        assert!(serial.particle(7) && serial.node(7) && serial.node_flags().is_none());
        assert_eq!(serial.particles(["a", "b"]).collect::<Vec<_>>(), ["a", "b"]);

        let ownership = rank_one_of_two();
        let rank = Owned {
            ownership: Some(&ownership),
        };
        assert!(!rank.particle(0) && rank.particle(1) && !rank.particle(3));
        assert_eq!(
            rank.particles(["a", "b", "c"]).collect::<Vec<_>>(),
            ["b", "c"]
        );
        // Nodes 2 to 4: the lower faces of layers 2 and 3, and the grid's last node layer.
        let nodes: Vec<bool> = (0..6).map(|n| rank.node(n)).collect();
        assert_eq!(nodes, [false, false, true, true, true, false]);
        assert!(rank.is_distributed());
    }

    #[test]
    fn the_system_parameter_reads_the_world_s_ownership() {
        let mut world = World::new();
        let mut serial = bevy_ecs::system::SystemState::<OwnedRows>::new(&mut world);
        assert!(serial.get(&world).unwrap().particle(5));
        world.insert_resource(rank_one_of_two());
        let mut rank = bevy_ecs::system::SystemState::<OwnedRows>::new(&mut world);
        let owned = rank.get(&world).unwrap();
        assert!(!owned.particle(0) && owned.particle(2) && owned.node(4));
        assert!(Owned::in_world(&world).is_distributed());
    }
}

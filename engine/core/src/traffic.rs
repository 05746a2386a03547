//! The bytes a step moves through memory, counted from the data each system reads and writes.
//!
//! Each system of the step schedule declares its access to the world (the components and
//! resources of its queries); the ECS records it when the schedule is built. For every
//! component a system reads, the count adds the component's size times the entities that
//! carry it; a component it writes counts twice (kernels update in place: read, then written
//! back). Resources count their own size, and the connectivity table and the neighbour lists,
//! which dominate, count their heap (rows, weights, gradients; list entries) for every system
//! that reads them.
//!
//! The count is a lower bound of the traffic: it takes a system's query as one pass over its
//! data (a kernel that walks the connectivity once per node and once per particle is counted
//! once), ignores caches (data reused from cache moves nothing, which makes the bound less
//! tight, not wrong), and cannot see inside the few systems that take the whole world
//! (listed as such). `fractum bench --profile` divides it by the particle count, and with the
//! rate and a measured memory bandwidth places each pipeline on the roofline.

use crate::connectivity::Connectivity;
use crate::dim::{Dim, Dimension};
use crate::neighbourhood::Neighbourhoods;
use crate::with_dim;
use bevy_ecs::component::ComponentId;
use bevy_ecs::query::ComponentAccessKind;
use bevy_ecs::schedule::Schedule;
use bevy_ecs::system::SystemAccess;
use bevy_ecs::world::World;

/// What one system moves in a step.
#[derive(Clone, Debug, PartialEq)]
pub struct SystemTraffic {
    /// The system's name, without its module path.
    pub name: String,
    /// Bytes read.
    pub read: f64,
    /// Bytes written.
    pub written: f64,
    /// Whether the system takes the whole world, so its access is unknown (counted as zero).
    pub exclusive: bool,
}

impl SystemTraffic {
    /// Bytes read and written.
    pub fn bytes(&self) -> f64 {
        self.read + self.written
    }
}

/// The traffic of every system of `schedule` on `world`, in the schedule's order; empty before
/// the schedule has been built.
pub fn schedule_traffic(schedule: &Schedule, world: &World) -> Vec<SystemTraffic> {
    let Ok(systems) = schedule.systems_with_access() else {
        return Vec::new();
    };
    let heap = resource_heap(world);
    systems
        .map(|(_, system)| {
            let name = short_name(&system.system().name().to_string());
            match system.access() {
                SystemAccess::Shared(access) => {
                    let (read, written) = access
                        .combined_access()
                        .try_iter_access()
                        .map(|kinds| {
                            kinds.fold((0.0, 0.0), |(r, w), kind| match kind {
                                ComponentAccessKind::Shared(id) => {
                                    (r + bytes_of(world, id, &heap), w)
                                }
                                ComponentAccessKind::Exclusive(id) => {
                                    let b = bytes_of(world, id, &heap);
                                    (r + b, w + b)
                                }
                                ComponentAccessKind::Archetypal(_) => (r, w),
                            })
                        })
                        .unwrap_or((0.0, 0.0));
                    SystemTraffic {
                        name,
                        read,
                        written,
                        exclusive: false,
                    }
                }
                SystemAccess::None => SystemTraffic {
                    name,
                    read: 0.0,
                    written: 0.0,
                    exclusive: false,
                },
                SystemAccess::Exclusive => SystemTraffic {
                    name,
                    read: 0.0,
                    written: 0.0,
                    exclusive: true,
                },
            }
        })
        .collect()
}

/// The heap bytes of the large resources the engine knows, by their id.
fn resource_heap(world: &World) -> Vec<(ComponentId, f64)> {
    let dimension = world.get_resource::<Dimension>().copied();
    let mut heap = Vec::new();
    if let Some(dimension) = dimension {
        with_dim!(dimension, D => connectivity_heap::<D>(world, &mut heap));
    }
    if let (Some(id), Some(lists)) = (
        world.component_id::<Neighbourhoods>(),
        world.get_resource::<Neighbourhoods>(),
    ) {
        heap.push((id, lists.heap_bytes()));
    }
    heap
}

fn connectivity_heap<D: Dim>(world: &World, heap: &mut Vec<(ComponentId, f64)>) {
    if let (Some(id), Some(c)) = (
        world.component_id::<Connectivity<D>>(),
        world.get_resource::<Connectivity<D>>(),
    ) {
        heap.push((id, c.heap_bytes()));
    }
}

/// The bytes of component (or resource) `id` in `world`: its size times the entities that
/// carry it, plus the heap the engine knows of.
fn bytes_of(world: &World, id: ComponentId, heap: &[(ComponentId, f64)]) -> f64 {
    let size = world
        .components()
        .get_info(id)
        .map_or(0, |info| info.layout().size()) as f64;
    let carriers: usize = world
        .archetypes()
        .iter()
        .filter(|archetype| archetype.contains(id))
        .map(|archetype| archetype.len() as usize)
        .sum();
    let extra = heap
        .iter()
        .find(|(known, _)| *known == id)
        .map_or(0.0, |(_, bytes)| *bytes);
    // A resource lives outside the archetypes: it counts once.
    size * carriers.max(1) as f64 + extra
}

/// `fractum_systems::basis::lme::lme_basis<D2>` → `lme_basis`.
fn short_name(full: &str) -> String {
    let without_generics = full.split('<').next().unwrap_or(full);
    without_generics
        .rsplit("::")
        .next()
        .unwrap_or(without_generics)
        .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_lose_their_path_and_generics() {
        assert_eq!(
            short_name("fractum_systems::basis::lme::lme_basis<D2>"),
            "lme_basis"
        );
        assert_eq!(short_name("stage_check"), "stage_check");
    }
}

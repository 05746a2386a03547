//! The memory a scene needs, estimated before anything large is allocated, against what the
//! machine has. A scene that cannot fit is refused as a scene error naming the estimate, its
//! largest part and the memory available, instead of aborting in an allocation later.
//!
//! The estimate is made from counts before any node or particle is spawned: the grid's nodes,
//! each body's seeded particles, and what the pipeline, installed first on a world with no
//! node and a sample of particles, gives each particle and node (its components) and declares
//! per particle (a basis its support, a neighbour search its lists) with
//! [`crate::registry::Installer::declare_particle_memory`]. It is held against what the process
//! may use ([`process_available`]): the machine's available memory, the process's own limits
//! and its memory cgroup's, whichever is least.

mod limits;

pub use limits::{Available, MemoryBound, cgroup_headroom, process_available};

use crate::components::{NodeBundle, ParticleBundle};
use crate::dim::Dim;
use bevy_ecs::prelude::Resource;

/// The working buffers of a step (systems' per-node and per-particle scratch, the kd-trees, the
/// frame being written, the allocator's slack) as a multiple of the declared storage. Measured
/// as peak resident memory over the declared estimate on shipped scenes (release, one thread,
/// 20 steps, entities spawned once with their components): Kalthoff–Winkler 123 MiB over
/// 53.1 MiB (2.3), the graded drop-weight beam 168 MiB over 95.2 MiB (1.8), the LME
/// edge-cracked panel 32 MiB over 14.4 MiB (2.2), the Brazilian disk (DFG) 44 MiB over
/// 15.6 MiB (2.8).
pub const WORKING_BUFFERS: f64 = 2.0;

/// Bytes the ECS keeps per entity besides its components (entity id, location, table row).
const ENTITY_OVERHEAD: f64 = 32.0;

/// The environment variable that overrides the memory available (bytes), e.g. to run a scene
/// meant for a larger machine through `fractum check` on a small one, or to test the refusal.
pub const MEMORY_LIMIT_VARIABLE: &str = "FRACTUM_MEMORY_LIMIT";

/// Per-particle storage declared by installed systems: the declaring entry's field path
/// (`pipeline[2]`), what, and bytes per particle.
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct ParticleMemory(pub Vec<(String, String, f64)>);

/// A count as a person reads it: whole below a million, else `1.2e9`.
pub fn describe_count(count: f64) -> String {
    if count < 1e6 {
        format!("{count:.0}")
    } else {
        format!("{count:.1e}")
    }
}

/// The estimate a built scene passed: bytes needed and bytes available (`fractum check`
/// prints it).
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct MemoryUse {
    /// Estimated bytes.
    pub needed: f64,
    /// What the process could use when the scene was built, and what bounded it.
    pub available: Available,
}

/// The parts of an estimate: what, and bytes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MemoryEstimate {
    /// Each part with its bytes.
    pub parts: Vec<(String, f64)>,
    /// Working buffers on top of the parts, as a multiple of their sum (0 before a pipeline
    /// is installed; [`WORKING_BUFFERS`] after).
    pub working: f64,
}

impl MemoryEstimate {
    /// Adds a part.
    pub fn add(&mut self, what: impl Into<String>, bytes: f64) {
        self.parts.push((what.into(), bytes));
    }

    /// Total bytes, working buffers included.
    pub fn total(&self) -> f64 {
        (1.0 + self.working) * self.parts.iter().map(|(_, b)| b).sum::<f64>()
    }

    /// `None` when the estimate fits in `available`, else the message refusing it.
    pub fn refusal(&self, available: Available) -> Option<String> {
        let total = self.total();
        if total.is_finite() && total <= available.bytes {
            return None;
        }
        let largest = self
            .parts
            .iter()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map_or(String::new(), |(what, bytes)| {
                format!("; its largest part is {what}: {}", describe_bytes(*bytes))
            });
        Some(format!(
            "the scene needs about {} of memory{largest}, and {} is available ({}); use fewer \
             particles or cells, or a smaller support (the estimate can be off by a factor of \
             two or more either way: {MEMORY_LIMIT_VARIABLE}=<bytes> sets the memory to check \
             against)",
            describe_bytes(total),
            describe_bytes(available.bytes),
            available.bound.describe()
        ))
    }
}

/// The bytes each node takes (its components and the ECS's own record).
pub fn node_bytes<D: Dim>() -> f64 {
    std::mem::size_of::<NodeBundle<D>>() as f64 + ENTITY_OVERHEAD
}

/// The bytes each particle takes before systems add their own components.
pub fn particle_bytes<D: Dim>() -> f64 {
    std::mem::size_of::<ParticleBundle<D>>() as f64 + ENTITY_OVERHEAD
}

/// The bytes of one particle–node entry of [`crate::connectivity::Connectivity`]: node index,
/// weight, gradient, field slot and its transposed record.
pub fn connectivity_entry_bytes<D: Dim>() -> f64 {
    (4 + 8 + 8 * D::N + 1 + 8) as f64
}

/// How many nodes of a uniform lattice lie within `radius` cells of a point, generously: the
/// volume of a ball half a cell wider (for a support estimate; on the mean, the ball's own
/// volume). Measured against the connectivity `basis/lme` builds (bytes a particle after three
/// steps, against the declared): 476 against 1 194 for the 3D drop weight, 940 against 1 521
/// for the graded 2D one, 338 against 655 for the edge-cracked panel.
pub fn cells_in_ball(dimensions: usize, radius: f64) -> f64 {
    ball_volume(dimensions, radius + 0.5)
}

/// The volume of a ball of `radius` cells, in cells: the mean number of particles within that
/// radius of a particle at one particle per cell (for a neighbour list's estimate; particles
/// near a body's edge have fewer).
pub fn ball_volume(dimensions: usize, radius: f64) -> f64 {
    match dimensions {
        2 => std::f64::consts::PI * radius * radius,
        _ => 4.0 / 3.0 * std::f64::consts::PI * radius * radius * radius,
    }
}

/// The mean particles per cell of a scene's seeds, for a world installed without particles
/// (the memory estimate's probe): [`particles_per_cell`] reads it there.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct SeedDensity(pub f64);

/// The mean number of particles per cell of the smallest width in `world` as built (total
/// particle volume against the count), for estimating neighbour lists; [`SeedDensity`] where
/// the world has it.
pub fn particles_per_cell<D: Dim>(world: &mut bevy_ecs::world::World) -> f64 {
    if let Some(density) = world.get_resource::<SeedDensity>() {
        return density.0;
    }
    use crate::components::{Particle, Volume};
    use bevy_ecs::query::With;
    let spacing = world.resource::<crate::resources::Grid<D>>().spacing;
    let thickness = if D::N == 2 {
        world
            .get_resource::<crate::resources::Thickness>()
            .map_or(1.0, |t| t.0)
    } else {
        1.0
    };
    let mut query = world.query_filtered::<&Volume, With<Particle>>();
    let (count, volume) = query
        .iter(world)
        .fold((0.0, 0.0), |(n, v), vol| (n + 1.0, v + vol.0));
    if count == 0.0 || volume <= 0.0 {
        return 0.0;
    }
    spacing.powi(D::N as i32) * thickness / (volume / count)
}

/// Memory the run may use: [`MEMORY_LIMIT_VARIABLE`] when set, else what the process may use
/// ([`process_available`]); infinite where nothing can be read, so nothing is refused on a
/// guess.
pub fn available_memory() -> Available {
    match std::env::var(MEMORY_LIMIT_VARIABLE)
        .ok()
        .and_then(|v| v.trim().parse::<f64>().ok())
    {
        Some(bytes) => Available {
            bytes,
            bound: MemoryBound::Variable,
        },
        None => process_available(),
    }
}

/// Bytes as a person reads them: `3.2 GiB`.
pub fn describe_bytes(bytes: f64) -> String {
    const UNITS: [&str; 6] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB"];
    if !bytes.is_finite() {
        return format!("{bytes} B");
    }
    let mut value = bytes;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit + 1 == UNITS.len() && value >= 1024.0 {
        return format!("{bytes:.3e} B");
    }
    format!("{value:.1} {}", UNITS[unit])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_estimate_above_the_available_memory_is_refused_naming_its_largest_part() {
        let mut estimate = MemoryEstimate::default();
        estimate.add("grid nodes", 3.0 * 1024.0 * 1024.0 * 1024.0);
        estimate.add("particles", 1024.0);
        let bytes = |bytes| Available {
            bytes,
            bound: MemoryBound::AddressSpace,
        };
        assert_eq!(
            estimate.refusal(bytes(4.0 * 1024.0 * 1024.0 * 1024.0)),
            None
        );
        let message = estimate.refusal(bytes(1024.0 * 1024.0 * 1024.0)).unwrap();
        assert!(message.contains("about 3.0 GiB"), "{message}");
        assert!(message.contains("grid nodes: 3.0 GiB"), "{message}");
        assert!(message.contains("1.0 GiB is available"), "{message}");
        assert!(
            message.contains("address-space limit (ulimit -v)"),
            "{message}"
        );
        estimate.add("overflow", f64::INFINITY);
        assert!(estimate.refusal(Available::UNKNOWN).is_some());
        assert_eq!(describe_bytes(1e30), "1.000e30 B");
    }
}

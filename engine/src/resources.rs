//! Resources shared by the whole step: clock, grid geometry, materials, body force.

use crate::dim::Vector;
use bevy_ecs::prelude::Resource;

/// Simulation clock. `step` counts completed steps; `dt` is the size of the step being taken.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct SimClock {
    /// Completed steps.
    pub step: u64,
    /// Simulated time at the start of the current step.
    pub time: f64,
    /// Size of the current step.
    pub dt: f64,
}

/// Uniform background grid over an axis-aligned box.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Lower corner.
    pub min: Vector,
    /// Node spacing `h`.
    pub spacing: f64,
    /// Number of cells along x and y.
    pub cells: [usize; 2],
}

impl Grid {
    /// Upper corner.
    pub fn max(&self) -> Vector {
        self.min + Vector::new(self.cells[0] as f64, self.cells[1] as f64) * self.spacing
    }

    /// Nodes along x and y.
    pub fn nodes_per_axis(&self) -> [usize; 2] {
        [self.cells[0] + 1, self.cells[1] + 1]
    }

    /// Total node count.
    pub fn node_count(&self) -> usize {
        let [nx, ny] = self.nodes_per_axis();
        nx * ny
    }

    /// Linear index of node (i, j).
    pub fn node_index(&self, i: usize, j: usize) -> usize {
        i + j * self.nodes_per_axis()[0]
    }

    /// Position of the node with linear index `index`.
    pub fn node_position(&self, index: usize) -> Vector {
        let nx = self.nodes_per_axis()[0];
        let (i, j) = (index % nx, index / nx);
        self.min + Vector::new(i as f64, j as f64) * self.spacing
    }

    /// Cell (i, j) containing `x`, or `None` when `x` lies outside the grid box.
    pub fn cell_of(&self, x: Vector) -> Option<[usize; 2]> {
        let local = (x - self.min) / self.spacing;
        if !(local.x >= 0.0 && local.y >= 0.0) {
            return None;
        }
        let (i, j) = (local.x.floor() as usize, local.y.floor() as usize);
        // A point exactly on the upper boundary belongs to the last cell.
        let i = if i == self.cells[0] && local.x == self.cells[0] as f64 {
            i - 1
        } else {
            i
        };
        let j = if j == self.cells[1] && local.y == self.cells[1] as f64 {
            j - 1
        } else {
            j
        };
        (i < self.cells[0] && j < self.cells[1]).then_some([i, j])
    }

    /// True when `x` lies inside the grid box (boundary included).
    pub fn contains(&self, x: Vector) -> bool {
        self.cell_of(x).is_some()
    }
}

/// Elastic properties of a named material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name used in the scene.
    pub name: String,
    /// Mass density ρ.
    pub density: f64,
    /// Young's modulus E.
    pub youngs_modulus: f64,
    /// Poisson's ratio ν.
    pub poisson_ratio: f64,
}

impl Material {
    /// Lamé constants (λ, μ).
    pub fn lame(&self) -> (f64, f64) {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let mu = e / (2.0 * (1.0 + nu));
        (lambda, mu)
    }

    /// Plane-strain dilatational (P-) wave speed `sqrt((λ + 2μ)/ρ)`, the fastest signal.
    pub fn wave_speed(&self) -> f64 {
        let (lambda, mu) = self.lame();
        ((lambda + 2.0 * mu) / self.density).sqrt()
    }
}

/// The scene's materials, indexed by [`crate::components::MaterialId`].
#[derive(Resource, Clone, Debug, Default)]
pub struct Materials(pub Vec<Material>);

impl Materials {
    /// Largest wave speed over all materials.
    pub fn max_wave_speed(&self) -> f64 {
        self.0.iter().map(Material::wave_speed).fold(0.0, f64::max)
    }
}

/// How much of the central-difference stable time step the installed systems allow.
///
/// The engine's limit is `h / (√d (c + |v|))`: the central-difference limit of a lumped-mass
/// bilinear grid in `d` dimensions. An integrator with a smaller stability region lowers
/// `factor` at install (through [`crate::registry::Installer::restrict_time_step`]) and says why.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct TimeStepLimit {
    /// Fraction of the central-difference limit, in (0, 1].
    pub factor: f64,
    /// Which system set it and why (empty when nothing restricts it).
    pub reason: String,
}

impl Default for TimeStepLimit {
    fn default() -> Self {
        Self {
            factor: 1.0,
            reason: String::new(),
        }
    }
}

impl TimeStepLimit {
    /// The stable step for spacing `h` and fastest signal speed `speed` (wave plus material).
    pub fn stable_step(&self, h: f64, speed: f64) -> f64 {
        if speed > 0.0 {
            self.factor * h / ((crate::dim::DIM as f64).sqrt() * speed)
        } else {
            f64::INFINITY
        }
    }
}

/// Uniform body force per unit mass (an acceleration, e.g. gravity).
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct BodyForce(pub Vector);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_indexing_round_trips() {
        let grid = Grid {
            min: Vector::new(-1.0, 0.0),
            spacing: 0.5,
            cells: [4, 2],
        };
        assert_eq!(grid.node_count(), 15);
        assert_eq!(grid.max(), Vector::new(1.0, 1.0));
        assert_eq!(
            grid.node_position(grid.node_index(2, 1)),
            Vector::new(0.0, 0.5)
        );
        assert_eq!(grid.cell_of(Vector::new(1.0, 1.0)), Some([3, 1]));
        assert_eq!(grid.cell_of(Vector::new(-0.99, 0.01)), Some([0, 0]));
        assert_eq!(grid.cell_of(Vector::new(1.01, 0.5)), None);
        assert_eq!(grid.cell_of(Vector::new(0.0, f64::NAN)), None);
    }

    #[test]
    fn wave_speed_reduces_to_bar_speed_without_poisson_effect() {
        let m = Material {
            name: "bar".into(),
            density: 1.0,
            youngs_modulus: 100.0,
            poisson_ratio: 0.0,
        };
        assert!((m.wave_speed() - 10.0).abs() < 1e-12);
    }
}

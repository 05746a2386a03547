"""The benchmark block of `fractum bench` (tools/src/bench.rs, `bench_spec`), as plain numbers
for the peers' kernels: an elastic square (2D) or cube (3D) of E = 1 MPa, ν = 0.3, ρ = 1000
kg/m³, 2 particles per cell per direction at the quarter points of cells of h = 0.01 m, a
margin of four cells on a grid of `cells + 8` cells per axis, and the initial velocity
`v_a = A_a sin(2π (x_0 − margin) / 2 side)` with A = (0.1, 0.05, 0.025) m/s.

Standard library and numpy only: every peer script imports it."""

import math

import numpy as np

SPACING = 0.01
DENSITY = 1000.0
YOUNGS_MODULUS = 1.0e6
POISSON_RATIO = 0.3
MARGIN_CELLS = 4
AMPLITUDES = (0.1, 0.05, 0.025)


class Block:
    """The block with about `particles` particles in `dimension` dimensions."""

    def __init__(self, particles, dimension):
        per_cell = 2**dimension
        self.dimension = dimension
        self.cells = max(1, round((particles / per_cell) ** (1.0 / dimension)))
        self.grid_cells = self.cells + 2 * MARGIN_CELLS
        self.margin = MARGIN_CELLS * SPACING
        self.side = self.cells * SPACING
        self.particle_volume = (SPACING / 2) ** dimension
        self.particle_mass = DENSITY * self.particle_volume
        nu, e = POISSON_RATIO, YOUNGS_MODULUS
        self.mu = e / (2 * (1 + nu))
        self.lam = e * nu / ((1 + nu) * (1 - 2 * nu))

    @property
    def count(self):
        return (2 * self.cells) ** self.dimension

    def positions(self):
        """(n, d) particle positions, x fastest."""
        line = self.margin + (np.arange(2 * self.cells) + 0.5) * SPACING / 2
        axes = np.meshgrid(*([line] * self.dimension), indexing="ij")
        return np.stack([a.ravel(order="F") for a in axes], axis=1)

    def velocities(self, positions):
        """(n, d) initial velocities: the half sine along x, one amplitude per axis."""
        phase = np.sin(2 * math.pi * (positions[:, 0] - self.margin) / (2 * self.side))
        return np.stack([AMPLITUDES[a] * phase for a in range(self.dimension)], axis=1)

    def wave_speed(self):
        """The P-wave speed, sqrt((λ + 2μ) / ρ) (m/s)."""
        return math.sqrt((self.lam + 2 * self.mu) / DENSITY)

    def time_step(self):
        """The step `Cfl(0.5)` gives at the start: `0.5 h / (√d (c + |v|max))`."""
        fastest = math.sqrt(sum(a * a for a in AMPLITUDES[: self.dimension]))
        return 0.5 * SPACING / (math.sqrt(self.dimension) * (self.wave_speed() + fastest))


def summary(positions, velocities, mass):
    """What the peers compare: the mean position and the kinetic energy."""
    return {
        "mean_position": [float(v) for v in positions.mean(axis=0)],
        "kinetic_energy": float(0.5 * mass * (velocities**2).sum()),
    }

"""Stepping a scene from Python: ``Simulation(scene).step(100)``, its particles and nodes as
numpy arrays, and the columns a study sets before the first step."""

import numpy as np

from . import _native
from ._run import _as_scene


def _read_only(arrays):
    for value in arrays.values():
        if isinstance(value, np.ndarray):
            value.flags.writeable = False
    return arrays


class Columns:
    """Particle columns by name: each a read-only numpy snapshot of the state now.
    ``sim.particles["velocity"] = array`` sets a column before the first step (``velocity``,
    ``damage``, ``strength_scale``: the damage law's strength times the scale, checked as the
    law checks the scene's)."""

    def __init__(self, simulation, read):
        self._simulation = simulation
        self._read = read

    def _arrays(self):
        return self._simulation._snapshot(self._read)

    def keys(self):
        """The columns' names."""
        return list(self._arrays().keys())

    def __iter__(self):
        return iter(self.keys())

    def __contains__(self, name):
        return name in self._arrays()

    def __getitem__(self, name):
        arrays = self._arrays()
        if name not in arrays:
            raise KeyError(f"no column {name!r}; there are {sorted(arrays)}")
        return arrays[name]

    def __setitem__(self, name, values):
        if self._read != "particles":
            raise TypeError("node columns are the step's own; only particle columns can be set")
        values = np.ascontiguousarray(values, dtype=np.float64)
        if values.ndim == 1:
            self._simulation._native.set_scalar(name, values)
        elif values.ndim == 2:
            self._simulation._native.set_vector(name, values)
        else:
            raise ValueError(f"`{name}` takes a 1D or 2D array; got {values.ndim} dimensions")
        self._simulation._cache = None

    def __repr__(self):
        return f"<{self._read}: {', '.join(self.keys())}>"


class Simulation:
    """A scene built in memory and stepped from Python (nothing is written to disk).

    ``step(n)`` takes up to ``n`` steps with the GIL released; ``time``, ``steps``,
    ``finished``; ``particles[...]`` and ``nodes[...]`` are read-only numpy snapshots;
    ``energy()`` gives the energy columns of series.csv as they are now."""

    def __init__(self, scene, threads=None):
        scene = _as_scene(scene)
        self.scene = scene
        self._native = _native.Simulation(scene.name, scene.text, threads)
        self._cache = None

    def step(self, steps=1):
        """Takes up to ``steps`` steps (fewer at the scene's end); returns how many it took.
        A blow-up raises ``fractum.RunError``."""
        if int(steps) < 0:
            raise ValueError("steps cannot be negative")
        self._cache = None
        return self._native.step(int(steps))

    @property
    def time(self):
        """Simulated time (s)."""
        return self._native.time

    @property
    def steps(self):
        """Steps taken."""
        return self._native.steps

    @property
    def finished(self):
        """Whether the scene's end is reached."""
        return self._native.finished

    @property
    def dimension(self):
        """2 or 3."""
        return self._native.dimension

    def time_step(self):
        """The step the next ``step`` takes (s)."""
        return self._native.time_step()

    @property
    def particles(self):
        """The particles' columns."""
        return Columns(self, "particles")

    @property
    def nodes(self):
        """The grid nodes that carry mass: index, position, fields, and per field slot key,
        mass, velocity and normal."""
        return Columns(self, "nodes")

    def _snapshot(self, read):
        key = (read, self._native.steps)
        if self._cache is None or self._cache[0] != key:
            self._cache = (key, _read_only(getattr(self._native, read)()))
        return self._cache[1]

    def series(self):
        """The row series.csv would hold now, as a dict."""
        return self._native.series()

    def energy(self):
        """The energy columns of ``series()``: kinetic, strain, total, dissipated energy and
        the work of the loads, where the scene has them (J; per thickness in 2D)."""
        return {k: v for k, v in self.series().items() if "energy" in k or "work" in k}

    def __repr__(self):
        return f"<fractum.Simulation {self.scene.name}: step {self.steps}, t = {self.time:.4e} s>"

"""Fractum from Python: dynamic fracture and frictional contact with the Material Point Method.

    import fractum
    scene = fractum.Scene.load("scenes/charpy_dfg.ron")
    scene.system("damage/rankine").params["tensile_strength"] = 8e8
    run = fractum.run(scene, out="out/charpy", threads=2)
    run.series["dissipated_energy"][-1]

docs/guide/python.md is the guide. The engine is Rust; this package drives it: scenes
(``Scene``), runs into a folder (``run``, ``open``, ``resume``, ``Run``), stepping in memory
(``Simulation``), and the analysis tools (``curve``, ``crack``, ``fragments``, ``snapshot``,
``systems``)."""

from ._native import RunError, SceneError
from ._ron import Ron
from ._scene import Scene
from ._run import Run, open, resume, run  # noqa: A004 - `fractum.open` opens a run
from ._simulation import Simulation
from ._analysis import crack, curve, fragments, snapshot, systems

__all__ = [
    "Ron", "Run", "RunError", "Scene", "SceneError", "Simulation",
    "crack", "curve", "fragments", "open", "resume", "run", "snapshot", "systems",
]

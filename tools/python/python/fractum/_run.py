"""Runs: a scene run to its end into an output folder (the files ``fractum run`` writes), and
what a finished, stopped or checkpointed run left there, as numpy arrays."""

import csv
import sys
import time as _time
from pathlib import Path

import numpy as np

from . import _native
from ._scene import Scene, _atomic_write


def _as_scene(scene):
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, (str, Path)):
        return Scene.load(scene)
    raise TypeError(f"expected a fractum.Scene or a scene file's path, not {type(scene).__name__}")


class _TextProgress:
    """A one-line progress report on stderr, where tqdm is not installed."""

    def __init__(self, label):
        self.label = label
        self.last = 0.0

    def __call__(self, step, time, fraction):
        now = _time.monotonic()
        if now - self.last < 1.0 and fraction < 1.0:
            return
        self.last = now
        sys.stderr.write(f"\r{self.label}: {100 * fraction:5.1f}%  step {step}  t = {time:.4e} s")
        sys.stderr.flush()

    def close(self):
        sys.stderr.write("\n")


class _TqdmProgress:
    def __init__(self, label):
        from tqdm.auto import tqdm

        self.bar = tqdm(total=1.0, desc=label, unit="run", bar_format="{l_bar}{bar}| {postfix} [{elapsed}<{remaining}]")

    def __call__(self, step, time, fraction):
        self.bar.n = round(fraction, 4)
        self.bar.set_postfix_str(f"step {step}, t = {time:.4e} s", refresh=False)
        self.bar.refresh()

    def close(self):
        self.bar.close()


def _progress(progress, label):
    """A callback and its closer for ``progress``: True (tqdm where installed, else a line on
    stderr), False or None (nothing), or a callable ``f(step, time, fraction)``."""
    if progress is True:
        try:
            bar = _TqdmProgress(label)
        except ImportError:
            bar = _TextProgress(label)
        return bar, bar.close
    if progress in (False, None):
        return None, lambda: None
    if callable(progress):
        return progress, lambda: None
    raise TypeError("progress is True, False, or a callable f(step, time, fraction)")


def _checkpoint_text(every):
    if every is None or isinstance(every, str):
        return every
    if isinstance(every, int):
        return str(every)
    raise TypeError("checkpoint_every is a number of steps (1000) or a time as text ('2.5e-5s')")


def run(scene, out=None, threads=None, steps=None, force=False, progress=True,
        checkpoint_every=None, keep_checkpoints=3):
    """Runs ``scene`` (a Scene, or a scene file's path) into the folder ``out`` (default
    ``out/<scene file's stem>``) as ``fractum run`` does, and returns the ``Run``.

    ``threads``: threads for the step (default: all cores); ``steps``: stop at this step;
    ``force``: replace a previous run in ``out``; ``checkpoint_every``: steps (``1000``) or
    simulated time (``"2.5e-5s"``). The GIL is released while the run steps. Ctrl-C lets the
    current step finish, writes the outputs and a checkpoint, and raises ``KeyboardInterrupt``
    (``fractum.resume(out)`` continues the run)."""
    scene = _as_scene(scene)
    if out is None:
        stem = scene.path.stem if scene.path is not None else "run"
        out = Path("out") / stem
    out = Path(out)
    callback, close = _progress(progress, scene.path.stem if scene.path else "run")
    try:
        summary = _native.run(
            scene.name, scene.text, scene.record_path(), str(out), force, threads, steps,
            _checkpoint_text(checkpoint_every), keep_checkpoints, callback,
        )
    finally:
        close()
    # The scene this run ran, as it was edited: beside its outputs.
    _atomic_write(out / "scene.ron", scene.text)
    return Run(out, summary)


def resume(out, threads=None, steps=None, progress=True, checkpoint_every=None, keep_checkpoints=3):
    """Continues the run in ``out`` from its newest checkpoint, as ``fractum resume`` does
    (the scene is the checkpoint's copy); returns the ``Run``."""
    out = Path(out)
    callback, close = _progress(progress, out.name)
    try:
        summary = _native.resume(
            str(out), threads, steps, _checkpoint_text(checkpoint_every), keep_checkpoints, callback,
        )
    finally:
        close()
    return Run(out, summary)


def open(out):  # noqa: A001 - the package's verb, as in `fractum.open(...)`
    """The run in the folder ``out``, finished, stopped or checkpointed."""
    out = Path(out)
    if not (out / "series.csv").exists() and not (out / "particles.pvd").exists():
        raise FileNotFoundError(
            f"{out} holds no run (no series.csv or particles.pvd); run a scene there first"
        )
    return Run(out, None)


def read_series(path):
    """A series.csv as a dict of numpy arrays by column (``step`` as integers)."""
    with builtins_open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise ValueError(f"{path} is empty")
    header, body = rows[0], rows[1:]
    columns = {}
    for i, name in enumerate(header):
        values = [row[i] for row in body]
        dtype = np.int64 if name == "step" else np.float64
        columns[name] = np.array(values, dtype=dtype)
    return columns


def builtins_open(*args, **kwargs):
    """The built-in ``open`` (this module defines its own)."""
    import builtins

    return builtins.open(*args, **kwargs)


class Run:
    """The outputs of a run in its folder: the series, the frames, the summary."""

    def __init__(self, out, summary):
        self.out = Path(out)
        self._summary = summary

    def __repr__(self):
        return f"<fractum.Run {self.out}>"

    @property
    def summary(self):
        """What the run did: steps, time, particles, threads, wall_s, particle_steps_per_s,
        frames, checkpoint and exit (``end``, ``steps`` or ``interrupted``). For an opened
        run, what its files tell: steps and time of the last series row."""
        if self._summary is not None:
            return dict(self._summary)
        series = self.series
        return {
            "steps": int(series["step"][-1]) if len(series["step"]) else 0,
            "time": float(series["time"][-1]) if len(series["time"]) else 0.0,
            "frames": len(self.frames),
            "checkpoint": str(self.checkpoints[-1]) if self.checkpoints else None,
        }

    @property
    def series(self):
        """series.csv as a dict of numpy arrays by column."""
        return read_series(self.out / "series.csv")

    def series_frame(self):
        """series.csv as a pandas DataFrame (pandas must be installed)."""
        try:
            import pandas
        except ImportError as e:
            raise ImportError("series_frame() needs pandas: pip install pandas") from e
        return pandas.DataFrame(self.series)

    @property
    def frames(self):
        """The particle frames: a list of ``(time, path)``."""
        return self._collection("particles.pvd")

    @property
    def grid_frames(self):
        """The grid frames: a list of ``(time, path)``."""
        return self._collection("grid.pvd")

    def _collection(self, name):
        path = self.out / name
        if not path.exists():
            return []
        return [(t, self.out / file) for t, file in _native.read_collection(str(path))]

    @property
    def checkpoints(self):
        """The checkpoint files, oldest first."""
        folder = self.out / "checkpoints"
        return sorted(folder.glob("checkpoint_*.bin")) if folder.exists() else []

    def frame(self, index=-1, time=None):
        """Particle frame ``index`` (or the one nearest ``time``): a dict of numpy arrays,
        vectors ``(n, d)``, stresses ``(n, 3, 3)``, scalars ``(n,)``."""
        frames = self.frames
        if not frames:
            raise FileNotFoundError(f"{self.out} has no particle frames (output.vtu_every is 0)")
        if time is not None:
            index = min(range(len(frames)), key=lambda i: abs(frames[i][0] - time))
        t, path = frames[index]
        data = _native.read_frame(str(path))
        data["time"] = t
        return data

    @property
    def scene(self):
        """The scene this run ran (scene.ron, written beside the outputs by ``fractum.run``)."""
        return Scene.load(self.out / "scene.ron")

"""The command line's analysis tools as functions returning data (the same code, the same
numbers), each drawing into a matplotlib ``ax`` when given one."""

from pathlib import Path

import numpy as np

from . import _native
from ._run import Run


def _folder(run):
    if isinstance(run, Run):
        return run.out
    if isinstance(run, (str, Path)):
        return Path(run)
    raise TypeError(f"expected a fractum.Run or a run's folder, not {type(run).__name__}")


def _series_file(series):
    path = _folder(series)
    return path / "series.csv" if path.is_dir() else path


def curve(series, x, y, start=0.0):
    """The peak of column ``y`` against ``x`` of a run's series (a Run, its folder, or a
    series.csv) and the RMS deviation of its rise from a straight line (points with ``x`` from
    ``start``), as ``fractum curve`` reports them: peak, x_at_peak, slope, rms_deviation, and
    fall (how far ``x`` runs past the peak before ``y`` falls below 5% of it; None when it never
    does)."""
    return _native.curve(str(_series_file(series)), x, y, float(start))


def crack(run, notch, direction=(1.0, 0.0), damage_above=0.5, link=None, angle_length=None, ax=None):
    """The crack that grows from the notch tip ``notch`` through a run's frames, as ``fractum
    crack`` traces it: arrays ``time``, ``tip`` (n, 3) and ``length``, the ``initial_angle``
    (degrees from ``direction``) and the mean and largest ``speed`` (m/s). With ``ax``, draws
    the length against time."""
    result = _native.crack_path(
        str(_folder(run)), [float(v) for v in notch], [float(v) for v in direction],
        float(damage_above), link, angle_length,
    )
    if ax is not None:
        ax.plot(result["time"] * 1e6, result["length"] * 1e3, marker=".")
        ax.set_xlabel("time (µs)")
        ax.set_ylabel("crack length (mm)")
    return result


def fragments(run, time=None, damage_below=0.5, link=None, thickness=None, bodies=(), ax=None):
    """The fragments of a run's frame nearest ``time`` (the last by default), as ``fractum
    fragments`` finds them: per fragment (largest first) ``particles``, ``mass``, ``volume``,
    ``diameter``, ``centroid`` and ``velocity``. With ``ax``, draws the cumulative mass
    fraction against the equivalent diameter."""
    result = _native.fragments_of(
        str(_folder(run)), time, float(damage_below), link, thickness, [int(b) for b in bodies],
    )
    if ax is not None:
        order = np.argsort(result["diameter"])
        mass = result["mass"][order]
        cumulative = np.cumsum(mass) / mass.sum() if mass.size else mass
        ax.step(result["diameter"][order] * 1e3, cumulative, where="post",
                label=f"{_folder(run).name}, t = {result['time'] * 1e6:.1f} µs")
        ax.set_xscale("log")
        ax.set_xlabel("equivalent diameter (mm)")
        ax.set_ylabel("cumulative mass fraction")
        ax.legend(loc="best")
    return result


def snapshot(run, field="damage", index=-1, time=None, output=None, view="xy", width=900,
             range=None, array=False):  # noqa: A002 - the command line's option name
    """A PNG of a particle frame coloured by ``field``, as ``fractum snapshot`` draws it: the
    frame ``index`` of a run (or the one nearest ``time``), or a frame file. Returns the PNG's
    path, or with ``array=True`` its pixels as an (h, w, 3 or 4) array (matplotlib reads it)."""
    if isinstance(run, (str, Path)) and str(run).endswith((".vtu", ".pvtu")):
        frame = Path(run)
    else:
        frames = Run(_folder(run), None).frames
        if not frames:
            raise FileNotFoundError(f"{_folder(run)} has no particle frames")
        if time is not None:
            index = min(builtins_range(len(frames)), key=lambda i: abs(frames[i][0] - time))
        frame = frames[index][1]
    if output is None:
        output = frame.with_name(f"{frame.stem}_{field}.png")
    path = _native.snapshot_png(str(frame), str(output), field, view, int(width),
                                None if range is None else (float(range[0]), float(range[1])))
    if not array:
        return path
    try:
        import matplotlib.image
    except ImportError as e:
        raise ImportError("snapshot(array=True) reads the PNG with matplotlib") from e
    return matplotlib.image.imread(path)


def builtins_range(n):
    """The built-in ``range`` (``snapshot`` has an argument of that name)."""
    import builtins

    return builtins.range(n)


def systems():
    """Every registered system: name, stage, summary, params (name, type, default, doc) and
    requires."""
    return _native.systems()

"""Scenes as objects: read and change what a study varies, the RON text kept as its author
wrote it (comments, layout, the other values), so a scene's errors keep pointing at lines the
author knows."""

import difflib
import functools
import os
from pathlib import Path

from . import _native
from ._ron import Ron, from_ron, to_ron


@functools.lru_cache(maxsize=1)
def _registered_systems():
    """The registered systems with their documented parameters (the registry is fixed)."""
    return tuple(_native.systems())


def _atomic_write(path, text):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    temporary.write_text(text, encoding="utf-8")
    os.replace(temporary, path)


class Scene:
    """A scene: its RON text, and where it came from (geometry files resolve beside it).

    ``scene["grid.spacing"]`` reads and ``scene["grid.spacing"] = 0.5e-3`` sets the value at
    a field path, the path `fractum check` names in its errors; ``scene.grid``,
    ``scene.materials``, ``scene.output``, ``scene.time`` and ``scene.system(name).params``
    are views that do the same by attribute or key. A value keeps its kind (a number stays a
    number), and an edit that makes the text no scene raises ``SceneError`` and changes
    nothing. ``check()`` builds the scene as ``fractum check`` does."""

    def __init__(self, text, path=None, name=None):
        if not isinstance(text, str):
            raise TypeError(f"a scene's text is a str, not {type(text).__name__}")
        self._path = None if path is None else Path(path)
        self._name = name or (str(path) if path is not None else "<scene from Python>")
        self._original = text if path is not None else None
        _native.scene_parse(self._name, text)
        self._text = text

    @classmethod
    def load(cls, path):
        """Reads the scene file at ``path``."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as e:
            raise FileNotFoundError(f"cannot read the scene file {path}: {e.strerror}") from e
        except UnicodeDecodeError as e:
            raise _native.SceneError(
                f"{path}: the scene file is not UTF-8 text (byte {e.start}); save it as UTF-8"
            ) from e
        return cls(text.removeprefix("\ufeff"), path=path)

    @classmethod
    def from_str(cls, text, name="<scene from Python>", base=None):
        """A scene from its RON text; ``base``: the folder its geometry files are relative to
        (the current folder by default)."""
        path = None if base is None else Path(base) / "scene.ron"
        scene = cls(text, path=path, name=name)
        scene._original = None
        return scene

    # -- text -------------------------------------------------------------------------

    @property
    def text(self):
        """The scene's RON text, as edited."""
        return self._text

    @property
    def name(self):
        """The name messages give the scene: its file's path, marked ``(edited)`` once the
        text differs from the file (the lines and columns are the edited text's; an edit
        within a line keeps the file's line numbers)."""
        if self._path is not None and self.edited:
            return f"{self._name} (edited)"
        return self._name

    @property
    def path(self):
        """The file the scene was read from, or None."""
        return self._path

    @property
    def edited(self):
        """Whether the text differs from the file it was read from (a scene from a string
        counts as edited)."""
        return self._original is None or self._text != self._original

    def save(self, path):
        """Writes the scene's text to ``path`` (atomically: no half-written file)."""
        _atomic_write(path, self._text)

    def copy(self):
        """An independent copy."""
        twin = Scene.__new__(Scene)
        twin.__dict__.update(self.__dict__)
        return twin

    def __reduce__(self):
        return (_restore, (self._text, self._path, self._name, self._original))

    def __eq__(self, other):
        return isinstance(other, Scene) and (self._text, self._path) == (other._text, other._path)

    def __repr__(self):
        title = self.get("title", "")
        return f"<fractum.Scene {self._name}{' - ' + title if title else ''}>"

    # -- values by path -----------------------------------------------------------------

    def raw(self, path):
        """The RON text of the value at ``path``, or None."""
        return _native.scene_value(self._text, path)

    def keys(self, path=""):
        """The names directly inside the value at ``path``."""
        return _native.scene_children(self._text, path)

    def get(self, path, default=None):
        """The value at ``path`` (see ``__getitem__``), or ``default`` where there is none."""
        raw = self.raw(path)
        return default if raw is None else self._value(path, raw)

    def __getitem__(self, path):
        raw = self.raw(path)
        if raw is None:
            raise KeyError(f"the scene has no value at `{path}`")
        return self._value(path, raw)

    def __setitem__(self, path, value):
        old = self.raw(path)
        text = to_ron(value, old, where=f"`{path}`")
        self._text = _native.scene_set(self.name, self._text, path, text)

    def _value(self, path, raw):
        value = from_ron(raw)
        return View(self, path) if value is None else value

    # -- views ----------------------------------------------------------------------------

    @property
    def grid(self):
        """The grid: ``scene.grid.spacing = 0.5e-3``."""
        return View(self, "grid")

    @property
    def time(self):
        """Time stepping: ``scene.time.step``, ``scene.end_time``."""
        return View(self, "time")

    @property
    def output(self):
        """Output settings (fields absent from the file are added when set)."""
        return View(self, "output")

    @property
    def materials(self):
        """Materials by name: ``scene.materials["steel"].youngs_modulus = 2.1e11``."""
        return Materials(self)

    @property
    def title(self):
        """The scene's title."""
        return self.get("title", "")

    @title.setter
    def title(self, value):
        self["title"] = value

    @property
    def end_time(self):
        """The simulated time the run ends at (s), or None where it ends after a number of
        steps."""
        end = self.raw("time.end") or ""
        return self["time.end.0"] if end.startswith("Time") else None

    @end_time.setter
    def end_time(self, seconds):
        self["time.end"] = Ron(f"Time({to_ron(float(seconds), where='end_time')})")

    @property
    def end_steps(self):
        """The number of steps the run ends after, or None where it ends at a time."""
        end = self.raw("time.end") or ""
        return self["time.end.0"] if end.startswith("Steps") else None

    @end_steps.setter
    def end_steps(self, steps):
        self["time.end"] = Ron(f"Steps({int(steps)})")

    def pipeline(self):
        """The names of the pipeline's systems, in the scene's order."""
        return [self[f"pipeline{item}.system"] for item in self.keys("pipeline")]

    def system(self, name, index=0):
        """The pipeline entry of the system ``name`` (the ``index``-th where the pipeline
        names it more than once)."""
        items = [item for item in self.keys("pipeline") if self.get(f"pipeline{item}.system") == name]
        if not items:
            known = [s["name"] for s in _registered_systems()]
            close = difflib.get_close_matches(name, self.pipeline() + known, n=3)
            hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
            raise KeyError(f"the pipeline has no system {name!r} (it has {self.pipeline()}){hint}")
        if index >= len(items):
            raise KeyError(f"the pipeline names {name!r} {len(items)} time(s); no index {index}")
        return System(self, f"pipeline{items[index]}", name)

    def check(self):
        """Builds the scene as ``fractum check`` does; its report as a dict (``str()`` of it
        is the text the command prints). Raises ``SceneError`` with the file, line, column and
        field where the scene is refused."""
        return Check(_native.check(self.name, self._text))

    def record_path(self):
        """The path a run's checkpoints record for this scene: its file where unedited, else
        a name beside it that is no file (a resume then uses the checkpoint's copy of the
        text, and geometry files still resolve beside the original)."""
        if self._path is None:
            base = Path.cwd() / "scene-from-python.ron"
        elif self.edited:
            base = self._path.with_name(f"{self._path.stem}.edited-in-python.ron")
        else:
            base = self._path
        return str(base.absolute())


def _restore(text, path, name, original):
    scene = Scene(text, path=path, name=name)
    scene._original = original
    return scene


class View:
    """The value at a path of a scene, read and changed by attribute or key:
    ``view.spacing``, ``view["spacing"]``, ``view.spacing = 1e-3``."""

    def __init__(self, scene, path):
        object.__setattr__(self, "_scene", scene)
        object.__setattr__(self, "_path", path)

    def _child(self, key):
        if isinstance(key, int):
            return f"{self._path}[{key}]"
        return f"{self._path}.{key}" if self._path else key

    def __getitem__(self, key):
        return self._scene[self._child(key)]

    def __setitem__(self, key, value):
        self._scene[self._child(key)] = value

    def __getattr__(self, key):
        if key.startswith("_"):
            raise AttributeError(key)
        try:
            return self[key]
        except KeyError as e:
            raise AttributeError(str(e)) from None

    def __setattr__(self, key, value):
        self[key] = value

    def __contains__(self, key):
        return self._scene.raw(self._child(key)) is not None

    def keys(self):
        """The names inside this value."""
        return self._scene.keys(self._path)

    def get(self, key, default=None):
        """The value at ``key``, or ``default``."""
        return self._scene.get(self._child(key), default)

    @property
    def ron(self):
        """This value's RON text."""
        return self._scene.raw(self._path)

    def __repr__(self):
        return f"<{self._path}: {self.ron}>"


class Materials:
    """The scene's materials by name."""

    def __init__(self, scene):
        self._scene = scene

    def keys(self):
        """The materials' names."""
        return self._scene.keys("materials")

    def __iter__(self):
        return iter(self.keys())

    def __len__(self):
        return len(self.keys())

    def __contains__(self, name):
        return name in self.keys()

    def __getitem__(self, name):
        if name not in self.keys():
            close = difflib.get_close_matches(str(name), self.keys(), n=2)
            hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
            raise KeyError(f"no material {name!r} (the scene has {self.keys()}){hint}")
        return View(self._scene, f"materials.{name}")

    def __setitem__(self, name, fields):
        """Adds or replaces a material: a dict of ``density``, ``youngs_modulus``,
        ``poisson_ratio``."""
        if not isinstance(fields, dict):
            raise TypeError("a material is a dict of its fields, e.g. dict(density=7800.0, ...)")
        self._scene[f"materials.{name}"] = Ron(to_ron(fields, where=f"materials.{name}"))

    def __repr__(self):
        return f"<materials {self.keys()}>"


class System:
    """A pipeline entry: its system's ``name`` and its ``params`` (a parameter absent from
    the file is added when set, after checking the system has it)."""

    def __init__(self, scene, path, name):
        self._scene = scene
        self.path = path
        self.name = name

    @property
    def params(self):
        """The entry's parameters."""
        return Params(self._scene, f"{self.path}.params", self.name)

    def __repr__(self):
        return f"<{self.path}: {self.name}, params {self._scene.raw(self.path + '.params') or '()'}>"


class Params(View):
    """A system's parameters: names checked against what the system documents."""

    def __init__(self, scene, path, system):
        super().__init__(scene, path)
        object.__setattr__(self, "_system", system)

    def _documented(self):
        for entry in _registered_systems():
            if entry["name"] == self._system:
                return entry["params"]
        return None

    def _checked(self, key):
        documented = self._documented()
        if documented is None or not isinstance(key, str):
            return
        names = [p["name"] for p in documented]
        if key not in names:
            close = difflib.get_close_matches(key, names, n=2)
            hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
            raise KeyError(f"{self._system} has no parameter {key!r} (it has {names}){hint}")

    def __getitem__(self, key):
        self._checked(key)
        raw = self._scene.raw(self._child(key))
        if raw is not None:
            return self._scene[self._child(key)]
        default = next(p["default"] for p in self._documented() if p["name"] == key)
        if default is None:
            raise KeyError(f"{self._system}: `{key}` is not set and has no default")
        if default.startswith("none"):
            return None  # an optional parameter the scene leaves out
        value = from_ron(default)
        return default if value is None else value

    def __setitem__(self, key, value):
        self._checked(key)
        documented = {p["name"]: p for p in self._documented() or []}
        old = self._scene.raw(self._child(key))
        if old is None and key in documented and documented[key]["type"] in ("f64", "u32", "u64", "usize"):
            old = "0.0"  # a number, whatever the file does not say yet
        text = to_ron(value, old, where=f"`{self._child(key)}`")
        self._scene[self._child(key)] = Ron(text)


class Check(dict):
    """What ``fractum check`` reports, as a dict; ``str()`` gives its text."""

    def __str__(self):
        return self["report"]

"""Python values to RON text and back, for the values a study changes in a scene."""

import json
import math
import numbers
import re

_NUMBER = re.compile(r"^[+-]?(\d[\d_]*\.?[\d_]*([eE][+-]?\d+)?|\.\d+([eE][+-]?\d+)?|inf|NaN)$")
_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_VARIANT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*\s*\(")


class Ron:
    """RON text given as it is, for values no Python type says: an enum variant with data
    (``Ron("Steps(500)")``), a map (``Ron('{"a": 1}')``), a shape (``Ron("Disk(center: (0.0,
    0.0), radius: 0.01)")``)."""

    def __init__(self, text):
        if not isinstance(text, str):
            raise TypeError(f"Ron takes RON text as a str, not {type(text).__name__}")
        self.text = text

    def __repr__(self):
        return f"Ron({self.text!r})"

    def __eq__(self, other):
        return isinstance(other, Ron) and other.text == self.text


def kind(raw):
    """What kind of value the RON text ``raw`` is, in words a message can use."""
    raw = raw.strip()
    if raw in ("true", "false"):
        return "a bool"
    if _NUMBER.match(raw):
        return "a number"
    if raw.startswith('"'):
        return "a string"
    if _IDENTIFIER.match(raw):
        return "a name (an enum variant)"
    if _VARIANT.match(raw):
        return "an enum variant with data"
    if raw.startswith("["):
        return "a list"
    if raw.startswith("{"):
        return "a map"
    return "a struct or tuple"


def _kind_of_value(value):
    if isinstance(value, bool):
        return "a bool"
    if isinstance(value, numbers.Real):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, (list,)):
        return "a list"
    if isinstance(value, (tuple, dict)):
        return "a struct or tuple"
    return type(value).__name__


def _compatible(old_kind, value):
    """Whether ``value`` may replace a value of ``old_kind``."""
    new_kind = _kind_of_value(value)
    if old_kind == new_kind:
        return True
    # A str replaces a name (an enum variant: `Spectral`) as well as a string.
    if isinstance(value, str) and old_kind == "a name (an enum variant)":
        return True
    # A name such as `Fixed` may become a variant with data written as a struct, and back.
    return False


def to_ron(value, old_raw=None, where="value"):
    """The RON text of ``value``; ``old_raw`` (the text it replaces) keeps its kind: a number
    stays a number, a name stays a name. Raises TypeError for a value of another kind."""
    if isinstance(value, Ron):
        return value.text
    if old_raw is not None:
        old_kind = kind(old_raw)
        if not _compatible(old_kind, value):
            raise TypeError(
                f"{where} holds {old_kind} ({old_raw.strip()[:60]}); got {_kind_of_value(value)} "
                f"({value!r}). Give {old_kind}, or fractum.Ron('...') for RON text as it is"
            )
        if isinstance(value, str) and old_kind == "a name (an enum variant)":
            if not _IDENTIFIER.match(value):
                raise ValueError(f"{where}: {value!r} is not a name such as {old_raw.strip()}")
            return value
    return _encode(value, where)


def _encode(value, where):
    if value is None:
        raise TypeError(f"{where}: None has no RON form here; leave the value out of the scene")
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        number = float(value)
        if not math.isfinite(number):
            raise ValueError(f"{where}: {number} is not a finite number")
        return repr(number)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, tuple):
        return "(" + ", ".join(_encode(v, where) for v in value) + ")"
    if isinstance(value, list):
        return "[" + ", ".join(_encode(v, where) for v in value) + "]"
    if isinstance(value, dict):
        fields = ", ".join(f"{_field(k, where)}: {_encode(v, where)}" for k, v in value.items())
        return f"({fields})"
    if isinstance(value, Ron):
        return value.text
    raise TypeError(f"{where}: a {type(value).__name__} has no RON form; use fractum.Ron('...')")


def _field(name, where):
    if not isinstance(name, str) or not _IDENTIFIER.match(name):
        raise TypeError(f"{where}: struct fields are names; got {name!r}")
    return name


def from_ron(raw):
    """The Python value of the RON text ``raw`` where it is a scalar, a string, or a tuple or
    list of them; None where it is a struct, a map or a variant (the caller gives a view)."""
    raw = raw.strip()
    if raw == "true":
        return True
    if raw == "false":
        return False
    if _NUMBER.match(raw):
        text = raw.replace("_", "")
        if text in ("inf", "+inf"):
            return math.inf
        if text == "-inf":
            return -math.inf
        if text == "NaN":
            return math.nan
        if re.match(r"^[+-]?\d+$", text):
            return int(text)
        return float(text)
    if raw.startswith('"'):
        try:
            return json.loads(raw)
        except ValueError:
            return raw
    if _IDENTIFIER.match(raw):
        return raw
    if raw.startswith(("(", "[")):
        return _literal(raw)
    return None


def _literal(raw):
    """A tuple or list of numbers, strings and bools, or None."""
    import ast

    text = re.sub(r"\btrue\b", "True", re.sub(r"\bfalse\b", "False", raw))
    try:
        value = ast.literal_eval(text)
    except (ValueError, SyntaxError, MemoryError, RecursionError):
        return None
    return value if isinstance(value, (tuple, list)) else None

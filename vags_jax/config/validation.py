"""Type checks of config dataclasses, driven by their field annotations.

``@checked`` (placed *under* ``@dataclass(frozen=True)``) makes a config class check, before its
own ``__post_init__`` runs, that every field holds a value of its annotated type, so any field
added later is checked too, with no extra code.  Rules (the same for ``--set`` overrides,
config.json and Python callers):

* ``int``: an int; ``bool`` is not accepted, and neither is a float, even an integral one
  (``replay.capacity=1e5`` is refused with the spelling to use, ``100000``), so a size never
  silently changes meaning.  NumPy integers are converted to ``int``.
* ``float``: a finite int or float (not ``bool``, not NaN or +-inf); stored as ``float``.
* ``bool``: ``True`` / ``False`` only (``--set`` spells them ``true`` / ``false``).
* ``str``: a string.  ``Literal[...]``: one of the listed values.
* ``Optional[X]``: ``None`` (``null`` in ``--set`` / JSON) or an ``X``.
* ``tuple[X, ...]``: a tuple (or list) of ``X``; ``tuple[X, Y]``: exactly that many items.
  Lists are stored as tuples (configs are hashable: they are static arguments of jit).
* a dataclass type: an instance of it (checked recursively).
* any other annotation is not checked here.

Errors are ``ValueError`` naming the field (``Class.field``) and the type it needs.  Value
ranges are checked by each class's ``__post_init__`` after this pass.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import sys
import typing
from typing import Any, Optional

import numpy as np

_NoneType = type(None)


def describe(annotation: Any) -> str:
    """Human-readable name of an annotation (``"an int"``, ``"null or a number"``, ...)."""
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if annotation is int:
        return "an int"
    if annotation is float:
        return "a finite number"
    if annotation is bool:
        return "true or false"
    if annotation is str:
        return "a string"
    if origin is typing.Literal:
        return "one of " + ", ".join(repr(a) for a in args)
    if origin is typing.Union:
        rest = [a for a in args if a is not _NoneType]
        head = "null or " if len(rest) < len(args) else ""
        return head + " or ".join(describe(a) for a in rest)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return f"a list of {_plural(args[0])}"
        return f"a list of {len(args)} items ({', '.join(_bare(a) for a in args)})"
    if dataclasses.is_dataclass(annotation):
        return f"a {annotation.__name__} section"
    return getattr(annotation, "__name__", repr(annotation))


def _bare(a) -> str:
    return {int: "int", float: "number", bool: "bool", str: "string"}.get(a, describe(a))


def _plural(a) -> str:
    return {int: "ints", float: "numbers", bool: "bools", str: "strings"}.get(a, describe(a))


def _show(value: Any) -> str:
    return f"{value!r} ({type(value).__name__})"


class _Bad(Exception):
    def __init__(self, where: str, value: Any, annotation: Any, hint: str = ""):
        self.where, self.value, self.annotation, self.hint = where, value, annotation, hint


def coerce(value: Any, annotation: Any, where: str = "") -> Any:
    """``value`` checked against ``annotation``; returns it normalised (tuple for list,
    float for an int in a float field, int for a NumPy int).  Raises ``_Bad``."""
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if annotation is Any:
        return value
    if annotation is bool:
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        raise _Bad(where, value, annotation)
    if annotation is int:
        if isinstance(value, (bool, np.bool_)):
            raise _Bad(where, value, annotation)
        if isinstance(value, (int, np.integer)):
            return int(value)
        hint = ""
        if isinstance(value, (float, np.floating)) and math.isfinite(value) and float(value).is_integer():
            hint = f"; write it without a decimal point or exponent: {int(value)}"
        raise _Bad(where, value, annotation, hint)
    if annotation is float:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise _Bad(where, value, annotation)
        value = float(value)
        if not math.isfinite(value):
            raise _Bad(where, value, annotation)
        return value
    if annotation is str:
        if isinstance(value, str):
            return value
        raise _Bad(where, value, annotation)
    if origin is typing.Literal:
        if any(value == a and type(value) is type(a) for a in args):
            return value
        raise _Bad(where, value, annotation)
    if origin is typing.Union:
        if value is None:
            if _NoneType in args:
                return None
            raise _Bad(where, value, annotation)
        for a in args:
            if a is _NoneType:
                continue
            try:
                return coerce(value, a, where)
            except _Bad:
                pass
        raise _Bad(where, value, annotation)
    if origin is tuple:
        if not isinstance(value, (tuple, list)):
            raise _Bad(where, value, annotation)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(coerce(v, args[0], f"{where}[{i}]") for i, v in enumerate(value))
        if args == ((),) or not args:  # tuple[()] / bare tuple
            return tuple(value)
        if len(value) != len(args):
            raise _Bad(where, value, annotation, f"; it has {len(value)} items, needs {len(args)}")
        return tuple(coerce(v, a, f"{where}[{i}]") for i, (v, a) in enumerate(zip(value, args)))
    if dataclasses.is_dataclass(annotation) and isinstance(annotation, type):
        if isinstance(value, annotation):
            return value
        raise _Bad(where, value, annotation)
    return value  # an annotation this module does not know: not checked


@functools.lru_cache(maxsize=None)
def field_types(cls) -> dict[str, Any]:
    """{field name: resolved annotation} of a dataclass (string annotations evaluated)."""
    module = sys.modules.get(cls.__module__)
    hints = typing.get_type_hints(cls, globalns=vars(module) if module else None)
    return {f.name: hints.get(f.name, Any) for f in dataclasses.fields(cls)}


def check_value(cls, name: str, value: Any, label: Optional[str] = None) -> Any:
    """Checks one value for field ``name`` of dataclass ``cls``; returns it normalised.
    Raises ValueError naming ``label`` (default ``Class.name``) and the type it needs."""
    label = label or f"{cls.__name__}.{name}"
    annotation = field_types(cls)[name]
    try:
        return coerce(value, annotation, label)
    except _Bad as bad:
        if bad.where != label:  # an item of a tuple
            raise ValueError(f"{bad.where} must be {describe(bad.annotation)}, got {_show(bad.value)}"
                             f"{bad.hint} (in {label}, which must be {describe(annotation)})") from None
        raise ValueError(f"{label} must be {describe(annotation)}, got {_show(bad.value)}{bad.hint}") from None


def check_fields(obj) -> None:
    """Type-checks every field of dataclass instance ``obj`` and stores normalised values."""
    cls = type(obj)
    for name in field_types(cls):
        value = getattr(obj, name)
        fixed = check_value(cls, name, value)
        if fixed is not value:
            object.__setattr__(obj, name, fixed)  # frozen dataclasses too


def checked(cls):
    """Class decorator: ``check_fields`` runs before the class's own ``__post_init__``.

    Put it *under* ``@dataclass(...)`` so that dataclass sees the ``__post_init__``::

        @dataclass(frozen=True)
        @checked
        class Section: ...
    """
    own = cls.__dict__.get("__post_init__")

    def __post_init__(self):
        check_fields(self)
        if own is not None:
            own(self)
        else:  # a base class's
            for base in type(self).__mro__[1:]:
                if "__post_init__" in base.__dict__:
                    base.__dict__["__post_init__"](self)
                    break

    __post_init__.__doc__ = own.__doc__ if own is not None else None
    cls.__post_init__ = __post_init__
    return cls

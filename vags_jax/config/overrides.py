"""Changing and (de)serialising configs: ``replace`` with dotted keys (``--set``),
``parse_overrides`` for the command lines, ``to_dict`` / ``from_dict`` for config.json."""
from __future__ import annotations

import dataclasses
import json

from vags_jax.config.validation import check_value


def replace(cfg, **changes):
    """dataclasses.replace that also accepts dotted keys, e.g. replace(cfg, **{"dqn.gamma": 0.9}).

    Each value is type-checked against its field's annotation first (``vags_jax.config.validation``),
    so an error names the dotted key as given (``stage1.n_worlds must be an int, got True``)."""
    return _replace(cfg, changes, "")


def without_iterations(cfg):
    """``cfg`` with every training stage's iteration count set to 1: what a stage's compiled
    programs depend on (iteration counts only decide how many chunks run)."""
    return replace(cfg, **{f"stage{n}.iterations": 1 for n in (1, 2, 3)}, **{"nbv.iterations": 1, "vpg.iterations": 1})


def _replace(cfg, changes: dict, prefix: str):
    nested: dict[str, dict] = {}
    flat = {}
    for k, v in changes.items():
        if "." in k:
            head, rest = k.split(".", 1)
            nested.setdefault(head, {})[rest] = v
        else:
            flat[k] = v
    names = {f.name for f in dataclasses.fields(cfg)}
    for head, sub in nested.items():
        if head not in names or not dataclasses.is_dataclass(getattr(cfg, head)):
            sections = sorted(f.name for f in dataclasses.fields(cfg)
                              if dataclasses.is_dataclass(getattr(cfg, f.name)))
            raise ValueError(f"unknown config section {prefix + head!r} in {type(cfg).__name__}; "
                             f"sections: {sections}")
        flat[head] = _replace(getattr(cfg, head), sub, f"{prefix}{head}.")
    for k in list(flat):
        if k not in names:
            raise ValueError(
                f"unknown config field {prefix + k!r} for {type(cfg).__name__}; valid fields: {sorted(names)}"
            )
        if k not in nested:
            flat[k] = check_value(type(cfg), k, flat[k], label=prefix + k)
    try:
        return dataclasses.replace(cfg, **flat)
    except ValueError as e:  # "Stage.n_worlds must ..." -> "stage1.n_worlds must ..."
        msg, cls = str(e), type(cfg).__name__ + "."
        if prefix and msg.startswith(cls):
            raise ValueError(prefix + msg[len(cls):]) from None
        raise


# ----------------------------------------------------------------------------- (de)serialisation


def to_dict(cfg) -> dict:
    """Nested plain-dict form (JSON-ready) of a config dataclass."""
    return dataclasses.asdict(cfg)


def from_dict(cls, data: dict):
    """Rebuild config dataclass ``cls`` from ``to_dict`` output; unknown keys are errors."""
    if not isinstance(data, dict):
        raise ValueError(f"expected a mapping for {cls.__name__}, got {type(data).__name__}")
    names = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - set(names))
    if unknown:
        raise ValueError(
            f"unknown config field(s) {unknown} for {cls.__name__}; valid fields: {sorted(names)}"
        )
    kwargs = {}
    for name, value in data.items():
        default = getattr(cls(), name) if _has_all_defaults(cls) else None
        if dataclasses.is_dataclass(default) and isinstance(value, dict):
            kwargs[name] = from_dict(type(default), value)
        elif isinstance(value, list):
            kwargs[name] = tuple(value)
        else:
            kwargs[name] = value
    return cls(**kwargs)


# Fields whose default changed after runs were written without them: a run's config.json that
# lacks one reads the value those runs trained with, so resuming an old run keeps its behaviour.
LEGACY_FIELDS = {("vags", "stage3_gdnet"): "all", ("vags", "stage3_gdnet_pick"): "last",
                 ("ggcnn", "labels"): "positives"}


def from_saved(cls, data: dict):
    """``from_dict`` of a config.json a run wrote: each ``LEGACY_FIELDS`` entry it lacks reads
    its legacy value instead of today's default."""
    if isinstance(data, dict):
        for (section, name), value in LEGACY_FIELDS.items():
            if isinstance(data.get(section), dict) and name not in data[section]:
                data = {**data, section: {**data[section], name: value}}
    return from_dict(cls, data)


def _has_all_defaults(cls) -> bool:
    return all(
        f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING
        for f in dataclasses.fields(cls)
    )


def parse_overrides(items: list[str]) -> dict:
    """Parse ``["dqn.gamma=0.9", "net.trunk=small"]`` into ``{"dqn.gamma": 0.9, ...}``.

    Values are read as JSON when possible (numbers, true/false, null, lists), else as strings;
    `replace` then checks each against its field's type (``vags_jax.config.validation``: ``1e3`` is a
    float, so an int field refuses it and says to write ``1000``; ``Infinity`` / ``NaN`` are
    refused for number fields).
    """
    out = {}
    for item in items:
        if "=" not in item:
            raise ValueError(f"override {item!r} must look like section.field=value")
        key, raw = item.split("=", 1)
        try:
            value = json.loads(raw)
        except json.JSONDecodeError:
            value = raw
        if isinstance(value, list):
            value = tuple(value)
        key = key.strip()
        if key in out:
            raise ValueError(f"override {key!r} is given twice ({out[key]!r} and {value!r}); keep one")
        out[key] = value
    return out

"""Load torchvision's ImageNet DenseNet-121 weights into our Flax trunks.

The user supplies the file (nothing is downloaded).  Accepted:

* ``.npz``: numpy arrays keyed by torchvision state-dict names (``features.conv0.weight``,
  ``features.denseblock1.denselayer1.norm1.running_mean``, ``features.norm5.weight``...).
  Make one from a torchvision checkpoint with (torch needed once, anywhere)::

      python -c "import sys, torch, numpy as np; sd = torch.load(sys.argv[1], map_location='cpu'); np.savez(sys.argv[2], **{k: v.numpy() for k, v in sd.items()})" densenet121-a639ec97.pth densenet121.npz

* ``.pth`` / ``.pt``: a torch state dict (or a dict holding one under ``"state_dict"``);
  needs ``torch`` importable (it is not a dependency of vags_jax).

Mapping: conv ``weight`` (O, I, kH, kW) -> ``kernel`` (kH, kW, I, O); BN ``weight`` -> ``scale``,
``bias`` -> ``bias`` (params), ``running_mean`` -> ``mean``, ``running_var`` -> ``var``
(batch_stats).  ``classifier.*`` and ``*.num_batches_tracked`` are ignored; ``module.`` prefixes,
a missing ``features.`` prefix and the old ``norm.1`` / ``conv.2`` spelling are accepted.  The same
ImageNet weights go into both trunks (colour and depth), as in VPG.

Training reads them through ``net.init`` (``--set net.init=densenet121.pth``): GDNet (stage 1)
and VANet (stage 2) start from ``initial_variables``; ``check_init`` reads the file before
anything is compiled.
"""
from __future__ import annotations

import os
import re
from typing import Iterable, Mapping, Optional

import jax.numpy as jnp
import numpy as np

from .densenet import BLOCK_CONFIG
from .qnet import init_qnet, variable_shapes

TO_NPZ_HINT = (
    "convert the checkpoint to .npz on any machine with torch: python -c \"import sys, torch, numpy "
    "as np; sd = torch.load(sys.argv[1], map_location='cpu'); np.savez(sys.argv[2], **{k: v.numpy() "
    "for k, v in sd.items()})\" densenet121.pth densenet121.npz"
)

# torch key -> (collection, path inside the trunk, kind); kind "conv" is transposed OIHW -> HWIO.
KeyMap = dict[str, tuple[str, tuple[str, ...], str]]


def densenet121_key_map(block_config: Iterable[int] = BLOCK_CONFIG) -> KeyMap:
    """Every torchvision ``features.*`` tensor of DenseNet-121 and where it lives in our trunk."""
    m: KeyMap = {}

    def conv(tname: str, path: tuple[str, ...]):
        m[f"features.{tname}.weight"] = ("params", path + ("kernel",), "conv")

    def bn(tname: str, path: tuple[str, ...]):
        m[f"features.{tname}.weight"] = ("params", path + ("scale",), "vec")
        m[f"features.{tname}.bias"] = ("params", path + ("bias",), "vec")
        m[f"features.{tname}.running_mean"] = ("batch_stats", path + ("mean",), "vec")
        m[f"features.{tname}.running_var"] = ("batch_stats", path + ("var",), "vec")

    conv("conv0", ("conv0",))
    bn("norm0", ("norm0",))
    block_config = tuple(block_config)
    for b, n_layers in enumerate(block_config, start=1):
        for l in range(1, n_layers + 1):
            base = f"denseblock{b}.denselayer{l}"
            path = (f"denseblock{b}", f"denselayer{l}")
            bn(f"{base}.norm1", path + ("norm1",))
            conv(f"{base}.conv1", path + ("conv1",))
            bn(f"{base}.norm2", path + ("norm2",))
            conv(f"{base}.conv2", path + ("conv2",))
        if b != len(block_config):
            bn(f"transition{b}.norm", (f"transition{b}", "norm"))
            conv(f"transition{b}.conv", (f"transition{b}", "conv"))
    bn("norm5", ("norm5",))
    return m


_OLD_STYLE = re.compile(r"^(.*denselayer\d+\.(?:norm|relu|conv))\.((?:1|2)\.(?:weight|bias|running_mean|running_var))$")


def _normalise_keys(state: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    out = {}
    for k, v in state.items():
        if k.startswith("module."):
            k = k[len("module."):]
        m = _OLD_STYLE.match(k)
        if m:
            k = m.group(1) + m.group(2)
        out[k] = np.asarray(v)
    if not any(k.startswith("features.") for k in out) and "conv0.weight" in out:
        out = {("features." + k if not k.startswith("classifier.") else k): v for k, v in out.items()}
    return out


def read_state_dict(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read a torchvision state dict from ``.npz`` or ``.pth`` / ``.pt`` into numpy arrays."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"pretrained weights file not found: {path}")
    if path.endswith(".npz"):
        with np.load(path, allow_pickle=False) as z:
            return {k: np.asarray(z[k]) for k in z.files}
    if path.endswith((".pth", ".pt")):
        try:
            import torch  # lazily: torch is not a dependency
        except ImportError as e:
            raise ImportError(f"reading {path} needs torch, which is not installed; either "
                              f"`pip install torch`, or {TO_NPZ_HINT} and pass the .npz") from e
        obj = torch.load(path, map_location="cpu", weights_only=True)
        if isinstance(obj, Mapping) and "state_dict" in obj and isinstance(obj["state_dict"], Mapping):
            obj = obj["state_dict"]
        if not isinstance(obj, Mapping):
            raise ValueError(f"{path} holds a {type(obj).__name__}, expected a state dict (name -> tensor)")
        return {k: v.detach().cpu().numpy() for k, v in obj.items() if hasattr(v, "detach")}
    raise ValueError(f"pretrained weights must be a .npz or .pth/.pt file, got {path}")


def _get(tree: Mapping, path: tuple[str, ...]):
    for p in path:
        tree = tree[p]
    return tree


def _set(tree: dict, path: tuple[str, ...], value) -> None:
    for p in path[:-1]:
        tree = tree[p]
    tree[path[-1]] = value


def _copy(tree):
    if isinstance(tree, Mapping):
        return {k: _copy(v) for k, v in tree.items()}
    return tree


def _trunk_tree(variables: Mapping, collection: str, trunk: Optional[str]):
    tree = variables[collection]
    return tree if trunk is None else tree[trunk]


def _show(keys: list[str], n: int = 5) -> str:
    return ", ".join(keys[:n]) + (f" ... ({len(keys)} in all)" if len(keys) > n else "")


def load_densenet121(variables: Mapping, weights, trunks: Iterable[Optional[str]] = ("colour_trunk", "depth_trunk"),
                     strict: bool = True) -> dict:
    """Return ``variables`` with torchvision DenseNet-121 ``features`` weights in the given trunks.

    Args:
      variables: ``{"params": ..., "batch_stats": ...}`` of a GDNet / VANet built with
        ``trunk="densenet121"`` (or of a bare ``DenseNet121`` with ``trunks=(None,)``).
      weights: a path (``.npz`` / ``.pth``) or a mapping torch name -> array.
      trunks: submodule names to fill (None: the root is the trunk).
      strict: raise on unexpected keys other than ``classifier.*`` / ``num_batches_tracked``.
    Returns:
      A new variables dict (inputs untouched); loaded leaves are float32 ``jnp`` arrays, the
      rest (e.g. the head) is unchanged.
    Raises:
      ValueError listing the first offending keys, for missing keys, shape mismatches, a
      non-DenseNet trunk, or (strict) unexpected keys.
    """
    state = weights if isinstance(weights, Mapping) else read_state_dict(weights)
    state = _normalise_keys(state)
    key_map = densenet121_key_map()
    missing = [k for k in key_map if k not in state]
    if missing:
        raise ValueError(f"DenseNet-121 state dict is missing {len(missing)} of {len(key_map)} keys: "
                         f"{_show(missing)}")
    unexpected = [k for k in state if k not in key_map and not k.startswith("classifier.")
                  and not k.endswith("num_batches_tracked")]
    if strict and unexpected:
        raise ValueError(f"state dict has keys that are not DenseNet-121 features: {_show(unexpected)} "
                         f"(pass strict=False to ignore them)")

    out = {c: _copy(t) for c, t in variables.items()}
    for trunk in trunks:
        where = "the root" if trunk is None else f"{trunk!r}"
        try:
            _get(_trunk_tree(out, "params", trunk), ("conv0", "kernel"))
            _get(_trunk_tree(out, "batch_stats", trunk), ("norm5", "mean"))
        except (KeyError, TypeError) as e:
            raise ValueError(f"variables have no DenseNet-121 trunk at {where} (no conv0 / norm5); "
                             f"was the network built with Net.trunk='densenet121'?") from e
        bad = []
        for tkey, (coll, path, kind) in key_map.items():
            value = np.asarray(state[tkey], np.float32)
            if kind == "conv" and value.ndim == 4:
                value = value.transpose(2, 3, 1, 0)  # OIHW -> HWIO
            tree = _trunk_tree(out, coll, trunk)
            try:
                current = _get(tree, path)
            except KeyError:
                bad.append(f"{tkey} (no {coll}/{'/'.join(path)} in {where})")
                continue
            if tuple(current.shape) != value.shape:
                bad.append(f"{tkey}: got {tuple(state[tkey].shape)}, expected "
                           f"{_torch_shape(tuple(current.shape), kind)}")
                continue
            _set(tree, path, jnp.asarray(value, jnp.float32))
        if bad:
            raise ValueError(f"DenseNet-121 weights do not fit trunk {where}: {_show(bad)}")
    return out


def initial_variables(key, model, net_cfg, height: int, width: int) -> dict:
    """A fresh Q-network's ``{"params", "batch_stats"}`` (``init_qnet``) for heightmaps of
    (height, width), with the ImageNet weights of ``net_cfg.init`` (a ``config.Net``) in both
    DenseNet-121 trunks when it names a file; the head stays random."""
    variables = init_qnet(key, model, height, width)
    return variables if net_cfg.init is None else load_densenet121(variables, net_cfg.init)


def check_init(net_cfg, model, height: int, width: int) -> None:
    """Reads ``net_cfg.init`` and checks that it fills ``model``'s trunks, with nothing compiled
    (the variables' shapes are traced).  ValueError (one line) saying what to fix."""
    if net_cfg.init is None:
        return

    path = net_cfg.init
    if not os.path.isfile(path):
        raise ValueError(f"net.init {path!r}: no such file; give a torchvision DenseNet-121 state dict you have "
                         f"(.pth, or .npz of the same keys): nothing is downloaded")
    try:
        load_densenet121(variable_shapes(model, height, width), path)
    except (ValueError, ImportError, OSError, KeyError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ValueError(f"net.init {path!r}: {first}") from None


def _torch_shape(shape: tuple[int, ...], kind: str) -> tuple[int, ...]:
    if kind == "conv" and len(shape) == 4:
        h, w, i, o = shape
        return (o, i, h, w)
    return shape


def to_torchvision_state_dict(variables: Mapping, trunk: Optional[str] = "colour_trunk") -> dict[str, np.ndarray]:
    """Inverse of the loader for one trunk: torch name -> numpy array in torch layout (OIHW)."""
    out = {}
    for tkey, (coll, path, kind) in densenet121_key_map().items():
        value = np.asarray(_get(_trunk_tree(variables, coll, trunk), path), np.float32)
        if kind == "conv":
            value = value.transpose(3, 2, 0, 1)  # HWIO -> OIHW
        out[tkey] = value
    return out

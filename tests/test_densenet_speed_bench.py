"""bench/densenet_speed.py on a tiny input on CPU: every formulation of DenseNet-121's eval pass
(and of its stem, and of its prefixes) computes the module's result and is counted at the model
FLOPs it executes.  One run of the script for all forms, on a DenseNet of DenseNet-121's layers
with fewer of them in each block (``BLOCKS``; --blocks): DenseNet-121 itself compiled in about 50
s on CI's cores, and every form's code is the same whatever the block lengths."""
import json
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
import densenet_speed  # noqa: E402

# No "module" form: the script checks against the module's output computed with its cuts (one
# compile of DenseNet-121 less); every row's module_flops is the module's own count.
WHOLE = ["folded_s2d", "folded_s2d_dot", "folded_s2d_poolfirst", "folded_s2d_pooldot"]
UPTO = [f"upto_{c}" for c in densenet_speed.CUTS]
STEMS = ["stem", "stem_s2d"]
BLOCKS = (1, 2, 2, 1)  # dense layers per block (DenseNet-121: 6, 12, 24, 16)


@pytest.fixture(scope="module")
def rows(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("densenet_speed") / "speed.json")
    forms = WHOLE + UPTO + STEMS
    assert densenet_speed.main(["--px", "32", "--batches", "1", "--reps", "1", "--dtype", "float32",
                                "--forms", ",".join(forms), "--blocks", ",".join(map(str, BLOCKS)), "--out", out]) == 0
    with open(out) as f:
        rows = {r["form"]: r for r in json.load(f)["rows"]}
    assert list(rows) == forms and all(r["s"] > 0 and r["images"] == 1 for r in rows.values())
    return rows


def _conv_flops(px, k, c_in, c_out):
    return 2 * px * px * k * k * c_in * c_out


def _cumulative_flops():
    """The module's FLOPs up to each cut for one 32 x 32 image, from the layer arithmetic: stem
    16 x 16, blocks on 8, 4, 2, 1 px; a dense layer 1x1 to 128 channels, 3x3 to 32."""
    total, out = _conv_flops(16, 7, 3, 64), {"stem": _conv_flops(16, 7, 3, 64)}
    channels = 64
    for b, (n_layers, px) in enumerate(zip(BLOCKS, (8, 4, 2, 1))):
        for i in range(n_layers):
            total += _conv_flops(px, 1, channels + 32 * i, 128) + _conv_flops(px, 3, 128, 32)
        channels += 32 * n_layers
        out[f"block{b + 1}"] = total
        if b < 3:
            total += _conv_flops(px, 1, channels, channels // 2)
            channels //= 2
            out[f"trans{b + 1}"] = total
    return out


def _transition_flops():
    """The FLOPs of the three transitions' 1x1 convs (on 8 x 8, 4 x 4, 2 x 2): each cut after a
    transition minus the cut before it."""
    cuts = _cumulative_flops()
    return sum(cuts[f"trans{b}"] - cuts[f"block{b}"] for b in (1, 2, 3))


def test_whole_passes_agree_with_the_module(rows):
    assert all(rows[k]["max_rel_diff_to_module"] < 1e-5 for k in WHOLE), {k: rows[k]["max_rel_diff_to_module"] for k in WHOLE}
    assert {rows[k]["module_flops"] for k in WHOLE} == {_cumulative_flops()["block4"]}


def test_dot_forms_count_the_modules_flops_and_pool_first_a_quarter_of_the_transitions(rows):
    module = rows["folded_s2d"]["module_flops"]
    assert rows["folded_s2d"]["flops"] == rows["folded_s2d_dot"]["flops"] == module
    # The transitions' 1x1 convs on 8 x 8, 4 x 4, 2 x 2: pool-first runs them on a quarter of the pixels.
    transitions = _transition_flops()
    assert rows["folded_s2d_poolfirst"]["flops"] == rows["folded_s2d_pooldot"]["flops"] == module - transitions * 3 // 4
    for k in ("folded_s2d_poolfirst", "folded_s2d_pooldot"):
        assert rows[k]["mfu_of_module_flops"] > rows[k]["mfu"]


def test_each_prefix_agrees_with_the_module_at_its_cut(rows):
    assert all(rows[k]["max_rel_diff_to_module"] < 1e-5 for k in UPTO), {k: rows[k]["max_rel_diff_to_module"] for k in UPTO}
    flops = [rows[k]["flops"] for k in UPTO]
    assert all(a < b for a, b in zip(flops, flops[1:])), flops
    assert flops[-1] == rows["folded_s2d"]["module_flops"]
    # Each cut where the layer arithmetic puts it, the module's prefix counted the same.
    assert {k: rows[k]["module_flops"] for k in UPTO} == {k: rows[k]["flops"] for k in UPTO} == {
        f"upto_{c}": f for c, f in _cumulative_flops().items()}


def test_stems_agree_and_count_the_7x7_conv(rows):
    assert rows["stem_s2d"]["max_rel_diff_to_module"] < 1e-5 and rows["stem_s2d"]["flops"] == rows["stem"]["flops"]
    # The stem's model FLOPs: a 7 x 7 / 2 conv from 3 to 64 channels on 32 x 32 (no zero taps).
    assert rows["stem"]["flops"] == rows["stem"]["module_flops"] == 2 * 16 * 16 * 7 * 7 * 3 * 64


def test_blocks_must_be_four_positive_counts(capsys):
    for bad in ("1,2,2", "1,2,x,1", "1,0,2,1"):
        with pytest.raises(SystemExit) as e:
            densenet_speed.main(["--blocks", bad])
        assert e.value.code == 2 and "--blocks takes 4 positive integers" in capsys.readouterr().err

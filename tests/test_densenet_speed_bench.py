"""bench/densenet_speed.py on a tiny input on CPU: every formulation of DenseNet-121's eval pass
(and of its stem) computes the module's result and is counted at the same model FLOPs."""
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bench"))
import densenet_speed  # noqa: E402


def test_formulations_agree_with_the_module_and_count_the_same_flops(tmp_path):
    out = str(tmp_path / "speed.json")
    forms = ["module", "folded_s2d", "stem", "stem_s2d"]
    assert densenet_speed.main(["--px", "32", "--batches", "1", "--reps", "1", "--dtype", "float32",
                                "--forms", ",".join(forms), "--out", out]) == 0
    with open(out) as f:
        rows = {r["form"]: r for r in json.load(f)["rows"]}
    assert list(rows) == forms and all(r["s"] > 0 and r["images"] == 1 for r in rows.values())
    for group in (forms[:2], forms[2:]):  # whole passes; stems
        assert len({rows[k]["flops"] for k in group}) == 1, {k: rows[k]["flops"] for k in group}
        assert all(rows[k]["max_rel_diff_to_module"] < 1e-5 for k in group), rows
    # The stem's model FLOPs: a 7 x 7 / 2 conv from 3 to 64 channels on 32 x 32 (no zero taps).
    assert rows["stem"]["flops"] == 2 * 16 * 16 * 7 * 7 * 3 * 64

"""Prints the tables of driver.sh and headroom.sh: both pipelines' wall clocks; each run (trained
and evaluated with `vags.direct_score=q_mean`) against issue 23's goals, VAGS against its own
ablation; the grasps after a move against the direct ones on each table's moving bins;
gate_headroom.py's tables (VANet's move against a random object cell).  The table functions are
the thirty-fifth and thirty-sixth looks'.  Run from anywhere:
python bench/results/viewpoints/default/thirtyseventh_look/tables.py"""
import importlib.util
import os

HERE = os.path.dirname(os.path.abspath(__file__))
RUNS = (("q52", "cold (empty cache)"), ("q53", "from q52's cache"))


def _load(look):
    spec = importlib.util.spec_from_file_location(f"{look}_tables", os.path.join(HERE, "..", look, "tables.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main():
    look35, look36 = _load("thirtyfifth_look"), _load("thirtysixth_look")
    look35.timing_table(HERE, RUNS)
    look35.goals_tables(HERE, RUNS, suffixes=("",))
    look35.moving_bins_table(HERE, RUNS, suffixes=("",))
    look36.headroom_tables(HERE, RUNS)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

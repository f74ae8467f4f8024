#!/usr/bin/env bash
# One bare H200, 2026-11-29 02:43-02:47 UTC (the device tool's command, unfolded), the tree of ef99870:
# every formulation and cut of bench/densenet_speed.py, then the four whole-pass forms again in another order.
F=module,folded_s2d,folded_s2d_dot,folded_s2d_poolfirst,folded_s2d_pooldot,upto_stem,upto_block1,upto_trans1,upto_block2,upto_trans2,upto_block3,upto_trans3,upto_block4
PYTHONPATH=. python3 bench/densenet_speed.py --batches 1024 --reps 10 --forms $F --out $OUT/densenet_forms_h200.json 2>&1 | grep -v "^W0\|^I0" | tee $OUT/densenet_forms_h200.txt
PYTHONPATH=. python3 bench/densenet_speed.py --batches 1024 --reps 10 --forms folded_s2d,folded_s2d_pooldot,folded_s2d_poolfirst,folded_s2d_dot,folded_s2d \
  --out $OUT/densenet_forms_again_h200.json 2>&1 | grep -v "^W0\|^I0" | tee $OUT/densenet_forms_again_h200.txt

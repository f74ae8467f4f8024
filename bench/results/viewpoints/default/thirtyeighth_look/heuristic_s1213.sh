#!/usr/bin/env bash
# Written on 2026-12-07 AFTER driver.sh had run: the one-line command of the next device call on
# the same machine and compile cache, unrolled (its first try wrote the reports too deep for the
# copy back; they were written again to $OUT/r{0,10}_seed{S}.json and committed here as
# heuristic/r{0,10}/seed{S}/).  Step 1 of driver.sh on seeds 12 and 13.
cd /root/src
export PYTHONPATH=/root/vags-site:/root/src PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
H="--config gpu --policy heuristic --groups 6,7,8,9,10 --rounds 50 --seeds 12,13 --cache-dir /root/cc"
export XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.3
python eval.py $H --set benchmark.redraw_spilled=0 --out "$OUT/r0_seed{seed}.json" &
python eval.py $H --set benchmark.redraw_spilled=10 --out "$OUT/r10_seed{seed}.json"
wait

#!/usr/bin/env bash
# Written on 2026-12-07 before its device call.
# Issue 27: at stage 1's 512 worlds the grasp loop is latency-bound (the thirty-fifth look:
# 147 ms for 512 grasps, 176 ms for 1,024), and there a bare scan of MJX steps ran 1.21x faster
# unrolled 4 times with XLA's CUDA graphs allowed down to one kernel
# (--xla_gpu_graph_min_graph_size=1).  Does that flag alone speed our grasp loop, and does XLA
# capturing the loop itself into a graph (command buffers with WHILE) work with MJX's Warp calls?
# bench/physics_profile.py (the `gpu` physics, 512 worlds of 3 objects), one process each, A B C
# then A B C again: A the defaults, B XLA_FLAGS=--xla_gpu_graph_min_graph_size=1, C B plus
# --xla_gpu_enable_command_buffer with WHILE and CONDITIONAL added to its defaults.
# Fixed before the run: nothing changes in the product on this; it says where to look next.
S=/root/src
export PYTHONPATH=/root/vags-site:$S PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
cd $S
RES=/root/res C=/root/cc
source bench/driver_lib.sh
start_log
P="python bench/physics_profile.py --config gpu --worlds 512 --objects 3 --repeats 5 --variant default:"
G="--xla_gpu_graph_min_graph_size=1"
W="--xla_gpu_enable_command_buffer=FUSION,CUBLAS,CUBLASLT,CUSTOM_CALL,CUDNN,WHILE,CONDITIONAL"
for i in 1 2; do
  run A$i timeout 150 $P --out $RES/A.jsonl
  XLA_FLAGS="$G" run B$i timeout 150 $P --out $RES/B.jsonl
  XLA_FLAGS="$G $W" run C$i timeout 150 $P --out $RES/C.jsonl
done
echo "done $(date +%T)" >> $RES/machine_log.txt

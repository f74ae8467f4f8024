#!/usr/bin/env bash
# Written on 2026-12-07, before the device call that runs it.  Issue 27: what the small programs
# cut from an eval.py process this session (ab0cf9b: renderer tables, the move-cost threshold,
# restore targets and the benchmark's key seeding no longer run eager programs; 33 -> 21 on the
# tiny preset on the CPU) save on the GPU.  No trained run fits this session's device time, so
# the policy is the heuristic on the gpu preset (no networks: the environment, renderer, re-drop
# and rounds loop that every policy's process builds), groups 1-10 x 10 rounds, seed 11.
# "new" is this tree; "old" is the same tree with ffd2d2e's four files, made beside the tree and
# carried with the call (.dev is git-ignored):
#   for f in vags_jax/perception/render.py vags_jax/policies/decision.py vags_jax/stages/rundir.py \
#            vags_jax/benchmark/protocol.py; do mkdir -p .dev/old/$(dirname $f); git show ffd2d2e:$f > .dev/old/$f; done
# Runs: new cold (fills the cache), old warm-up (compiles its extra small programs), then
# new, old, new, old warm, each timed as a whole process, programs counted from JAX's log;
# bench/process_startup.py once before them all (the device time left may end the list early).  About 5 minutes on ONE bare machine after the wheels.
S=/root/src
export PYTHONPATH=/root/vags-site PYTHONUNBUFFERED=1 CUDA_VISIBLE_DEVICES=0
unset JAX_COMPILATION_CACHE_DIR
RES=/root/res C=/root/cc
mkdir -p /root/old && (cd $S && tar cf - --exclude=.whl --exclude=.dev . | tar xf - -C /root/old) && cp -r $S/.dev/old/vags_jax /root/old/
cd $S && source bench/driver_lib.sh && start_log
one() {  # KEY TREE
  local key=$1 tree=$2
  (cd $tree && export JAX_LOG_COMPILES=1 PYTHONPATH=/root/vags-site:$tree && run $key bash -c \
    "time python eval.py --config gpu --policy heuristic --groups 1-10 --rounds 10 --seed 11 --cache-dir $C --out $RES/$key/eval.json")
  echo "$key programs=$(grep -c 'Finished XLA compilation of' $RES/$key.txt) hits=$(grep -c 'Persistent compilation cache hit' $RES/$key.txt) $(grep real $RES/$key.txt)" >> $RES/programs.txt
}
(cd $S && PYTHONPATH=/root/vags-site:$S python bench/process_startup.py --programs 60 --out $RES/startup.json > $RES/startup.txt 2>&1)
echo "startup rc=$? $(date +%T)" >> $RES/machine_log.txt
one new_cold $S
one old_warmup /root/old
one new_warm1 $S
one old_warm1 /root/old
one new_warm2 $S
one old_warm2 /root/old
echo "done $(date +%T)" >> $RES/machine_log.txt

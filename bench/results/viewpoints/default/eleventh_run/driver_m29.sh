#!/usr/bin/env bash
# Issue 23: an eleventh fresh gpu run with today's defaults (stage 3 "all", the GDNet picked by the
# gate table); the stage-2 ablation beside stage 3; then VAGS, its ablation and the Fig. 6 sweep.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o29; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader) tree $(cat .dev/m29/tree 2>/dev/null)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
R=runs/r29
run stage1 python train.py --config gpu --stage gdnet --out $R --cache-dir $C --quiet --json
run stage2 python train.py --out $R --stage stage2 --cache-dir $C --quiet --json
cp $R/config.json $O/; cp $R/metrics.jsonl $O/metrics_stage1.jsonl; cp $R/stage2/metrics.jsonl $O/metrics_stage2.jsonl
ev 0.3 nv_stage2 python eval.py --run $R --networks stage2 --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/stage2/seed{seed}/eval_vags-no-viewpoint.json" &
XLA_PYTHON_CLIENT_MEM_FRACTION=0.6 run stage3 python train.py --out $R --stage stage3 --cache-dir $C --json
cp $R/stage3/metrics.jsonl $O/metrics_stage3.jsonl; cp $R/timings.jsonl $R/gate.json $R/config.json $O/
ev 0.3 nv python eval.py --run $R --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
ev 0.3 vags python eval.py --run $R --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags.json" &
ev 0.3 sweep python eval.py --run $R --seed 11 --rounds 20 --threshold-sweep=-0.25:0.25:0.05 --cache-dir $C --out $O/sweep/eval_vags_r20.json &
wait; echo "done $(date +%T)" >> $log; touch runs/m29_done

#!/usr/bin/env bash
# Issue 23, on the same machine after driver_m28.sh: stage 3 "all" from the tenth run's stage-2
# checkpoint (a hard-linked copy without stage3/ and gate.json), then VAGS and its ablation beside each other.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1; O=$PWD/runs/o28/all; mkdir -p $O; C=/root/cc; R=runs/r28all; cp -al runs/r28 $R; rm -rf $R/stage3 $R/gate.json; find $R -type f -not -path '*/checkpoints/*' | while read f; do cp "$f" "$f.tmp" && mv "$f.tmp" "$f"; done
python - $R/config.json <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); d["vags"]["stage3_gdnet"] = "all"; json.dump(d, open(sys.argv[1], "w"), indent=1)
PY
t=$(date +%s); XLA_PYTHON_CLIENT_MEM_FRACTION=0.6 python train.py --out $R --stage stage3 --cache-dir $C --quiet --json > $O/stage3.txt 2>&1; echo "s3_all rc=$? $(( $(date +%s)-t )) s $(date +%T)" | tee $O/machine_log.txt; tail -1 $O/stage3.txt; cp $R/stage3/metrics.jsonl $O/metrics_stage3.jsonl; cp $R/gate.json $R/timings.jsonl $R/config.json $O/
export XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.3
python eval.py --run $R --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags-no-viewpoint.json" > $O/nv.txt 2>&1 &
python eval.py --run $R --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags.json" > $O/vags.txt 2>&1 &
for i in $(seq 1 60); do sleep 5; [ -f $O/seed13/eval_vags.json ] && [ -f $O/seed13/eval_vags-no-viewpoint.json ] && break; [ $(( $(date +%s)-t )) -gt 545 ] && break; done; echo "evals end $(date +%T)" >> $O/machine_log.txt

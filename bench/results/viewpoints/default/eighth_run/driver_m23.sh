#!/usr/bin/env bash
# Issue 23: stage 3 and GDNet.  One fresh gpu run through stage 2 (runs/base), then stage 3 two
# ways from the same stage-2 checkpoint (vags.stage3_gdnet = direct | frozen), each with its
# rate table, VAGS and --no-viewpoint on seeds 11-13.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o23; log=$PWD/runs/m23.log; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader) $(git log --oneline -1 2>/dev/null)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
run stage1 python train.py --config gpu --stage gdnet --out runs/base --cache-dir $C --quiet --json
run stage2 python train.py --out runs/base --stage stage2 --cache-dir $C --quiet --json
cp runs/base/config.json runs/base/metrics.jsonl runs/base/timings.jsonl $O/; cp runs/base/stage2/metrics.jsonl $O/metrics_stage2.jsonl
du -sh runs/base >> $log
for v in direct frozen; do
  R=runs/s3_$v; cp -al runs/base $R
  find $R -type f -not -path '*/checkpoints/*' | while read f; do cp "$f" "$f.tmp" && mv "$f.tmp" "$f"; done
  python - $R/config.json $v <<'PY'
import json, sys
p, v = sys.argv[1], sys.argv[2]
d = json.load(open(p)); d["vags"]["stage3_gdnet"] = v
json.dump(d, open(p, "w"), indent=1)
PY
  ( export XLA_PYTHON_CLIENT_MEM_FRACTION=0.3
    run s3_$v python train.py --out $R --stage stage3 --cache-dir $C --quiet --json
    mkdir -p $O/$v; cp $R/stage3/metrics.jsonl $O/$v/metrics_stage3.jsonl; cp $R/timings.jsonl $O/$v/
    [ -f $R/gate.json ] || run gate_$v python -m vags_jax.stages.gate_measure --run $R
    cp $R/gate.json $R/gate_states.npz $O/$v/ 2>/dev/null
    run vags_$v python eval.py --run $R --seeds 11,12,13 --cache-dir $C --out "$O/$v/seed{seed}/eval_vags.json"
    run nv_$v python eval.py --run $R --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/$v/seed{seed}/eval_vags-no-viewpoint.json"
  ) &
  sleep 20
done
wait; echo "done $(date +%T)" >> $log; touch runs/m23_done

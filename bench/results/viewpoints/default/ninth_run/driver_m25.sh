#!/usr/bin/env bash
# Issue 23: stage 3 two ways (vags.stage3_gdnet = direct | frozen) from one fresh gpu run's
# stage-2 checkpoint, against that run's stage-2 networks (= stage 1's GDNet) without moves.
# Each stage 3 trains at 0.6 of the GPU (it OOMed at 0.3 in m23) and measures its own gate table;
# evaluations run beside it, each capped at 0.3 and allocating on demand.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o25; log=$PWD/runs/m25.log; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
ev() { XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=0.3 run "$@"; }
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
done
ev nv_stage2 python eval.py --run runs/s3_direct --networks stage2 --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/stage2/seed{seed}/eval_vags-no-viewpoint.json" &
XLA_PYTHON_CLIENT_MEM_FRACTION=0.6 run s3_direct python train.py --out runs/s3_direct --stage stage3 --cache-dir $C --quiet --json
mkdir -p $O/direct; cp runs/s3_direct/stage3/metrics.jsonl runs/s3_direct/timings.jsonl runs/s3_direct/gate.json $O/direct/
ev vags_direct python eval.py --run runs/s3_direct --seeds 11,12,13 --cache-dir $C --out "$O/direct/seed{seed}/eval_vags.json" &
XLA_PYTHON_CLIENT_MEM_FRACTION=0.6 run s3_frozen python train.py --out runs/s3_frozen --stage stage3 --cache-dir $C --quiet --json
mkdir -p $O/frozen; cp runs/s3_frozen/stage3/metrics.jsonl runs/s3_frozen/timings.jsonl runs/s3_frozen/gate.json $O/frozen/
ev nv_direct python eval.py --run runs/s3_direct --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/direct/seed{seed}/eval_vags-no-viewpoint.json" &
ev vags_frozen python eval.py --run runs/s3_frozen --seeds 11,12,13 --cache-dir $C --out "$O/frozen/seed{seed}/eval_vags.json" &
wait; echo "done $(date +%T)" >> $log; touch runs/m25_done

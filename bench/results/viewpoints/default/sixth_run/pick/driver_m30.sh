#!/usr/bin/env bash
# Issue 23: the pick on the sixth run (stage 3 "all", whose GDNet alone lost 9-10 points): the
# gate table measured with stage 3's GDNet and with stage 2's, then VAGS and its ablation on the
# networks it kept, seeds 11-13.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
O=$PWD/runs/o30; log=$O/machine_log.txt; mkdir -p $O; C=/root/cc
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader) tree $(cat .dev/m30/tree)" > $log
run() { k=$1; shift; t=$(date +%s); "$@" > $O/$k.txt 2>&1; echo "$k rc=$? $(( $(date +%s)-t )) s $(date +%T)" >> $log; }
ev() { f=$1; shift; XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=$f run "$@"; }
R=runs/r16; mkdir -p runs; tar xzf .dev/o16/r16.tgz -C runs; mv $R/gate.json $O/gate_before.json
python - $R/config.json <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); d["vags"]["stage3_gdnet_pick"] = "rate"; json.dump(d, open(sys.argv[1], "w"), indent=1)
PY
run gate python -m vags_jax.stages.gate_measure --run $R
cp $R/gate.json $O/
ev 0.45 vags python eval.py --run $R --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags.json" &
ev 0.45 nv python eval.py --run $R --no-viewpoint --seeds 11,12,13 --cache-dir $C --out "$O/seed{seed}/eval_vags-no-viewpoint.json" &
wait; echo "done $(date +%T)" >> $log; touch runs/m30_done

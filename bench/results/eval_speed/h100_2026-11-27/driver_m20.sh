#!/usr/bin/env bash
# Issue 27: a warm 500-round eval.py of VAGS (the sixth run's networks), side by side: the code
# before this session's loading change ("old", c9cec8e's eval.py, checkpoint.py, rundir.py) and
# after ("new"), first without byte-compiled modules (as this machine's install left them), then
# after compileall (as a pip install leaves them).
export PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=$PWD/runs/o20; log=$PWD/runs/m20.log; mkdir -p $O
tar xzf .dev/o16/r16.tgz -C runs
NEW=$PWD; OLD=/root/old; rm -rf $OLD; mkdir -p $OLD; cp -r eval.py train.py vags_jax $OLD/
cp .dev/m20/old/eval.py $OLD/eval.py; cp .dev/m20/old/checkpoint.py .dev/m20/old/rundir.py $OLD/vags_jax/stages/
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader) PYTHONDONTWRITEBYTECODE=${PYTHONDONTWRITEBYTECODE-unset}" > $log
ev() { k=$1; dir=$2; shift 2; t=$(date +%s%N); (cd $dir && PYTHONPATH=/root/vags-site:$dir python eval.py --run $NEW/runs/r16 --seed 14 --cache-dir /root/cc-eval --out $O/$k/eval_vags.json "$@" > $O/$k.txt 2>&1); echo "$k rc=$? $(( ($(date +%s%N) - t) / 1000000 )) ms $(date +%T)" >> $log; }
ev cold $NEW
ev new_nopyc1 $NEW; ev old_nopyc1 $OLD
python -m compileall -q -j 8 /root/vags-site $NEW/vags_jax $NEW/eval.py $OLD/vags_jax $OLD/eval.py > /dev/null 2>&1
p=$(python -c "import jax, os; print(os.path.dirname(os.path.dirname(jax.__file__)))"); echo "site $p" >> $log
for m in jax jaxlib flax optax orbax chex numpy etils ml_dtypes absl scipy treescope tensorstore msgpack rich humanize; do [ -d $p/$m ] && python -m compileall -q -j 8 $p/$m > /dev/null 2>&1; done
echo "compileall done $(date +%T)" >> $log
for i in 1 2 3; do ev new_pyc$i $NEW; ev old_pyc$i $OLD; done
touch runs/m20_done
# Second call on the same warm machine (the old copy lacked scenes/, so its runs above ended with rc=2):
#   cp -r scenes /root/old; then for i in 1 2 3: ev old_pyc$i $OLD; ev new_pyc$((i+3)) $NEW

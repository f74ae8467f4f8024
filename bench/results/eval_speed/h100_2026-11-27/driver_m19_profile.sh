#!/usr/bin/env bash
# Issue 27: where a warm 500-round eval.py of VAGS spends its time (the sixth run's networks).
# A cold eval fills the cache; then warm: plain x2, two seeds in one process, cProfile.
export PYTHONPATH=/root/vags-site:$PWD PYTHONUNBUFFERED=1
unset JAX_COMPILATION_CACHE_DIR
O=runs/o19; log=runs/m19.log; mkdir -p $O
tar xzf .dev/o16/r16.tgz -C runs
echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader)" > $log
ev() { k=$1; shift; t=$(date +%s%N); python "$@" --run runs/r16 --cache-dir /root/cc-eval > $O/$k.txt 2>&1; echo "$k rc=$? $(( ($(date +%s%N) - t) / 1000000 )) ms $(date +%T)" >> $log; }
ev cold eval.py --seed 14 --out $O/cold/eval_vags.json
ev warm1 eval.py --seed 14 --out $O/warm1/eval_vags.json
ev warm2 eval.py --seed 14 --out $O/warm2/eval_vags.json
ev seeds2 eval.py --seeds 14,15 --out "$O/seeds2/seed{seed}/eval_vags.json"
ev prof -m cProfile -o $O/warm.prof eval.py --seed 14 --out $O/prof/eval_vags.json
python -X importtime -c "import eval" 2> $O/importtime.txt
python -c "import pstats; pstats.Stats('$O/warm.prof').sort_stats('cumulative').print_stats(60)" > $O/prof_cum.txt
python -c "import pstats; pstats.Stats('$O/warm.prof').sort_stats('tottime').print_stats(40)" > $O/prof_tot.txt
touch runs/m19_done

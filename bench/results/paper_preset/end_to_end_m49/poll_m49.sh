# poll: wait up to $1 s for "done" (or for the line named by $2), then tar results to $OUT
O=runs/o49; end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q "^${2:-done}" $O/machine_log.txt 2>/dev/null; do sleep 10; done
cat $O/machine_log.txt; tail -n 3 $O/gpu_mem.txt 2>/dev/null; for f in $O/stage1.txt $O/precompile.txt $O/stage2.txt $O/stage3.txt $O/eval_vags.txt; do echo "== $f"; tail -c 700 $f 2>/dev/null; done
tar czf $OUT/o49.tgz runs/o49 2>/dev/null; ls -la $OUT

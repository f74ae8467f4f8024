# poll: wait up to $1 s for the line named by $2 (default "done"), then tar results to $OUT
O=runs/o51; end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q "^${2:-done}" $O/machine_log.txt 2>/dev/null; do sleep 10; done
cat $O/machine_log.txt; cat runs/g51/timings.jsonl 2>/dev/null; tail -c 400 $O/train.txt 2>/dev/null; for f in $O/vags.txt $O/vags_nv.txt $O/warm_eval.txt; do tail -c 300 $f 2>/dev/null; done
tar czf $OUT/o51.tgz runs/o51 2>/dev/null; ls -la $OUT

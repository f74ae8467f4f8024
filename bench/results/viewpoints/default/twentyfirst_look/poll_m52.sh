# poll: wait up to $1 s for the line named by $2 (default "done"), then tar results to $OUT
O=runs/o52; end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q "^${2:-done}" $O/machine_log.txt 2>/dev/null; do sleep 10; done
cat $O/machine_log.txt; cat runs/g52/timings.jsonl 2>/dev/null; tail -c 600 $O/train.txt 2>/dev/null; for f in $O/refit16.txt $O/vags.txt $O/vags_nv.txt $O/cap.txt $O/cap16.txt; do tail -c 400 $f 2>/dev/null; done; cat runs/g52w/timings.jsonl 2>/dev/null
tar czf $OUT/o52.tgz runs/o52 2>/dev/null; ls -la $OUT

# poll: wait up to $1 s for the line named by $2 (default "done"), then tar results to $OUT
O=/root/runs/o54; end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q "^${2:-done}" $O/machine_log.txt 2>/dev/null; do sleep 5; done
cat $O/machine_log.txt; cat /root/runs/g54/timings.jsonl /root/runs/g54w/timings.jsonl 2>/dev/null; grep -h "compile ahead\|warning\|Error\|error" $O/train.txt $O/train_warm.txt 2>/dev/null | tail -20; tail -c 400 $O/train.txt $O/train_warm.txt 2>/dev/null; for f in $O/vags.txt $O/vags_nv.txt $O/wvags.txt $O/wvags_nv.txt $O/sweep.txt; do tail -c 300 $f 2>/dev/null; done
tar czf $OUT/o54.tgz -C /root/runs o54 2>/dev/null; ls -la $OUT

O=/root/runs/o55; end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q "^${2:-done}" $O/machine_log.txt 2>/dev/null; do sleep 5; done
cat /root/runs/o54/machine_log.txt $O/machine_log.txt 2>/dev/null; cat /root/runs/g55w/timings.jsonl 2>/dev/null; grep -h "compile ahead\|warning\|Error" $O/train_warm.txt 2>/dev/null | tail -8; tail -c 300 /root/runs/o54/sweep.txt; for f in $O/wvags.txt $O/wvags_nv.txt; do tail -c 400 $f 2>/dev/null; done
tar czf $OUT/o54.tgz -C /root/runs o54 2>/dev/null; tar czf $OUT/o55.tgz -C /root/runs o55 2>/dev/null; ls -la $OUT

O=/root/runs/o56; end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q "^${2:-done}" $O/machine_log.txt 2>/dev/null; do sleep 5; done
cat $O/machine_log.txt 2>/dev/null; cat /root/runs/g56/timings.jsonl 2>/dev/null | tail -12; tail -c 600 $O/train.txt 2>/dev/null; cat $O/estimates.txt 2>/dev/null
for f in $O/vags.txt $O/vags_nv.txt $O/vags_e.txt $O/vags_rep.txt; do tail -c 300 $f 2>/dev/null; done
tar czf $OUT/o56.tgz -C /root/runs o56 2>/dev/null; ls -la $OUT

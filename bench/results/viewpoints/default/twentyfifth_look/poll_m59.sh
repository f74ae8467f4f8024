N=59; O=/root/runs/o$N; end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q "^${2:-done}" $O/machine_log.txt 2>/dev/null; do sleep 4; done
cat $O/machine_log.txt 2>/dev/null; tail -n 3 /root/runs/g$N/timings.jsonl 2>/dev/null | cut -c1-200
cat $O/paired.txt 2>/dev/null | head -40
for f in $O/vags_nv.txt $O/vags_s.txt $O/vags_cap.txt; do grep -A6 "^| vags" $f 2>/dev/null | tail -5; grep "rate gate" $f 2>/dev/null; done
tar czf $OUT/o$N.tgz -C /root/runs o$N 2>/dev/null; ls -la $OUT

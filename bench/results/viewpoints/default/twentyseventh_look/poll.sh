# poll.sh SECONDS PATTERN: waits for PATTERN in the machine log, prints progress, packs results.
L=/root/runs/machine_log.txt; end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q "${2:-^done}" $L 2>/dev/null; do sleep 4; done
cat $L 2>/dev/null
for N in 64 65 66 67; do [ -d /root/runs/o$N ] || continue; echo "== g$N"; tail -n 1 /root/runs/g$N/timings.jsonl 2>/dev/null | cut -c1-160; tail -c 200 /root/runs/o$N/train.txt 2>/dev/null; echo
  for f in vags_nv_. vags_. vags16_.; do grep -A6 "^| vags" /root/runs/o$N/$f.txt 2>/dev/null | tail -4; done; done
for N in 64 65 66 67; do [ -d /root/runs/o$N ] && tar czf $OUT/o$N.tgz -C /root/runs o$N machine_log.txt 2>/dev/null; done; ls -la $OUT

# poll.sh SECONDS PATTERN: waits for PATTERN in the machine log, prints progress, packs results.
L=/root/runs/machine_log.txt; end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q "${2:-^done}" $L 2>/dev/null; do sleep 4; done
cat $L 2>/dev/null
for N in 60 61 62 63; do echo "== g$N"; tail -n 2 /root/runs/g$N/timings.jsonl 2>/dev/null | cut -c1-160; tail -c 300 /root/runs/o$N/train.txt 2>/dev/null; echo
  for f in vags_nv vags vags_cap; do grep -A6 "^| vags" /root/runs/o$N/$f.txt 2>/dev/null | tail -4; done; done
for N in 60 61 62 63; do [ -d /root/runs/o$N ] && tar czf $OUT/o$N.tgz -C /root/runs o$N machine_log.txt 2>/dev/null; done; ls -la $OUT

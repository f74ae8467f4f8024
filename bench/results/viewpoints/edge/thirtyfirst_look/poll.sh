#!/usr/bin/env bash
# poll.sh SECONDS N: waits up to SECONDS for look N's "done", prints the logs, packs both looks' results (no checkpoints).
N=${2:-80}; L=/root/runs/o$N/machine_log.txt; end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q "^done" $L 2>/dev/null; do sleep 4; done
for n in 80 81; do O=/root/runs/o$n; [ -d $O ] || continue; echo "=== o$n"; cat $O/machine_log.txt
  for k in train measure abl_q vags_q abl_s vags_s; do [ -f $O/$k.txt ] && { echo "== $k"; tail -3 $O/$k.txt; }; done; done
tail -3 /root/driver.out 2>/dev/null
cd /root/runs && tar czf $OUT/looks.tgz o80 o81 2>/dev/null; ls -la $OUT

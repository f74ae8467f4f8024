#!/usr/bin/env bash
# poll.sh SECONDS: waits up to SECONDS for the driver's "done", prints the log, packs the results (no checkpoints).
N=${2:-70}; O=/root/runs/o$N; L=$O/machine_log.txt; end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q "^done" $L 2>/dev/null; do sleep 4; done
cat $L 2>/dev/null; tail -3 /root/driver.out 2>/dev/null
for k in train measure abl_q vags_q abl_s vags_s; do [ -f $O/$k.txt ] && { echo "== $k"; tail -4 $O/$k.txt; }; done
cd /root/runs && tar czf $OUT/o$N.tgz o$N 2>/dev/null; ls -la $OUT

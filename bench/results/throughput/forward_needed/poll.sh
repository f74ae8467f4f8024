#!/usr/bin/env bash
# Waits up to $1 seconds (or until the driver's "done" line in log $2, by default
# /root/res/machine_log.txt), then packs /root/res into $OUT.
end=$(( $(date +%s) + ${1:-540} )); log=${2:-/root/res/machine_log.txt}
while [ $(date +%s) -lt $end ] && ! grep -q '^done' $log 2>/dev/null; do sleep 10; done
cat $log 2>/dev/null; tail -3 /root/driver.out 2>/dev/null
nvidia-smi --query-gpu=index,utilization.gpu,memory.used --format=csv,noheader
tar czf $OUT/res.tgz -C /root res 2>/dev/null; ls -la $OUT

#!/usr/bin/env bash
# Waits up to $1 seconds (or until the driver's "done" line), then packs /root/res into $OUT.
end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q '^done' /root/res/machine_log.txt 2>/dev/null; do sleep 10; done
cat /root/res/machine_log.txt 2>/dev/null; tail -3 /root/driver.out 2>/dev/null
nvidia-smi --query-gpu=index,utilization.gpu,memory.used --format=csv,noheader
tar czf $OUT/res.tgz -C /root res 2>/dev/null; ls -la $OUT

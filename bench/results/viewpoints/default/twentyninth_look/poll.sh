# poll.sh SECONDS PATTERN: waits for PATTERN in the log, prints progress, packs results (no checkpoints).
O=/root/runs/look; L=$O/log.txt; end=$(( $(date +%s) + ${1:-540} ))
while [ $(date +%s) -lt $end ] && ! grep -q "${2:-^done}" $L 2>/dev/null; do sleep 4; done
cat $L 2>/dev/null; tail -5 /root/driver.out 2>/dev/null

[ -f $O/summary.md ] && cat $O/summary.md
cd /root/runs && { find look -path look/cache -prune -o -path 'look/s*/run' -prune -o -type f -print;
  ls look/s*/run/{config.json,timings.jsonl,summary.json,gate.json,gate_states.npz,compile_ahead*.log} 2>/dev/null; } > /tmp/list.txt
tar czf $OUT/look.tgz -T /tmp/list.txt 2>/dev/null; ls -la $OUT

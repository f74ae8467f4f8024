# Functions for a device driver (bench/results/*/driver*.sh): `source bench/driver_lib.sh` after
# setting RES (the folder whose contents come back) and C (the compile cache).
#   run KEY CMD...   runs CMD with its output in $RES/KEY.txt and appends "KEY rc=N S s HH:MM:SS"
#                    to $RES/machine_log.txt (the line bench/pipeline_times.py reads); returns CMD's
#                    status.  Its variables are local, so a caller's loop variables survive it.
#   ev KEY CMD...    run, for an evaluation sharing the GPU: on-demand allocation, 30 % of the device.
#   keep RUN DEST    copies a run's small files (config, metrics, timings, summary, gate table and
#                    its states, the compile-ahead logs, stages 2-3's metrics) to DEST.
#   start_log        writes the log's first line: the time and the GPUs.
: "${RES:?set RES before sourcing bench/driver_lib.sh}"
mkdir -p "$RES"

start_log() {
  echo "start $(date +%T) $(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | tr '\n' ' ')" \
    > "$RES/machine_log.txt"
}

run() {
  local key=$1 t0 rc
  shift
  t0=$(date +%s)
  "$@" > "$RES/$key.txt" 2>&1
  rc=$?
  echo "$key rc=$rc $(( $(date +%s) - t0 )) s $(date +%T)" >> "$RES/machine_log.txt"
  return $rc
}

ev() {
  XLA_PYTHON_CLIENT_PREALLOCATE=false XLA_PYTHON_CLIENT_MEM_FRACTION=${EV_MEM_FRACTION:-0.3} run "$@"
}

keep() {
  local src=$1 dst=$2 f s
  mkdir -p "$dst"
  for f in config.json metrics.jsonl timings.jsonl summary.json gate.json gate_states.npz \
           compile_ahead.log compile_ahead_gate.log; do
    [ -f "$src/$f" ] && cp "$src/$f" "$dst/"
  done
  for s in stage2 stage3; do
    [ -f "$src/$s/metrics.jsonl" ] && cp "$src/$s/metrics.jsonl" "$dst/${s}_metrics.jsonl"
  done
  return 0
}

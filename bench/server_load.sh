#!/usr/bin/env bash
# Load benchmark of stickslipd (issue 4 "Load"): while a study keeps both cores busy, 50
# concurrent clients poll GET /v1/studies/{id} for 30 s with wrk. Reports wrk's errors and
# latency percentiles, and the study's throughput (runs/s) under load against the mean of a
# no-load window before and after it, measured in the same run.
#
#   bash bench/server_load.sh [BUILD_DIR]        (default ./build; needs wrk and curl)
#
# Environment: DURATION (s, default 30), CONNECTIONS (default 50), WRK_THREADS (default 2),
# BASELINE (s, no-load window, default 30), POLL_MS (pause of each client between two polls,
# default 0 = back to back, i.e. as fast as the server answers; e.g. 100 = 50 clients at 10 Hz),
# DAEMON_ARGS (extra stickslipd options, e.g. "--handler-threads 0"). Targets: 0 errors, p99 <= 50 ms, drop <= 10 %.
# Note that wrk runs on the same 2-core machine, so its own CPU use counts in the drop.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
DURATION=${DURATION:-30}
CONNECTIONS=${CONNECTIONS:-50}
WRK_THREADS=${WRK_THREADS:-2}
BASELINE=${BASELINE:-30}
POLL_MS=${POLL_MS:-0}  # > 0: each client waits this long between polls; 0: back to back
for tool in wrk curl; do
  command -v "$tool" >/dev/null || { echo "server_load: $tool is missing (scripts/install-deps.sh)"; exit 2; }
done
[ -x "$BUILD/server/stickslipd" ] || { echo "server_load: build $BUILD/server/stickslipd first"; exit 2; }

WORK=$(mktemp -d)
DAEMON_PID=""
cleanup() {
  if [ -n "$DAEMON_PID" ] && kill -0 "$DAEMON_PID" 2>/dev/null; then
    kill -TERM "$DAEMON_PID"; wait "$DAEMON_PID" || true
  fi
  rm -rf "$WORK"
}
trap cleanup EXIT

"$BUILD/server/stickslipd" --db "$WORK/load.db" --port 0 --port-file "$WORK/port" --threads 2 \
  --log-level warn ${DAEMON_ARGS:-} >"$WORK/daemon.log" 2>&1 &
DAEMON_PID=$!
for _ in $(seq 200); do [ -s "$WORK/port" ] && break; sleep 0.05; done
URL="http://127.0.0.1:$(cat "$WORK/port")"

# Many runs of the same cost (so runs/s is comparable between windows): the four models cycle
# fastest, v_a/v_d = 1, k_d varies by +-1 % only; 2 x 2 s stages, adaptive integrator. Long
# enough to keep both cores busy through all three windows.
cat >"$WORK/study.json" <<'JSON'
{"name": "load", "stages": [{"duration": 2}, {"duration": 2, "f": 1500}],
 "design": {"type": "grid", "axes": [
   {"name": "k_d", "linspace": [11600, 11800, 1000]},
   {"name": "va_over_vd", "values": [1]},
   {"name": "model", "values": ["dahl", "karnopp", "reset_integrator", "lugre"]}]}}
JSON
ID=$(curl -sS -X POST -H 'Content-Type: application/json' --data-binary @"$WORK/study.json" \
  "$URL/v1/studies" | grep -o '"id":"[^"]*"' | head -1 | cut -d'"' -f4)
[ -n "$ID" ] || { echo "server_load: submit failed"; exit 1; }

done_runs() { curl -sS "$URL/v1/studies/$ID" | grep -o '"done":[0-9]*' | cut -d: -f2; }
state() { curl -sS "$URL/v1/studies/$ID" | grep -o '"state":"[^"]*"' | cut -d'"' -f4; }
# Runs per second over a window of $1 seconds (commit-quantised: batches of <= 64 runs or 0.5 s).
window_rate() {
  local a b t0 t1
  a=$(done_runs); t0=$(date +%s.%N)
  sleep "$1"
  b=$(done_runs); t1=$(date +%s.%N)
  awk -v a="$a" -v b="$b" -v t0="$t0" -v t1="$t1" 'BEGIN { printf "%.3f", (b - a) / (t1 - t0) }'
}

# CPU seconds used so far by the server's threads at nice 0 (I/O, handlers, main), i.e. not
# the study threads (nice --worker-nice, default 10). /proc/PID/task/TID/stat: field 14 utime,
# 15 stime (clock ticks), 19 nice; the comm field has no spaces here.
TICK=$(getconf CLK_TCK)
http_cpu() {
  cat /proc/"$DAEMON_PID"/task/*/stat 2>/dev/null |
    awk -v tick="$TICK" '$19 == 0 { s += $14 + $15 } END { printf "%.3f", s / tick }'
}

sleep 3  # let the study reach steady state
BEFORE=$(window_rate "$BASELINE")

WRK_SCRIPT=()
if [ "$POLL_MS" -gt 0 ]; then
  echo "function delay() return $POLL_MS end" >"$WORK/poll.lua"
  WRK_SCRIPT=(-s "$WORK/poll.lua")
fi
A=$(done_runs); T0=$(date +%s.%N); C0=$(http_cpu)
TIMEFORMAT='%U %S'
{ time wrk -t"$WRK_THREADS" -c"$CONNECTIONS" -d"${DURATION}s" --latency "${WRK_SCRIPT[@]}" \
  "$URL/v1/studies/$ID" >"$WORK/wrk.txt" 2>&1 ; } 2>"$WORK/wrk.time"
B=$(done_runs); T1=$(date +%s.%N); C1=$(http_cpu)
UNDER=$(awk -v a="$A" -v b="$B" -v t0="$T0" -v t1="$T1" 'BEGIN { printf "%.3f", (b - a) / (t1 - t0) }')

AFTER=$(window_rate "$BASELINE")
STATE=$(state)

set +e +o pipefail  # parsing wrk's report: a missing line is not an error
echo "== wrk: $CONNECTIONS connections, $WRK_THREADS threads, ${DURATION}s, GET /v1/studies/{id}, pause ${POLL_MS} ms"
cat "$WORK/wrk.txt"
REQS=$( (grep -o '^ *[0-9]* requests in' "$WORK/wrk.txt" || true) | grep -o '[0-9]*' | head -1)
SOCKET_ERRORS=$( (grep -o 'Socket errors:.*' "$WORK/wrk.txt" || true) | grep -o '[0-9]\+' | awk '{s += $1} END {print s + 0}')
NON2XX=$( (grep -o 'Non-2xx or 3xx responses: [0-9]*' "$WORK/wrk.txt" || true) | grep -o '[0-9]*$' || true)
P99=$(awk '/ 99%/ {print $2}' "$WORK/wrk.txt")
echo
echo "== summary"
echo "requests:              ${REQS:-?}"
echo "errors:                socket ${SOCKET_ERRORS:-0}, non-2xx ${NON2XX:-0}   (target 0)"
echo "p99 latency:           ${P99:-?}   (target <= 50 ms)"
echo "study throughput:      before ${BEFORE} runs/s, under load ${UNDER} runs/s, after ${AFTER} runs/s"
awk -v b="$BEFORE" -v a="$AFTER" -v u="$UNDER" 'BEGIN {
  base = (b + a) / 2; if (base <= 0) { print "throughput drop:       n/a (no progress)"; exit }
  printf "throughput drop:       %.1f %% vs the mean of before/after   (target <= 10 %%)\n", 100 * (base - u) / base }'
echo "study state at the end: $STATE"
# The drop the API can cause at most: the CPU its threads and the load generator used during the
# window, as a share of the 2 cores (independent of other users of the machine, unlike runs/s).
WRK_CPU=$(awk '{ print $1 + $2 }' "$WORK/wrk.time")
awk -v c0="$C0" -v c1="$C1" -v w="$WRK_CPU" -v t0="$T0" -v t1="$T1" -v n="$(nproc)" 'BEGIN {
  cap = n * (t1 - t0)
  printf "CPU during the window:  server HTTP threads %.2f s (%.1f %% of %d cores), wrk %.2f s (%.1f %%)\n",
         c1 - c0, 100 * (c1 - c0) / cap, n, w, 100 * w / cap }'
echo "machine load average:  $(cut -d' ' -f1-3 /proc/loadavg) (other users of the machine add noise to runs/s)"

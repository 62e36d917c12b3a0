#!/usr/bin/env bash
# Load benchmark of stickslipd (issue 4 "Load"): while a study keeps both cores busy, 50
# concurrent clients poll GET /v1/studies/{id} for 30 s with wrk. Targets: 0 errors (socket
# errors and non-2xx responses), p99 latency <= 50 ms, and a study throughput drop <= 10 %.
#
#   bash bench/server_load.sh [BUILD_DIR]        (default ./build; needs wrk and curl)
#
# One server, one long study, and alternating windows measured in the same run:
#   baseline, load(wrk nice W1), baseline, load(wrk nice W2), baseline, ... (REPS times each)
# The study's throughput (runs/s of the same study, read from its progress) in each load window
# is compared with the mean of the two baseline windows around it, so a slow drift of the
# machine (other users) cancels out; the load average is printed for every window.
#
# wrk runs on the same 2 cores as the study and the server, so its own CPU counts in the drop.
# WRK_NICES lists the nice values wrk is run at: 0 is the "raw" setting (wrk competes with the
# study at the same priority); 10 the "fair" one (the load generator stands for clients on other
# machines, so it is run at the same low priority as the server's HTTP threads, --io-nice 10).
#
# Environment: DURATION (s per load window, default 30), BASELINE (s per baseline window,
# default 30), REPS (default 2), WRK_NICES (default "0 10"), CONNECTIONS (default 50),
# WRK_THREADS (default 2), POLL_MS (pause of each client between two polls, default 0 = back to
# back), DAEMON_ARGS (extra stickslipd options, e.g. "--io-nice 0 --worker-nice 10"),
# STICKSLIPD (the binary, default BUILD_DIR/server/stickslipd).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
DURATION=${DURATION:-30}
BASELINE=${BASELINE:-30}
REPS=${REPS:-2}
WRK_NICES=${WRK_NICES:-"0 10"}
CONNECTIONS=${CONNECTIONS:-50}
WRK_THREADS=${WRK_THREADS:-2}
POLL_MS=${POLL_MS:-0}
STICKSLIPD=${STICKSLIPD:-$BUILD/server/stickslipd}
for tool in wrk curl; do
  command -v "$tool" >/dev/null || { echo "server_load: $tool is missing (scripts/install-deps.sh)"; exit 2; }
done
[ -x "$STICKSLIPD" ] || { echo "server_load: build $STICKSLIPD first"; exit 2; }

WORK=$(mktemp -d)
DAEMON_PID=""
cleanup() {
  if [ -n "$DAEMON_PID" ] && kill -0 "$DAEMON_PID" 2>/dev/null; then
    kill -TERM "$DAEMON_PID"; wait "$DAEMON_PID" || true
  fi
  rm -rf "$WORK"
}
trap cleanup EXIT

"$STICKSLIPD" --db "$WORK/load.db" --port 0 --port-file "$WORK/port" --threads 2 \
  --log-level warn ${DAEMON_ARGS:-} >"$WORK/daemon.log" 2>&1 &
DAEMON_PID=$!
for _ in $(seq 200); do [ -s "$WORK/port" ] && break; sleep 0.05; done
[ -s "$WORK/port" ] || { echo "server_load: stickslipd did not start"; cat "$WORK/daemon.log"; exit 1; }
URL="http://127.0.0.1:$(cat "$WORK/port")"

# Many runs of the same cost (so runs/s is comparable between windows): the four models cycle
# fastest, v_a/v_d = 1, k_d varies by +-1 % only; 2 x 2 s stages, adaptive integrator. 50,000
# runs keep both cores busy through all windows (about 100 runs/s on this machine, idle, since
# the faster adaptive event location; 12,000 ran out after two windows). A window that sees
# the study finish is flagged below.
cat >"$WORK/study.json" <<'JSON'
{"name": "load", "stages": [{"duration": 2}, {"duration": 2, "f": 1500}],
 "design": {"type": "grid", "axes": [
   {"name": "k_d", "linspace": [11600, 11800, 12500]},
   {"name": "va_over_vd", "values": [1]},
   {"name": "model", "values": ["dahl", "karnopp", "reset_integrator", "lugre"]}]}}
JSON
ID=$(curl -sS -X POST -H 'Content-Type: application/json' --data-binary @"$WORK/study.json" \
  "$URL/v1/studies" | grep -o '"id":"[^"]*"' | head -1 | cut -d'"' -f4)
[ -n "$ID" ] || { echo "server_load: submit failed"; exit 1; }

done_runs() { curl -sS "$URL/v1/studies/$ID" | grep -o '"done":[0-9]*' | cut -d: -f2; }
state() { curl -sS "$URL/v1/studies/$ID" | grep -o '"state":"[^"]*"' | cut -d'"' -f4; }
now() { date +%s.%N; }
rate() { awk -v a="$1" -v b="$2" -v t0="$3" -v t1="$4" 'BEGIN { printf "%.3f", (b - a) / (t1 - t0) }'; }
load1() { cut -d' ' -f1 /proc/loadavg; }

# CPU seconds used so far by the server's HTTP threads (named http-io / http-handler; the study
# threads are not). /proc/PID/task/TID/stat: field 2 comm, 14 utime, 15 stime (clock ticks).
TICK=$(getconf CLK_TCK)
http_cpu() {
  cat /proc/"$DAEMON_PID"/task/*/stat 2>/dev/null |
    awk -v tick="$TICK" '$2 ~ /^\(http-/ { s += $14 + $15 } END { printf "%.3f", s / tick }'
}
# A wrk latency figure ("850.00us", "12.30ms", "1.02s") in ms.
to_ms() {
  awk -v v="$1" 'BEGIN { n = v + 0; if (v ~ /us$/) n /= 1000; else if (v ~ /[0-9]s$/ && v !~ /ms$/) n *= 1000;
                         if (v == "") print "?"; else printf "%.2f", n }'
}

baseline_window() {  # prints "runs/s load1"
  local a b t0 t1
  a=$(done_runs); t0=$(now)
  sleep "$BASELINE"
  b=$(done_runs); t1=$(now)
  echo "$(rate "$a" "$b" "$t0" "$t1") $(load1)"
}

WRK_SCRIPT=()
if [ "$POLL_MS" -gt 0 ]; then
  echo "function delay() return $POLL_MS end" >"$WORK/poll.lua"
  WRK_SCRIPT=(-s "$WORK/poll.lua")
fi
load_window() {  # $1 = nice of wrk; prints "runs/s load1 requests errors non2xx p50 p99 http_cpu wrk_cpu"
  local a b t0 t1 c0 c1 out="$WORK/wrk-$2.txt"
  a=$(done_runs); t0=$(now); c0=$(http_cpu)
  TIMEFORMAT='%U %S'
  { time nice -n "$1" wrk -t"$WRK_THREADS" -c"$CONNECTIONS" -d"${DURATION}s" --latency \
      "${WRK_SCRIPT[@]}" "$URL/v1/studies/$ID" >"$out" 2>&1 ; } 2>"$WORK/wrk.time"
  b=$(done_runs); t1=$(now); c1=$(http_cpu)
  set +e +o pipefail  # parsing wrk's report: a missing line is not an error
  local reqs sock non2xx p50 p99 wcpu
  reqs=$(grep -o '^ *[0-9]* requests in' "$out" | grep -o '[0-9]*' | head -1)
  sock=$(grep -o 'Socket errors:.*' "$out" | grep -o '[0-9]\+' | awk '{s += $1} END {print s + 0}')
  non2xx=$(grep -o 'Non-2xx or 3xx responses: [0-9]*' "$out" | grep -o '[0-9]*$')
  p50=$(to_ms "$(awk '/^ *50%/ {print $2}' "$out")")
  p99=$(to_ms "$(awk '/^ *99%/ {print $2}' "$out")")
  wcpu=$(awk '{ print $1 + $2 }' "$WORK/wrk.time")
  set -e -o pipefail
  echo "$(rate "$a" "$b" "$t0" "$t1") $(load1) ${reqs:-0} ${sock:-0} ${non2xx:-0} $p50 $p99" \
       "$(awk -v c0="$c0" -v c1="$c1" 'BEGIN { printf "%.2f", c1 - c0 }') $wcpu"
}

echo "== stickslipd $(basename "$STICKSLIPD") ${DAEMON_ARGS:-(defaults)}; wrk: $CONNECTIONS connections," \
     "$WRK_THREADS threads, ${DURATION} s per window, pause ${POLL_MS} ms; baseline ${BASELINE} s; $(nproc) cores"
echo "   load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"
sleep 3  # let the study reach steady state
read -r PREV PREV_LOAD < <(baseline_window)
printf '%-9s %-9s %9s %9s %7s %7s %9s %9s %10s %8s %8s %7s %7s\n' rep wrk_nice base_rps load_rps drop% \
  load1 requests errors non2xx p50_ms p99_ms http_s wrk_s
SUMMARY="$WORK/summary"
: >"$SUMMARY"
for rep in $(seq "$REPS"); do
  for wn in $WRK_NICES; do
    read -r L LLOAD REQS SOCK NON2XX P50 P99 HCPU WCPU < <(load_window "$wn" "$rep")
    read -r NEXT NEXT_LOAD < <(baseline_window)
    DROP=$(awk -v p="$PREV" -v n="$NEXT" -v l="$L" 'BEGIN { b = (p + n) / 2; if (b <= 0) print "nan"; else printf "%.1f", 100 * (b - l) / b }')
    printf '%-9s %-9s %9.2f %9.2f %7s %7s %9s %9s %10s %8s %8s %7s %7s\n' "$rep" "$wn" \
      "$(awk -v p="$PREV" -v n="$NEXT" 'BEGIN { print (p + n) / 2 }')" "$L" "$DROP" "$LLOAD" \
      "$REQS" "$SOCK" "$NON2XX" "$P50" "$P99" "$HCPU" "$WCPU"
    echo "$wn $DROP $SOCK $NON2XX $P99 $REQS" >>"$SUMMARY"
    PREV=$NEXT
  done
done
STATE=$(state)
echo
echo "== summary per wrk nice (targets: 0 errors, p99 <= 50 ms, drop <= 10 %)"
for wn in $WRK_NICES; do
  awk -v wn="$wn" -v d="$DURATION" '$1 == wn { n++; drop += $2; err += $3 + $4; if ($5 > p99) p99 = $5; req += $6 }
    END { if (n) printf "wrk nice %-3s %d windows: mean drop %.1f %%, errors %d, worst p99 %.2f ms, %.0f requests/s\n",
                        wn, n, drop / n, err, p99, req / (n * d) }' "$SUMMARY"
done
echo "study state at the end: $STATE (must be running: otherwise the study ended inside a window)"
echo "http_s / wrk_s: CPU seconds of the server's HTTP threads / of wrk in the window;" \
     "load1: the 1-minute load average at the end of the window (other users add noise to runs/s)"

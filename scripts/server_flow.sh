#!/usr/bin/env bash
# The server flow of issue 4's first README command, ready for scripts/main.sh to call after
# scripts/build.sh: start stickslipd on the embedded SQLite store (ephemeral port), submit a study
# with the client, wait with progress, print its stick-slip map, and stop the server cleanly
# (SIGTERM, exit 0).
#
#   bash scripts/server_flow.sh [SPEC] [DB]     (defaults: studies/paper-map.json, ./stickslip.db)
#
# Re-running it resumes or reuses nothing by itself: each call submits the spec again (a new
# study); the store keeps every earlier study.
set -euo pipefail
cd "$(dirname "$0")/.."
SPEC=${1:-studies/paper-map.json}
DB=${2:-stickslip.db}
BIN=./build
PORT_FILE=$(mktemp)
rm -f "$PORT_FILE"

"$BIN/server/stickslipd" --db "$DB" --port 0 --port-file "$PORT_FILE" --log-level warn &
DAEMON=$!
stop_daemon() {
  if kill -0 "$DAEMON" 2>/dev/null; then
    kill -TERM "$DAEMON"
    wait "$DAEMON" || { echo "server_flow: stickslipd exited with $?" >&2; return 1; }
  fi
  rm -f "$PORT_FILE"
}
trap stop_daemon EXIT
for _ in $(seq 200); do [ -s "$PORT_FILE" ] && break; sleep 0.05; done
[ -s "$PORT_FILE" ] || { echo "server_flow: stickslipd did not start" >&2; exit 1; }
URL="http://127.0.0.1:$(cat "$PORT_FILE")"
echo "server_flow: stickslipd at $URL (open $URL/ in a browser for the dashboard while it runs)" >&2

set +e
OUT=$("$BIN/client/stickslip" submit "$SPEC" --wait --server "$URL")  # progress on stderr
STATUS=$?
set -e
echo "$OUT"
ID=$(echo "$OUT" | head -1)
[ -n "$ID" ] || exit "$STATUS"
"$BIN/client/stickslip" map "$ID" --server "$URL"
exit "$STATUS"

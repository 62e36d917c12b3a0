#!/usr/bin/env bash
# README command 1: all set-up, then the main job: start stickslipd on the embedded SQLite store,
# submit studies/paper-map.json with the client, wait with a progress bar, print the stick-slip
# map (amplitude per stage against v_a/v_d, one column per model), and stop the server cleanly.
#   bash scripts/main.sh [SPEC] [DB]     (defaults: studies/paper-map.json, ./stickslip.db)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
exec bash scripts/server_flow.sh "$@"

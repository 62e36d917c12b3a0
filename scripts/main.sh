#!/usr/bin/env bash
# README command 1: all set-up, then the main job. For now: the per-stage table of the seed's
# four friction models at v_a = 0, 0.2, 1.1 and 4 mm/s (10 s still base + 10 s vibrating).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
./build/client/stickslip table

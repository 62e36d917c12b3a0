#!/usr/bin/env bash
# README command 2: all set-up, then every test (CTest runs the GoogleTest suites).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j"$(nproc)" --timeout 600

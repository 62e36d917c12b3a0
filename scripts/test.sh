#!/usr/bin/env bash
# README command 2: all set-up, then every test (CTest runs the GoogleTest suites).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
# The fuzz sub-build (a CTest fixture) compiles through the same ccache as the main build.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
ctest --test-dir build --output-on-failure -j"$(nproc)" --timeout 600

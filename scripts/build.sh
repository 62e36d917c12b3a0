#!/usr/bin/env bash
# Installs dependencies (if missing) and builds everything in ./build (Release).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSTICKSLIP_REQUIRE_MPI=ON
cmake --build build -j"$(nproc)"

#!/usr/bin/env bash
# Installs dependencies (if missing) and builds everything in ./build (Release).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
# ccache (when present) keys objects by paths relative to this checkout, so a fresh clone
# elsewhere reuses what an earlier build compiled; a cold cache only costs the first build.
launcher=()
if command -v ccache >/dev/null; then
  export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DSTICKSLIP_REQUIRE_MPI=ON "${launcher[@]}"
cmake --build build -j"$(nproc)"

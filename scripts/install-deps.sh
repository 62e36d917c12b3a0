#!/usr/bin/env bash
# Installs every Debian 12 package stickslip needs to build, test and run.
# Idempotent: when every package is already installed it does nothing (no apt-get update either).
set -euo pipefail

PACKAGES=(
  build-essential cmake g++ pkg-config git
  ccache                   # compiler cache: rebuilds in a fresh clone reuse earlier objects
  libeigen3-dev            # linear algebra (calibration Jacobians, covariance)
  libboost-dev             # Asio, Beast, Math, Random (header-only parts)
  nlohmann-json3-dev       # JSON
  libsqlite3-dev sqlite3   # store; sqlite3 shell for inspection
  libgtest-dev libgmock-dev # GoogleTest
  libbenchmark-dev         # Google Benchmark
  libvalijson-dev          # JSON Schema validation
  libcli11-dev             # command line
  libspdlog-dev            # logging
  libnlopt-cxx-dev         # derivative-free optimisation
  openmpi-bin libopenmpi-dev # studies across machines (mpirun stickslip ..., --launcher; docs/scale.md)
  gnuplot-nox              # report plots
  python3                  # report tests: html.parser/xml.dom check of the page (stdlib only)
  curl                     # end-to-end tests drive the server with curl
  jq                       # the curl examples of POST /v1/diagnoses (docs/server.md, README)
  wrk                      # HTTP load benchmark
  chromium chromium-driver # the dashboard's browser tests (tests/browser): headless Chromium
  python3-selenium         # ... driven through chromium-driver; run with /usr/bin/python3
  fonts-dejavu-core        # ... so the pages render with real glyphs in the screenshots
  clang libfuzzer-14-dev   # the fuzz harnesses (tests/fuzz): clang and libFuzzer, and
  libclang-rt-14-dev       # ... the runtimes of -fsanitize=fuzzer,address,undefined (only
                           #     recommended by clang, and we install without recommends)
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"

#!/usr/bin/env bash
# The fuzz sub-build and runs (tests/fuzz/README.md), called by CTest (tests/CMakeLists.txt):
#   fuzz.sh build SRC_DIR FUZZ_BUILD_DIR [COMPILER_LAUNCHER]
#       configures SRC_DIR with clang++ and STICKSLIP_FUZZ=ON into FUZZ_BUILD_DIR (every library
#       instrumented for libFuzzer, AddressSanitizer and UndefinedBehaviorSanitizer) and builds the
#       `fuzzers` target. The ordinary g++ build is not touched.
#   fuzz.sh run SRC_DIR FUZZ_BUILD_DIR TARGET
#       runs fuzz_TARGET for STICKSLIP_FUZZ_SECONDS seconds (default 60) on the seeds of
#       SRC_DIR/tests/fuzz/corpus/TARGET (read only) plus what earlier runs found (kept in
#       FUZZ_BUILD_DIR/corpus/TARGET); a crash, leak, timeout or broken property fails it and
#       leaves the input in FUZZ_BUILD_DIR/artifacts/TARGET/. The last line gives the number of
#       executions.
set -euo pipefail
mode=$1 src=$2 bin=$3

if [ "$mode" = build ]; then
  launcher=${4:-}
  flags="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined"
  flags+=" -O1 -gline-tables-only -fno-omit-frame-pointer"
  args=(-S "$src" -B "$bin" -DSTICKSLIP_FUZZ=ON -DCMAKE_BUILD_TYPE=Fuzz
        -DCMAKE_CXX_COMPILER=clang++ "-DCMAKE_CXX_FLAGS=$flags"
        "-DCMAKE_EXE_LINKER_FLAGS=-fsanitize=address,undefined")
  if [ -n "$launcher" ]; then args+=("-DCMAKE_CXX_COMPILER_LAUNCHER=$launcher"); fi
  cmake "${args[@]}" >"$bin.configure.log" 2>&1 || { cat "$bin.configure.log"; exit 1; }
  exec cmake --build "$bin" --target fuzzers -j"$(nproc)"
fi

target=$4
exe="$bin/tests/fuzz/fuzz_$target"
[ -x "$exe" ] || { echo "fuzz.sh: $exe is missing (did fuzz.build run?)"; exit 1; }
seconds=${STICKSLIP_FUZZ_SECONDS:-60}
work="$bin/corpus/$target"
artifacts="$bin/artifacts/$target"
mkdir -p "$work" "$artifacts"
dict=()
if [ -f "$src/tests/fuzz/$target.dict" ]; then dict=("-dict=$src/tests/fuzz/$target.dict"); fi
log="$bin/$target.log"
set +e
"$exe" -max_total_time="$seconds" -timeout=25 -rss_limit_mb=2560 -max_len=65536 \
  -print_final_stats=1 -artifact_prefix="$artifacts/" "${dict[@]}" \
  "$work" "$src/tests/fuzz/corpus/$target" >"$log" 2>&1
rc=$?
set -e
if [ $rc -ne 0 ]; then
  tail -n 60 "$log"
  echo "fuzz.sh: fuzz_$target failed (exit $rc); the input is in $artifacts/"
  exit $rc
fi
execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 || true)
echo "fuzz_$target: ${execs:-?} executions in ${seconds} s, ${cov:-cov: ?}, corpus $(ls "$work" | wc -l) + $(ls "$src/tests/fuzz/corpus/$target" | wc -l) seeds"

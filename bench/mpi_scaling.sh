#!/usr/bin/env bash
# Efficiency from 1 to 2 MPI worker ranks (docs/scale.md), side by side with OpenMP, on one
# study (default: the paper map, studies/paper-map.json; 204 adaptive runs):
#   omp1  stickslip study run --threads 1                       (one process, one thread)
#   mpi1  mpirun -np 2 stickslip study run --threads 1          (rank 0 + 1 worker rank)
#   mpi2  mpirun -np 3 stickslip study run --threads 1          (rank 0 + 2 worker ranks)
#   omp2  stickslip study run --threads 2
# and prints E(1 -> 2 ranks) = T(mpi1) / (2 T(mpi2)), the MPI path's cost T(mpi1) / T(omp1),
# and the study's own wall times (the runner's, without mpirun's start-up) beside the whole
# command's. Not a test: ~5 minutes on the 2-core machine. Run it alone: the ranks of mpi2 and
# the master share 2 cores (rank 0 sleeps while it waits).
#
# Usage: bench/mpi_scaling.sh [BUILD_DIR] [SPEC]
set -euo pipefail
src="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$src/build}"
spec="${2:-$src/studies/paper-map.json}"
bin="$build/client/stickslip"
[ -x "$bin" ] || { echo "no $bin; build first" >&2; exit 2; }
work="$(mktemp -d /tmp/stickslip-mpi-scaling.XXXXXX)"
trap 'rm -rf "$work"' EXIT
# Only for this script's own mpirun calls (CI and containers run as root).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl_vader_single_copy_mechanism=none
mpirun=(mpirun --oversubscribe --bind-to none)
echo "spec $spec; load before: $(cut -d' ' -f1-3 /proc/loadavg)"

run() {  # name, command...: prints "name command_s study_s"
  local name=$1; shift
  local t0 t1 study
  t0=$(date +%s.%N)
  "$@" "$spec" --db "$work/$name.db" --quiet --json > "$work/$name.json"
  t1=$(date +%s.%N)
  study=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['wall_s'])" "$work/$name.json")
  echo "$name $(echo "$t1 - $t0" | bc -l) $study"
}

{
  run omp1 "$bin" study run --threads 1
  run mpi1 "${mpirun[@]}" -np 2 "$bin" study run --threads 1
  run mpi2 "${mpirun[@]}" -np 3 "$bin" study run --threads 1
  run omp2 "$bin" study run --threads 2
} | tee "$work/times"
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
python3 - "$work/times" "$work/omp1.db" <<'PY'
import sqlite3, sys
t = {}
for line in open(sys.argv[1]):
    name, cmd, study = line.split()
    t[name] = (float(cmd), float(study))
print(f"{'config':6} {'command [s]':>12} {'study [s]':>10}")
for k, (c, s) in t.items():
    print(f"{k:6} {c:12.2f} {s:10.2f}")
for i, label in ((0, "command"), (1, "study")):
    e_mpi = t['mpi1'][i] / (2 * t['mpi2'][i])
    e_omp = t['omp1'][i] / (2 * t['omp2'][i])
    cost = t['mpi1'][i] / t['omp1'][i]
    print(f"{label:8}: E(1->2 ranks) = {100*e_mpi:.1f} %   E(1->2 threads) = {100*e_omp:.1f} %"
          f"   T(mpi1)/T(omp1) = {cost:.3f}")
# The runs' own times (one thread each), for the projection in docs/scale.md.
w = sorted(r[0] for r in sqlite3.connect(sys.argv[2]).execute("SELECT wall_time_s FROM runs"))
print(f"runs: {len(w)}; time a run [s]: mean {sum(w)/len(w):.3f}, median {w[len(w)//2]:.3f}, "
      f"max {w[-1]:.3f}, sum {sum(w):.1f}")
PY

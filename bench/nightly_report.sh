#!/usr/bin/env bash
# Times the shipped nightly report (reports/nightly.json) on this machine: a cold run into a fresh
# database (every study computed), then a warm run on the next date (every study reused by spec
# hash, only summary + plots), then prints the Sobol confidence-interval widths that justify N.
# The issue's target: the cold run completes in <= 30 minutes on the 2-core machine.
#
# Usage: bench/nightly_report.sh [BUILD_DIR] [WORK_DIR]
#   BUILD_DIR default: build; WORK_DIR default: a new directory under /tmp (kept, printed).
# Not a test: it takes ~15-25 minutes. Run it alone (other jobs on the machine slow it down).
set -euo pipefail
src="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$src/build}"
work="${2:-$(mktemp -d /tmp/stickslip-nightly-bench.XXXXXX)}"
bin="$build/client/stickslip"
[ -x "$bin" ] || { echo "no $bin; build first" >&2; exit 2; }
mkdir -p "$work"
echo "work dir: $work   (load before: $(cut -d' ' -f1-3 /proc/loadavg))"

t0=$(date +%s.%N)
/usr/bin/time -f "cold: %e s wall, %U s user, %M kB max RSS" \
  "$bin" report --config "$src/reports/nightly.json" --out "$work/out" --db "$work/nightly.db" \
  --date 2000-01-01 --quiet
t1=$(date +%s.%N)
/usr/bin/time -f "warm: %e s wall, %U s user, %M kB max RSS" \
  "$bin" report --config "$src/reports/nightly.json" --out "$work/out" --db "$work/nightly.db" \
  --date 2000-01-02 --quiet
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"

python3 - "$work/out/2000-01-01/summary.json" "$work/out/2000-01-02/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
print("per entry: runs, computed, wall [s], CPU-s of the runs")
for k in s["entry_order"]:
    e = s["entries"][k]
    print(f"  {k:8s} {e['counts']['total']:6d} {e['run']['computed']:6d} "
          f"{e['run']['wall_s']:8.1f} {e['run']['compute_s']:8.1f}  failed {e['counts']['failed']}")
for k in s["entry_order"]:
    ind = s["entries"][k].get("indices")
    if not ind:
        continue
    print(f"{k}: {ind['method']}, valid {ind['valid']}")
    for o in ind["outputs"]:
        if not o["valid"]:
            print(f"  {o['output']}: INVALID {o['reason']}")
            continue
        if ind["method"] == "sobol":
            w1 = [x["S1_ci"][1] - x["S1_ci"][0] for x in o["indices"]]
            wt = [x["ST_ci"][1] - x["ST_ci"][0] for x in o["indices"]]
            print(f"  {o['output']}: widest S1 interval {max(w1):.3f}, widest ST interval {max(wt):.3f}")
            for x in sorted(o["indices"], key=lambda x: -x["ST"]):
                print(f"    {x['parameter']:4s} S1 {x['S1']:+.3f} [{x['S1_ci'][0]:+.3f},{x['S1_ci'][1]:+.3f}]"
                      f"  ST {x['ST']:.3f} [{x['ST_ci'][0]:.3f},{x['ST_ci'][1]:.3f}]")
        else:
            for x in sorted(o["indices"], key=lambda x: -x["mu_star"]):
                print(f"    {x['parameter']:4s} mu* {x['mu_star']:.4g} [{x['mu_star_ci'][0]:.4g},"
                      f"{x['mu_star_ci'][1]:.4g}] sigma {x['sigma']:.4g}")
w = json.load(open(sys.argv[2]))
print(f"warm report: {w['changes']['flagged']} change(s) flagged against {w['changes']['previous_date']}")
PY

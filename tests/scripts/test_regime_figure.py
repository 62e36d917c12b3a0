#!/usr/bin/env python3
"""scripts/regime_figure.py on a small hand-written diagnosis: the data file holds one block per
drive velocity, the runs in k_d order, the measured/fitted/held-out statistics taken from the
right parts (the first stage's fitted window; the held-out fold of the same run) and the regime
letters; the figure is written; a diagnosis without statistics for the manifest's runs is refused.

Usage: test_regime_figure.py SCRIPT WORKDIR
"""
import json
import os
import subprocess
import sys


def stats(drop, rate, regime):
    return {"drop_median": drop, "drop_q25": drop * 0.8, "drop_q75": drop * 1.2, "rate": rate,
            "regime": regime}


def entry(run, stage, part, m, b):
    return {"run": run, "stage": stage, "part": part, "measured": m, "base": b, "extended": b}


def main(script, work):
    os.makedirs(work, exist_ok=True)
    runs = [("soft_slow", 100.0, 1e-5), ("stiff_slow", 1000.0, 1e-5), ("soft_fast", 100.0, 1e-2)]
    manifest = {"name": "t", "runs": [{"name": n, "file": n + ".csv",
                                       "conditions": {"kd": k, "vd": v}} for n, k, v in runs]}
    statistics, folds = [], []
    for i, (n, _, _) in enumerate(runs):
        regime = "inertial" if n == "soft_fast" else "stick_slip"
        m = stats(0.01 * (i + 1), 1.0 + i, regime)
        statistics.append(entry(n, 1, "fitted", m, stats(0.02 * (i + 1), 2.0 + i, regime)))
        # A later stage and the held-out part must not be the ones plotted.
        statistics.append(entry(n, 1, "held_out", m, stats(9.0, 9.0, "creep")))
        statistics.append(entry(n, 2, "fitted", m, stats(8.0, 8.0, "creep")))
        folds.append({"run": n, "statistics": [entry(n, 1, "fitted", m, stats(0.03 * (i + 1), 3.0 + i, "creep"))]})
    diagnosis = {"base_model": "lugre", "statistics": statistics, "heldout_runs": {"folds": folds}}
    dpath, mpath = os.path.join(work, "d.json"), os.path.join(work, "m.json")
    json.dump(diagnosis, open(dpath, "w"))
    json.dump(manifest, open(mpath, "w"))
    png = os.path.join(work, "regime.png")
    subprocess.run([sys.executable, script, dpath, mpath, png], check=True)
    assert os.path.getsize(png) > 1000, "no figure"
    blocks = [b for b in open(os.path.join(work, "regime.dat")).read().split("\n\n\n") if b.strip()]
    rows = [[l.split() for l in b.strip().splitlines() if not l.startswith("#")] for b in blocks]
    assert len(rows) == 2, rows  # two drive velocities
    assert [r[0] for r in rows[0]] == ["soft_slow", "stiff_slow"], rows[0]  # k_d order
    soft = rows[0][0]
    assert abs(float(soft[3]) - 0.01) < 1e-12 and abs(float(soft[6]) - 0.02) < 1e-12, soft
    assert abs(float(soft[7]) - 0.03) < 1e-12 and abs(float(soft[10]) - 3.0) < 1e-12, soft
    assert soft[11] == "S/S/C", soft
    assert rows[1][0][0] == "soft_fast" and rows[1][0][11] == "I/I/C", rows[1]
    # No statistics for the manifest's runs: refused with exit 1 and a message.
    json.dump({"statistics": [], "base_model": "lugre"}, open(dpath, "w"))
    r = subprocess.run([sys.executable, script, dpath, mpath, png], capture_output=True, text=True)
    assert r.returncode == 1 and "no run" in r.stderr, (r.returncode, r.stderr)
    print("ok")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])

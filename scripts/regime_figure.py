#!/usr/bin/env python3
"""The measured and predicted stick-slip regime and statistics across the runs of a diagnosis.

Usage: scripts/regime_figure.py DIAGNOSIS.json MANIFEST.json OUT.png

Reads `stickslip diagnose`'s diagnosis.json and the manifest it was made from (the runs' drive
stiffness k_d [N/m] and velocity v_d [m/s]). For every run's first stage (fitted window) it
plots, against k_d, one panel per drive velocity:
  * top: the median force drop [N], measured (bar: quartiles), predicted by the calibrated base
    model, and predicted with the run held out (the whole-run fold: refitted on the other runs);
  * bottom: the drop rate [1/s], the same three.
Each measured point is labelled with its regime (S stick-slip, C creep, I inertial, - none) as
measured / fitted / held out. Writes OUT.png (gnuplot, pngcairo) and, beside it, OUT.dat and
OUT.gp, so the figure can be remade or restyled. Standard library only (json, subprocess).
"""
import json
import os
import subprocess
import sys

LETTER = {"stick_slip": "S", "creep": "C", "inertial": "I", "steady": "-", "none": "-"}


def first_stage(stats, run, part="fitted"):
    rows = [s for s in stats if s["run"] == run and s["part"] == part]
    if not rows:
        return None
    return min(rows, key=lambda s: s["stage"])


def rows_of(diagnosis, manifest):
    cond = {r["name"]: r["conditions"] for r in manifest["runs"]}
    folds = {f["run"]: f for f in diagnosis.get("heldout_runs", {}).get("folds", [])}
    out = []
    for run in cond:
        fitted = first_stage(diagnosis["statistics"], run)
        if fitted is None:
            continue
        fold = folds.get(run)
        held = first_stage(fold["statistics"], run) if fold else None
        m, b = fitted["measured"], fitted["base"]
        h = held["base"] if held else None
        nan = float("nan")
        out.append({
            "run": run, "kd": cond[run]["kd"], "vd": cond[run]["vd"],
            "m_drop": m["drop_median"], "m_q25": m["drop_q25"], "m_q75": m["drop_q75"],
            "b_drop": b["drop_median"], "h_drop": h["drop_median"] if h else nan,
            "m_rate": m["rate"], "b_rate": b["rate"], "h_rate": h["rate"] if h else nan,
            "label": "/".join(LETTER.get(x["regime"], "?") for x in (m, b, h) if x is not None),
        })
    return out


def write_data(rows, path):
    with open(path, "w") as f:
        f.write("# run kd[N/m] vd[m/s] drop_meas q25 q75 drop_base drop_heldout "
                "rate_meas rate_base rate_heldout regime(meas/fit/held)\n")
        for vd in sorted({r["vd"] for r in rows}):
            for r in sorted((r for r in rows if r["vd"] == vd), key=lambda r: r["kd"]):
                f.write("%s %g %g %.6g %.6g %.6g %.6g %.6g %.6g %.6g %.6g %s\n" % (
                    r["run"], r["kd"], r["vd"], r["m_drop"], r["m_q25"], r["m_q75"], r["b_drop"],
                    r["h_drop"], r["m_rate"], r["b_rate"], r["h_rate"], r["label"]))
            f.write("\n\n")  # one gnuplot data block per drive velocity


def gnuplot_script(rows, dat, png, base_model):
    vds = sorted({r["vd"] for r in rows})
    lines = [
        "set terminal pngcairo size %d,720 font ',10'" % (420 * len(vds) + 80),
        "set output '%s'" % png,
        "set multiplot layout 2,%d title 'Measured and predicted stick-slip (%s; first stage; "
        "labels: regime measured/fitted/held out, S stick-slip, I inertial, C creep)' noenhanced"
        % (len(vds), base_model),
        "set logscale x", "set xlabel 'k_d [N/m]'", "set grid", "set key top left font ',8'",
        "set xrange [100:4000]",
    ]
    for what, col_m, col_b, col_h, ylabel in (
            ("drop", 4, 7, 8, "median drop [N]"), ("rate", 9, 10, 11, "drops per second [1/s]")):
        for i, vd in enumerate(vds):
            lines.append("set ylabel '%s'" % ylabel)
            lines.append("set title 'v_d = %g mm/s'" % (vd * 1e3))
            lines.append("set logscale y" if what == "rate" else "unset logscale y")
            meas = ("'%s' index %d using 2:%d:5:6 with yerrorbars pt 7 lc rgb 'black' title "
                    "'measured (quartiles)'" % (dat, i, col_m)) if what == "drop" else (
                "'%s' index %d using 2:%d with points pt 7 lc rgb 'black' title 'measured'"
                % (dat, i, col_m))
            lines.append(
                "plot " + meas +
                ", '' index %d using 2:%d with linespoints pt 4 lc rgb 'blue' title 'fitted'"
                % (i, col_b) +
                ", '' index %d using 2:%d with linespoints pt 6 dt 2 lc rgb 'red' "
                "title 'whole run held out'" % (i, col_h) +
                ", '' index %d using 2:%d:12 with labels offset 2.5,1.0 font ',8' notitle"
                % (i, col_m))
    lines.append("unset multiplot")
    return "\n".join(lines) + "\n"


def main(argv):
    if len(argv) != 4:
        sys.stderr.write(__doc__)
        return 2
    with open(argv[1]) as f:
        diagnosis = json.load(f)
    with open(argv[2]) as f:
        manifest = json.load(f)
    rows = rows_of(diagnosis, manifest)
    if not rows:
        sys.stderr.write("regime_figure: no run of %s has statistics in %s\n" % (argv[2], argv[1]))
        return 1
    png = argv[3]
    stem = os.path.splitext(png)[0]
    write_data(rows, stem + ".dat")
    with open(stem + ".gp", "w") as f:
        f.write(gnuplot_script(rows, os.path.basename(stem) + ".dat", os.path.basename(png),
                               diagnosis.get("base_model", "?")))
    subprocess.run(["gnuplot", os.path.basename(stem) + ".gp"], check=True,
                   cwd=os.path.dirname(os.path.abspath(png)))
    print("wrote %s, %s.dat, %s.gp" % (png, stem, stem))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

#!/usr/bin/env python3
"""Projected efficiency of a study on P MPI ranks (docs/scale.md, "Projection").

Inputs are the measured figures (bench/mpi_ingest, bench/mpi_scaling.sh, docs/studies.md):
rank 0's ingest ceiling R0 [runs/s], the thread-seconds of a run t and of the slowest run t_max,
the MPI path's cost against OpenMP (T(mpi1)/T(omp1)), the bytes a run costs in messages, and
the launch time of the job. Rank 0 computes nothing: P ranks are P - 1 workers of one thread.

  T(P) = max(N t c / (P - 1), N / R0, N b / B) + tail + launch(P)
  tail = t_max while there are more runs than workers, else 0 (and T >= t_max)
  E(P) = (N t / P) / T(P)        (the ideal time of P cores over the time taken)

Usage: bench/mpi_projection.py [--r0 6000] [--t 0.388] [--tmax 0.95] ...
"""
import argparse
import math

p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
p.add_argument("--r0", type=float, default=6000, help="rank 0's ingest ceiling [runs/s]")
p.add_argument("--t", type=float, default=0.388, help="thread-seconds of a paper-map run [s]")
p.add_argument("--tmax", type=float, default=0.95, help="thread-seconds of its slowest run [s]")
p.add_argument("--cost", type=float, default=1.0, help="T(mpi1) / T(omp1), the MPI path's cost")
p.add_argument("--bytes", type=float, default=269, help="message bytes a run (result + chunk)")
p.add_argument("--bandwidth", type=float, default=1e9, help="rank 0's network [bytes/s]")
p.add_argument("--launch3", type=float, default=0.6, help="launch + finalize of 3 ranks [s]")
a = p.parse_args()


def launch(ranks):
    # Measured for 3 ranks on one node; beyond it an assumption: Open MPI starts its daemons
    # in a tree, so the time grows with log2 of the ranks (0.6 s, 1.8 s at 64, 2.5 s at 1024 ...).
    return a.launch3 * (1 + 0.5 * math.log2(max(ranks, 3) / 3))


def project(n, ranks):
    workers = ranks - 1
    compute = n * a.t * a.cost / workers
    if n > workers:
        compute += a.tmax
    compute = max(compute, a.tmax)
    bound0 = n / a.r0
    net = n * a.bytes / a.bandwidth
    t = max(compute, bound0, net)
    ideal = n * a.t / ranks
    return ideal / (t + launch(ranks)), ideal / t, n / t / a.r0, "rank 0" if bound0 >= compute else "compute"


print(f"R0 = {a.r0:.0f} runs/s, t = {a.t} s, t_max = {a.tmax} s; rank 0 is the bottleneck beyond "
      f"P = R0 t + 1 = {a.r0 * a.t + 1:.0f} ranks")
print(f"{'study':>22} {'ranks':>6} {'E':>7} {'E (no launch)':>14} {'rank 0 busy':>12}  bound")
for name, n in (("paper map (204 runs)", 204), ("100,000 runs", 100000)):
    for ranks in (16, 64, 256, 1024):
        e, e0, busy, bound = project(n, ranks)
        print(f"{name:>22} {ranks:6d} {100 * e:6.1f}% {100 * e0:13.1f}% {100 * min(busy, 1):11.1f}%  {bound}")

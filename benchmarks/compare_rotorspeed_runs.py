"""Paired difference of two ``eval_rotorspeed.py --json`` runs on the same flights.

For the CPIs with two or more visible pairs in both runs: the share of CPIs whose mean
rotor speed is within 1 % of the truth, and the share within 2 reported sigma, before
and after, with the paired difference's 95 % interval from a flight bootstrap (the
flight is the unit; the same draws for both runs).

    .venv/bin/python benchmarks/compare_rotorspeed_runs.py before.json after.json
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from microdoppler.stats.bootstrap import draw_flights, interval, ratio_replicates


def load(path) -> dict:
    with open(path) as fh:
        return {r["flight"]: r for r in json.load(fh)["flights"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before")
    ap.add_argument("after")
    args = ap.parse_args(argv)
    a, b = load(args.before), load(args.after)
    flights = sorted(set(a) & set(b))
    if set(a) != set(b):
        print(f"flights in one run only: {sorted(set(a) ^ set(b))}")
    rows = {"within 1 %": ([], []), "within 2 sigma": ([], [])}
    den = []
    for f in flights:
        ea, eb = np.abs(np.asarray(a[f]["mean_err"], float)), np.abs(np.asarray(b[f]["mean_err"], float))
        za, zb = np.abs(np.asarray(a[f]["z"], float)), np.abs(np.asarray(b[f]["z"], float))
        n = min(len(ea), len(eb))
        sel = (
            (np.asarray(a[f]["n_pairs"])[:n] >= 2)
            & (np.asarray(b[f]["n_pairs"])[:n] >= 2)
            & np.isfinite(ea[:n])
            & np.isfinite(eb[:n])
        )
        den.append(float(sel.sum()))
        rows["within 1 %"][0].append(float(np.sum(ea[:n][sel] <= 0.01)))
        rows["within 1 %"][1].append(float(np.sum(eb[:n][sel] <= 0.01)))
        rows["within 2 sigma"][0].append(float(np.sum(za[:n][sel] <= 2)))
        rows["within 2 sigma"][1].append(float(np.sum(zb[:n][sel] <= 2)))
    den = np.array(den)
    draws = draw_flights(flights, seed=0)
    print(f"{len(flights)} flights, {int(den.sum())} CPIs with >= 2 pairs in both runs")
    print("| measure | before | after | after - before (95 % CI, flights) | flights better / worse |")
    print("|---|---|---|---|---|")
    for name, (na, nb) in rows.items():
        na, nb = np.array(na), np.array(nb)
        ra, rb = ratio_replicates(na, den, draws), ratio_replicates(nb, den, draws)
        (la, ha), (lb, hb), (ld, hd) = interval(ra), interval(rb), interval(rb - ra)
        print(
            f"| {name} | {100 * na.sum() / den.sum():.1f} % [{100 * la:.1f}, {100 * ha:.1f}] "
            f"| {100 * nb.sum() / den.sum():.1f} % [{100 * lb:.1f}, {100 * hb:.1f}] "
            f"| {100 * (nb.sum() - na.sum()) / den.sum():+.2f} [{100 * ld:+.2f}, {100 * hd:+.2f}] points "
            f"| {int(np.sum(nb > na))} / {int(np.sum(nb < na))} |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Score a pipeline run's diagnosis report against the emulator's key.

Per drone flight of ``results/diagnosis/report.json``: the causes the key says the
flight carries (``results/emulator/key.json``, effects) against the causes the
diagnosis named, and for every cause named where it is true, the error of its main
parameter (catalog units). Flights the diagnosis skipped are listed apart; the key's
``truth.weak_blades`` (blades 30-50 dB under the body: no line to see) is shown per
flight.

    python benchmarks/score_world_key.py RUN_DIR [--cause blade_imbalance] [--json out.json]

Prints per cause: flights carrying it (all / with visible blades), named, named
where absent, and the parameter errors; then, for ``--cause``, one line per flight.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from microdoppler.causes.catalog import CAUSES


def score(run_dir) -> dict:
    run = Path(run_dir)
    key = json.loads((run / "results/emulator/key.json").read_text())
    rep = json.loads((run / "results/diagnosis/report.json").read_text())
    out = {"flights": {}, "causes": {}}
    for f in rep["flights"]:
        fid = f["flight_id"]
        k = key["flights"].get(fid)
        if k is None:
            continue
        truth = k["effects"]
        named = {
            c["cause"]: ((c.get("extension") or {}).get("params") or c.get("params") or {}) for c in f.get("causes", [])
        }
        out["flights"][fid] = {
            "skipped": f.get("cause") == "skipped",
            "truth": truth,
            "named": named,
            "weak_blades": bool(k["truth"].get("weak_blades", False)),
            "airframe": k.get("airframe", ""),
            "not_testable": f.get("not_testable", {}),
        }
    for cause, c in CAUSES.items():
        if cause == "none":
            continue
        p = c.main_param
        rows = [r for r in out["flights"].values() if not r["skipped"]]
        has = [r for r in rows if cause in r["truth"]]
        hit = [r for r in has if cause in r["named"]]
        errs = [
            r["named"][cause][p] - r["truth"][cause][p]
            for r in hit
            if p in r["named"][cause] and r["named"][cause][p] is not None and np.isfinite(r["named"][cause][p])
        ]
        out["causes"][cause] = {
            "true": len(has),
            "true_visible_blades": sum(not r["weak_blades"] for r in has),
            "named_where_true": len(hit),
            "named_where_true_visible": sum(not r["weak_blades"] for r in hit),
            "named_where_absent": sum(cause in r["named"] and cause not in r["truth"] for r in rows),
            "absent": sum(cause not in r["truth"] for r in rows),
            f"{p}_errors": [round(float(e), 4) for e in errs],
        }
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--cause", default="blade_imbalance")
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    s = score(a.run_dir)
    print(f"{'cause':22s} true (visible blades)  named where true (visible)  named where absent / absent  errors")
    for cause, c in s["causes"].items():
        e = next(v for k, v in c.items() if k.endswith("_errors"))
        print(
            f"{cause:22s} {c['true']:4d} ({c['true_visible_blades']:2d})            {c['named_where_true']:4d} "
            f"({c['named_where_true_visible']:2d})                 {c['named_where_absent']:3d} / {c['absent']:3d}"
            f"        {e}"
        )
    p = CAUSES[a.cause].main_param
    print(f"\n{a.cause}: per flight")
    for fid, r in sorted(s["flights"].items()):
        if a.cause in r["truth"] or a.cause in r["named"]:
            t = r["truth"].get(a.cause, {}).get(p)
            n = r["named"].get(a.cause, {}).get(p)
            print(
                f"  {fid:18s} airframe {r['airframe']:13s} weak_blades {r['weak_blades']!s:5s} skipped "
                f"{r['skipped']!s:5s} truth {t} named {n}  causes named {list(r['named'])}"
            )
    if a.json:
        Path(a.json).write_text(json.dumps(s, indent=1, default=float))


if __name__ == "__main__":
    main()

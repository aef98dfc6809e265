"""The two-sided goodness of fit on the wrong set-ups the import accepted (issue 56; not run in CI).

Remakes recordings of ``eval_wrong_setups.py --seed 41000 --diagnose`` (12 s each: the
any-radar generator's seeds 41000-41023, the independent generator's 41500-41507),
imports each with ``--estimate-motors`` once with its true set-up and, for the wrong
set-ups that read ``none`` in ``records/eval_wrong_setups_seed41000_diagnose.json``,
once with that wrong field, keeps the stores in ``--stores`` and diagnoses them with
this code. Run it once per code version (``PYTHONPATH``) with the same ``--stores`` (the
stores are made once) and compare the two JSON files: each store's causes, and the
two-sided check's lines (``missing``) and reason, and the declared fields the
recording cannot test (``setup_not_testable``: a wrong set-up reading ``none`` should
name its wrong field there). ``--names`` restricts the recordings.
About 1-2 minutes per recording for the imports (estimate mode), seconds per diagnosis.

    git worktree add ../before <older commit>     # the code to compare with, beside this checkout
    PYTHONPATH=src python benchmarks/eval_two_sided.py --stores two_sided_stores --json after.json
    PYTHONPATH=../before/src python benchmarks/eval_two_sided.py --stores two_sided_stores --json before.json

(run from the repository root; ``two_sided_stores/`` is made on the first run and reused.)
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

import eval_wrong_setups as E  # noqa: E402
from any_radar import draw_case, make_recording  # noqa: E402
from independent_generator import GenCase, make_flight  # noqa: E402

#: the wrong set-ups the import accepted that read ``none`` at the start of issue 56
NONE_BEFORE = {
    "any41008": "prf x2",
    "any41010": "carrier x2",
    "any41013": "blade_length x0.5",
    "any41016": "carrier x0.5",
    "any41019": "blade_length x2",
    "gen41501": "n_blades 2<->3",
    "gen41503": "blade_length x0.5",
}
NAMES = [f"any{41000 + i}" for i in range(24)] + [f"gen{41500 + i}" for i in range(8)]


def recording(name: str):
    if name.startswith("any"):
        flight, _ = make_recording(draw_case(int(name[3:]), duration_s=12.0))
        return flight
    seed = int(name[3:])
    i = seed - 41500
    eff = {"blade_imbalance": {"imbalance_db": 6.0}} if i % 3 == 2 else {}
    flight, _ = make_flight(
        GenCase(flight_id=name, seed=seed, radar=("gen_l", "gen_s")[i % 2], effects=eff, duration_s=12.0)
    )
    return flight


def make_stores(names, stores: Path) -> None:
    for name in names:
        kinds = {"right": None, **({"wrong": NONE_BEFORE[name]} if name in NONE_BEFORE else {})}
        if all((stores / f"{name}_{tag}.zarr").exists() for tag in kinds):
            continue
        path, decl, fixed = E.write_recording(recording(name), Path(tempfile.mkdtemp()) / name)
        for tag, kind in kinds.items():
            out = stores / f"{name}_{tag}.zarr"
            argv = ["import", path, *E.declared(decl, kind), *fixed, "--quiet", "--estimate-motors"]
            rc, msg, _ = E.run_import([*argv, "--out", out, "--overwrite"])
            print(f"{name} {tag} ({kind}): import rc {rc} {msg}", file=sys.stderr, flush=True)


def diagnose_stores(stores: Path) -> dict:
    from microdoppler.diagnosis import diagnose_flight
    from microdoppler.diagnosis.measure import Undiagnosable
    from microdoppler.io.flightzarr import read_flight

    out = {}
    for p in sorted(stores.glob("*.zarr")):
        try:
            e = diagnose_flight(read_flight(p), config={"figures": False})
        except Undiagnosable as exc:
            out[p.stem] = {"causes": ["skipped"], "reason": exc.reason}
            continue
        g = e["evidence"]["goodness_of_fit"]
        out[p.stem] = {
            "causes": [c["cause"] for c in e["causes"]],
            "missing": [[m["order"], m["side"], m["direction"]] for m in g.get("missing", [])],
            "reason": g.get("missing_reason", ""),
            "setup_not_testable": sorted(e.get("setup_not_testable") or {}),
        }
        print(p.stem, out[p.stem], file=sys.stderr, flush=True)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--stores", type=Path, required=True)
    ap.add_argument("--json", type=Path, required=True)
    ap.add_argument("--names", nargs="*", default=NAMES)
    a = ap.parse_args(argv)
    a.stores.mkdir(parents=True, exist_ok=True)
    make_stores(a.names, a.stores)
    res = diagnose_stores(a.stores)
    wrong = {k: v for k, v in res.items() if k.endswith("_wrong")}
    right = {k: v for k, v in res.items() if k.endswith("_right") and v["causes"] != ["skipped"]}
    field = {"prf": "prf_hz", "carrier": "carrier_hz", "blade_length": "blade_length_m", "n_blades": "n_blades"}

    def flagged(k: str, v: dict) -> bool:
        """A wrong set-up reading none that names its wrong field as not testable."""
        wrong_field = field[NONE_BEFORE[k.removesuffix("_wrong")].split()[0]]
        return v["causes"] == [] and wrong_field in v.get("setup_not_testable", [])

    summary = {
        "wrong_read_none": sum(v["causes"] == [] for v in wrong.values()),
        "wrong_read_none_naming_the_field_not_testable": sum(flagged(k, v) for k, v in wrong.items()),
        "right_fields_not_testable": {
            f: sum(f in v.get("setup_not_testable", []) for v in right.values()) for f in field.values()
        },
        "wrong": len(wrong),
        "right_unexplained": sum("unexplained" in v["causes"] for v in right.values()),
        "right_two_sided": sum(bool(v.get("missing")) for v in right.values()),
        "right_diagnosed": len(right),
    }
    a.json.write_text(json.dumps({"summary": summary, "stores": res}, indent=1) + "\n")
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

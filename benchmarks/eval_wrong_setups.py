"""Does ``microdoppler import`` refuse a wrongly declared set-up? (not run in CI)

Draws recordings from the test suite's generators, which share no code with the
emulator or the synthesis: ``--n-any`` from ``tests/any_radar.py`` (carriers 1.3-24
GHz, PRFs 2-20 kHz, 4/6/8 rotors of 2 or 3 blades, blade lengths 0.05-0.25 m,
hovering and flying; seeds ``--seed`` + 0, 1, ...) and ``--n-gen`` from
``tests/independent_generator.py`` (1.25 and 2.9 GHz, 4 rotors of 2 blades, flying;
equal blades or one blade 6 dB weak), each ``--duration-s`` long, and the docs'
stand recording (``docs/examples/make_stand_recording.py``, 12 s). Each is written as
a ``.npz`` with a track CSV and imported with the command line (in-process), once with
the true set-up and once per wrong declared field:

- ``prf x0.5``, ``prf x2``, ``prf x10``; ``carrier x0.5``, ``carrier x2``,
  ``carrier GHz as Hz``; ``n_blades 2<->3``; ``blade_length x2``, ``blade_length x0.5``.

Two ways of importing: ``plain`` (no rotor speeds: the range checks and the spectrum's
Doppler extent) for every recording and every wrong field, and ``estimate``
(``--estimate-motors``: the tips at the radar's rotor comb too) for the true set-up and
``--estimate-per-recording`` wrong fields per recording, in turn (the estimate takes
seconds per recording). A wrong set-up counts as caught where the import exits 2 with
a message naming the wrong field (the field's name in the line); a true one is a false
refusal where the import exits 2. The ``estimate`` rows also count the hint naming
``n_blades`` (printed, not a refusal). Intervals: Wilson 95 %. Writes
``benchmarks/records/eval_wrong_setups_seed<N>.json`` (or ``--json``).

    OMP_NUM_THREADS=1 PYTHONPATH=src .venv/bin/python benchmarks/eval_wrong_setups.py --seed 40000
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from any_radar import draw_case, make_recording  # noqa: E402
from independent_generator import GenCase, make_flight  # noqa: E402

from shares import wilson  # noqa: E402
from microdoppler.cli import main as cli  # noqa: E402

#: name -> (field, how the declared value is made from the true one)
WRONG = {
    "prf x0.5": ("prf_hz", lambda v: v * 0.5),
    "prf x2": ("prf_hz", lambda v: v * 2.0),
    "prf x10": ("prf_hz", lambda v: v * 10.0),
    "carrier x0.5": ("carrier_hz", lambda v: v * 0.5),
    "carrier x2": ("carrier_hz", lambda v: v * 2.0),
    "carrier GHz as Hz": ("carrier_hz", lambda v: v / 1e9),
    "n_blades 2<->3": ("n_blades", lambda v: 5 - v),
    "blade_length x2": ("blade_length_m", lambda v: v * 2.0),
    "blade_length x0.5": ("blade_length_m", lambda v: v * 0.5),
}
#: the wrong fields the rotor estimate can reach (the others are refused before it)
ESTIMATE_KINDS = (
    "prf x0.5",
    "prf x2",
    "carrier x0.5",
    "carrier x2",
    "n_blades 2<->3",
    "blade_length x2",
    "blade_length x0.5",
)


def recordings(args):
    """(name, flight, note) for every recording of the run."""
    for i in range(args.n_any):
        case = draw_case(args.seed + i, duration_s=args.duration_s)
        flight, _ = make_recording(case)
        yield (
            case.name,
            flight,
            f"any_radar {case.carrier_hz / 1e9:g} GHz, PRF {case.prf_hz:.0f} Hz, "
            f"{case.n_rotors}x{case.n_blades} blades, L {case.blade_length_m:.3f} m, tip "
            f"{case.tip_speed_mps:.0f} m/s, {case.setup}, weak {case.weak_blade_db:.1f} dB",
        )
    for i in range(args.n_gen):
        seed = args.seed + 500 + i
        radar = ("gen_l", "gen_s")[i % 2]
        eff = {"blade_imbalance": {"imbalance_db": 6.0}} if i % 3 == 2 else {}
        flight, _ = make_flight(
            GenCase(flight_id=f"gen{seed}", seed=seed, radar=radar, effects=eff, duration_s=args.duration_s)
        )
        yield flight.flight_id, flight, f"independent_generator {radar}, {'weak blade' if eff else 'equal blades'}"


def stand_recording(tmp: Path):
    """The docs' stand example, from its own script: (npz, sidecar)."""
    d = tmp / "stand"
    d.mkdir()
    subprocess.run(
        [sys.executable, str(ROOT / "docs/examples/make_stand_recording.py")], cwd=d, check=True, capture_output=True
    )
    return d / "stand_3p3ghz.npz", d / "stand.yaml"


def write_recording(flight, d: Path):
    d.mkdir()
    np.savez(d / "rec.npz", iq=flight.iq)
    track = d / "track.csv"
    with open(track, "w") as fh:
        fh.write("time_s,range_m,radial_velocity_mps\n")
        for t, r, v in zip(flight.track_time_s, flight.track_range_m, flight.track_radial_velocity_mps):
            fh.write(f"{t:.4f},{r:.3f},{v:.4f}\n")
    a = flight.attrs
    decl = {k: a[k] for k in ("prf_hz", "carrier_hz", "n_blades", "blade_length_m")}
    fixed = [
        "--target",
        "drone",
        "--radar-id",
        "eval",
        "--drone-model",
        "eval",
        "--n-motors",
        str(a["n_motors"]),
        "--track",
        str(track),
    ]
    return d / "rec.npz", decl, fixed


def run_import(argv, scratch=None) -> tuple[int, str, str | None]:
    """Run ``microdoppler import``; its return code, its error line and its n_blades
    hint, with the scratch folder's path left out of what is recorded."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = cli([str(a) for a in argv])
    text = err.getvalue() if scratch is None else err.getvalue().replace(f"{scratch}/", "")
    lines = [ln for ln in text.splitlines() if ln.startswith("error:")]
    hints = [ln for ln in text.splitlines() if ln.startswith("hint: n_blades")]
    return rc, (lines[0] if lines else ""), (hints[0] if hints else None)


def diagnose_store(store: Path, kind: str | None) -> dict:
    """The diagnosis of an imported store: its cause(s), skip reason and hint, and
    whether a wrong field is named there (in the reason, the hint or the store's
    plausibility warnings)."""
    from microdoppler.diagnosis import DiagnosisConfig
    from microdoppler.diagnosis.measure import Undiagnosable
    from microdoppler.diagnosis.pipeline import diagnose_flight, plausibility_warnings, skip_hint
    from microdoppler.io.flightzarr import read_flight

    f = read_flight(store)
    try:
        e = diagnose_flight(f, config=DiagnosisConfig())
        out = {"cause": e["cause"], "causes": [c["cause"] for c in e.get("causes") or []], "reason": "", "hint": ""}
    except Undiagnosable as exc:
        out = {"cause": "skipped", "causes": [], "reason": exc.reason, "hint": skip_hint(exc.reason, f)}
    text = " ".join([out["reason"], out["hint"], *plausibility_warnings(f)])
    out["names_field"] = bool(kind) and WRONG[kind][0] in text
    return out


def declared(decl: dict, kind: str | None) -> list:
    d = dict(decl)
    if kind is not None:
        field, how = WRONG[kind]
        d[field] = how(d[field])
    out = []
    for k, v in d.items():
        out += ["--" + k.replace("_", "-"), f"{int(v)}" if k == "n_blades" else f"{v:.10g}"]
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=40000)
    ap.add_argument("--n-any", type=int, default=48)
    ap.add_argument("--n-gen", type=int, default=12)
    ap.add_argument("--duration-s", type=float, default=3.0)
    ap.add_argument(
        "--estimate-per-recording",
        type=int,
        default=1,
        help="wrong fields imported with --estimate-motors per recording (in turn); 0: none",
    )
    ap.add_argument(
        "--diagnose",
        action="store_true",
        help="diagnose every store the estimate-mode import accepted (use --duration-s >= 12: the diagnosis needs "
        "20 CPIs)",
    )
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    t0 = time.time()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        jobs = []
        for i, (name, flight, note) in enumerate(recordings(args)):
            path, decl, fixed = write_recording(flight, tmp / name)
            jobs.append((name, note, path, decl, fixed))
        npz, sidecar = stand_recording(tmp)
        k_est = 0
        for name, note, path, decl, fixed in jobs:
            kinds = [None, *WRONG]
            for kind in kinds:
                rc, msg, _ = run_import(
                    [
                        "import",
                        path,
                        *declared(decl, kind),
                        *fixed,
                        "--quiet",
                        "--out",
                        tmp / f"{name}_plain.zarr",
                        "--overwrite",
                    ],
                    scratch=tmp,
                )
                rows.append({"recording": name, "note": note, "mode": "plain", "wrong": kind, "rc": rc, "message": msg})
            est_kinds = [None]
            for _ in range(args.estimate_per_recording):
                est_kinds.append(ESTIMATE_KINDS[k_est % len(ESTIMATE_KINDS)])
                k_est += 1
            if args.estimate_per_recording:
                for kind in est_kinds:
                    rc, msg, hint = run_import(
                        [
                            "import",
                            path,
                            *declared(decl, kind),
                            *fixed,
                            "--quiet",
                            "--estimate-motors",
                            "--out",
                            tmp / f"{name}_est.zarr",
                            "--overwrite",
                        ],
                        scratch=tmp,
                    )
                    row = {
                        "recording": name,
                        "note": note,
                        "mode": "estimate",
                        "wrong": kind,
                        "rc": rc,
                        "message": msg,
                        "n_blades_hint": hint,
                    }
                    if args.diagnose and rc == 0:  # what the diagnosis makes of an accepted store
                        row["diagnosis"] = diagnose_store(tmp / f"{name}_est.zarr", kind)
                    rows.append(row)
            print(
                f"{name}: {sum(r['rc'] == 2 for r in rows if r['recording'] == name and r['wrong'])} of "
                f"{sum(1 for r in rows if r['recording'] == name and r['wrong'])} wrong refused, right: "
                f"{[r['rc'] for r in rows if r['recording'] == name and not r['wrong']]} ({time.time() - t0:.0f} s)",
                file=sys.stderr,
                flush=True,
            )
        for mode, extra in (("plain", []), ("estimate", ["--estimate-motors"])):
            for kind in (None, "prf x10"):
                over = ["--prf-hz", "50001"] if kind else []
                rc, msg, _ = run_import(
                    [
                        "import",
                        npz,
                        "--sidecar",
                        sidecar,
                        *over,
                        *extra,
                        "--quiet",
                        "--out",
                        tmp / "stand.zarr",
                        "--overwrite",
                    ],
                    scratch=tmp,
                )
                rows.append(
                    {
                        "recording": "docs stand example",
                        "note": "docs/examples/make_stand_recording.py",
                        "mode": mode,
                        "wrong": kind,
                        "rc": rc,
                        "message": msg,
                    }
                )
    summary = {}
    for mode in ("plain", "estimate"):
        mr = [r for r in rows if r["mode"] == mode]
        right = [r for r in mr if r["wrong"] is None]
        per = {}
        for kind, (field, _) in WRONG.items():
            kr = [r for r in mr if r["wrong"] == kind]
            if not kr:
                continue
            caught = [r for r in kr if r["rc"] == 2 and field in r["message"]]
            per[kind] = {
                "n": len(kr),
                "refused_naming_field": len(caught),
                "refused_other": sum(r["rc"] == 2 and field not in r["message"] for r in kr),
                "rate": round(len(caught) / len(kr), 4),
                "wilson95": wilson(len(caught), len(kr)),
            }
        wrong = [r for r in mr if r["wrong"] is not None]
        n_caught = sum(r["rc"] == 2 and WRONG[r["wrong"]][0] in r["message"] for r in wrong)
        summary[mode] = {
            "right": {
                "n": len(right),
                "false_refusals": sum(r["rc"] == 2 for r in right),
                "wilson95": wilson(sum(r["rc"] == 2 for r in right), len(right)),
                "refused": [r for r in right if r["rc"] == 2],
            },
            "wrong": {
                "n": len(wrong),
                "refused_naming_field": n_caught,
                "rate": round(n_caught / max(len(wrong), 1), 4),
                "wilson95": wilson(n_caught, len(wrong)),
            },
            "per_wrong_field": per,
            "misses": [
                {k: r[k] for k in ("recording", "note", "wrong", "rc", "message")}
                for r in wrong
                if not (r["rc"] == 2 and WRONG[r["wrong"]][0] in r["message"])
            ],
        }
        if mode == "estimate" and args.diagnose:  # refused at import, or what the diagnosis read
            diag_right = [r["diagnosis"] for r in right if "diagnosis" in r]
            outcome = {}
            for r in wrong:
                d = r.get("diagnosis")
                key = (
                    "refused naming the field"
                    if r["rc"] == 2 and WRONG[r["wrong"]][0] in r["message"]
                    else "refused, another field"
                    if r["rc"] == 2
                    else f"{d['cause']}{' naming the field' if d['names_field'] else ''}"
                    if d
                    else "not diagnosed"
                )
                outcome[key] = outcome.get(key, 0) + 1
            n_none = sum(1 for r in wrong if (r.get("diagnosis") or {}).get("cause") == "none")
            summary[mode]["diagnosis"] = {
                "wrong_outcomes": outcome,
                "wrong_read_none": n_none,
                "wrong_read_none_wilson95": wilson(n_none, len(wrong)),
                "right_causes": {
                    c: sum(d["cause"] == c for d in diag_right) for c in sorted({d["cause"] for d in diag_right})
                },
                "right_unexplained": sum("unexplained" in d["causes"] for d in diag_right),
                "right_diagnosed": len(diag_right),
            }
        if mode == "estimate":  # the n_blades hint (printed, not a refusal)
            summary[mode]["n_blades_hint"] = {
                "right": sum(bool(r.get("n_blades_hint")) for r in right),
                "n_blades 2<->3": sum(bool(r.get("n_blades_hint")) for r in wrong if r["wrong"] == "n_blades 2<->3"),
                "other wrong": sum(bool(r.get("n_blades_hint")) for r in wrong if r["wrong"] != "n_blades 2<->3"),
            }
    record = {
        "benchmark": "eval_wrong_setups",
        "seed": args.seed,
        "n_any": args.n_any,
        "n_gen": args.n_gen,
        "duration_s": args.duration_s,
        "estimate_per_recording": args.estimate_per_recording,
        "wall_s": round(time.time() - t0, 1),
        "summary": summary,
        "rows": rows,
    }
    out = Path(args.json) if args.json else ROOT / "benchmarks" / "records" / f"eval_wrong_setups_seed{args.seed}.json"
    tmp_out = out.with_suffix(".json.tmp")
    tmp_out.write_text(json.dumps(record, indent=1) + "\n")
    os.replace(tmp_out, out)
    for mode, s in summary.items():
        print(
            f"{mode}: right refused {s['right']['false_refusals']} of {s['right']['n']}; wrong refused naming the "
            f"field {s['wrong']['refused_naming_field']} of {s['wrong']['n']} {s['wrong']['wilson95']}"
        )
        for kind, p in s["per_wrong_field"].items():
            print(f"  {kind:18s} {p['refused_naming_field']:3d} / {p['n']:3d}  {p['wilson95']}")
    print(f"wrote {out} ({time.time() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Which of :class:`~microdoppler.rotors.order.OrderConfig`'s settings change the order
check's outcome? (not run in CI)

Runs :func:`~microdoppler.rotors.order.resolve_order` on the recordings of
``benchmarks/order_fingerprint.py`` (the test suite's generators: hovering and flying, 2
and 3 blades, a weak blade, a wrong blade count, carriers 1.25-24 GHz, PRFs 2-14.5 kHz;
the rescue, the split and the tip speed's prior among them) under the defaults and with
one setting perturbed at a time: numbers x0.5 and x2 (integers rounded; fractions that
x2 would put at or beyond 1 to the midpoint; ``rerun_margin``, a factor, its excess
over 1), booleans flipped, ``extent_range``
narrowed and widened by 0.1 at each end. Per perturbation it counts the recordings
whose outcome changes against the defaults':

- ``order``: whether an estimate is made, or the chosen rate's ratio to the lines'
  comb (by more than 3 %);
- ``ambiguous``: the ambiguity mark;
- ``speed``: the mean speed (median over CPIs) by more than 0.5 %;
- ``error``: the error against the truth (the generators' own speeds) by more than
  0.5 % (``within_2pct`` and ``wrong_unmarked``, > 10 % off and not marked, are counted
  too).

A setting is inert on the set where no perturbation changes the order, the mark or the
speed of any recording. The re-measurements are memoised per recording (the same
settings give the same estimate), and so is the screen's coarse likelihood (keyed on
the CPIs' peaks, the rates and the settings the line model reads), so the settings that
act after the screen cost little. The defaults' run prints the fingerprint's hash (the
same as ``order_fingerprint.py``'s where every recording is run). Writes ``benchmarks/records/ablate_order_config.json``
(or ``--json``; written after every setting).

Usage: ``OMP_NUM_THREADS=1 PYTHONPATH=src python benchmarks/ablate_order_config.py``
(``--only NAME ...`` for some recordings, ``--fields NAME ...`` for some settings: runs
over different settings, side by side, are joined by ``--join A.json B.json``).
"""

from __future__ import annotations

import argparse
import hashlib
import inspect
import json
import math
import re
import sys
import time
from dataclasses import fields, replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import order_fingerprint as fp  # noqa: E402

from microdoppler.rotors import order as order_mod  # noqa: E402
from microdoppler.rotors.order import OrderConfig  # noqa: E402

ORDER_REL = 0.03
SPEED_REL = 0.005


def variants(name: str, value) -> list:
    """The perturbed values of one setting."""
    if isinstance(value, bool):
        return [not value]
    if isinstance(value, tuple):
        lo, hi = value
        return [(round(lo + 0.1, 3), round(hi - 0.1, 3)), (round(lo - 0.1, 3), round(hi + 0.1, 3))]
    if name == "rerun_margin":  # a factor >= 1: its excess over 1 x0.5 and x2
        return [1 + 0.5 * (value - 1), 1 + 2 * (value - 1)]
    if isinstance(value, int):
        return [max(1, int(round(value * 0.5))), value * 2]
    out = [value * 0.5, value * 2]
    if 0 < value < 1 and value * 2 >= 1:  # a fraction: x2 would leave (0, 1)
        out[1] = 0.5 * (value + 1)
    return out


def _reads(*fns) -> set:
    """The settings the functions read (``ocfg.<name>`` in their source)."""
    return {m for fn in fns for m in re.findall(r"ocfg\.(\w+)", inspect.getsource(fn))}


class ScreenMemo:
    """Memoises ``order._screen_scores`` (a pure function of the CPIs' peaks, the rates,
    the geometry and the settings the line model reads)."""

    def __init__(self):
        self.fn = order_mod._screen_scores
        self.reads = sorted(_reads(order_mod._geometry, order_mod._loglik, order_mod._tail_fall_db))
        self.memo = {}
        self.hits = 0

    def key(self, data, grid, B, L, lam, ocfg, rmax_db, kappas, rows):
        h = hashlib.sha256()
        for a in (data.peaks_x, data.peaks_y, data.masked, data.centre_bin, data.p_lo, data.p_hi, data.band_hz):
            h.update(np.ascontiguousarray(a).tobytes())
        h.update(np.concatenate(data.pk_table).tobytes())
        h.update(np.asarray(grid, float).tobytes())
        h.update(repr((data.prf, data.bin_hz, data.n_fft, B, L, lam, rmax_db, tuple(kappas))).encode())
        h.update(b"-" if rows is None else np.asarray(rows).tobytes())
        h.update(repr([(k, getattr(ocfg, k)) for k in self.reads]).encode())
        return h.hexdigest()

    def __call__(self, data, grid, B, L, lam, ocfg, rmax_db, kappas, rows=None):
        k = self.key(data, grid, B, L, lam, ocfg, rmax_db, kappas, rows)
        if k in self.memo:
            self.hits += 1
            return self.memo[k].copy()
        self.memo[k] = self.fn(data, grid, B, L, lam, ocfg, rmax_db, kappas, rows)
        return self.memo[k].copy()


def changes(base: dict, new: dict) -> dict:
    """Which of the outcomes differ between two summaries of one recording."""
    if base["ok"] != new["ok"]:
        return {"order": True, "ambiguous": True, "speed": True, "error": True}
    if not base["ok"]:
        return {"order": False, "ambiguous": False, "speed": False, "error": False}
    return {
        "order": (
            new["ratio"] != base["ratio"]  # an estimate without an order check (no candidate)
            if new["ratio"] is None or base["ratio"] is None
            else abs(math.log(new["ratio"] / base["ratio"])) > ORDER_REL
        ),
        "ambiguous": new["ambiguous"] != base["ambiguous"],
        "speed": abs(new["mean_rev_s"] / base["mean_rev_s"] - 1) > SPEED_REL,
        "error": abs(new["error"] - base["error"]) > SPEED_REL,
    }


def tally(summaries: dict) -> dict:
    """Within 2 % of the truth, and more than 10 % off without the ambiguity mark."""
    ok = [s for s in summaries.values() if s["ok"]]
    return {
        "within_2pct": sum(abs(s["error"]) <= 0.02 for s in ok),
        "wrong_unmarked": sum(abs(s["error"]) > 0.10 and not s["ambiguous"] for s in ok),
        "no_estimate": len(summaries) - len(ok),
    }


def code_version() -> str:
    """The last commit of ``rotors/order.py`` (with ``+`` where the work tree differs)."""
    import subprocess

    def git(*a):
        return subprocess.run(["git", *a], cwd=fp.ROOT, capture_output=True, text=True).stdout.strip()

    path = "src/microdoppler/rotors/order.py"
    return git("log", "-1", "--format=%h", "--", path) + ("+" if git("status", "--porcelain", "--", path) else "")


def _default(rows: list, fname: str):
    """A setting's default as its rows record it (a JSON list back to a tuple)."""
    d = rows[0]["default"]
    return tuple(d) if isinstance(d, list) else d


def summarise(rows: list, names: list) -> tuple[dict, list]:
    """Per setting: the most recordings any perturbation changed, per outcome, and which;
    and the settings inert on the set (every perturbation run, none changing an order, a
    mark or a speed)."""
    knobs = {}
    for fname in names:
        rs = [r for r in rows if r["field"] == fname and "invalid" not in r]
        k = {o: max((r[o] for r in rs), default=0) for o in ("order", "ambiguous", "speed", "error")}
        k["recordings_changed"] = sorted({n for r in rs for n in r["changed"]})
        n_var = len(variants(fname, _default(rs, fname))) if rs else 0
        k["variants_run"] = f"{len(rs)} of {n_var}"
        k["inert"] = bool(rs) and len(rs) == n_var and not any(k[o] for o in ("order", "ambiguous", "speed"))
        knobs[fname] = k
    return knobs, [k for k, v in knobs.items() if v["inert"]]


def join(paths: list, out: str) -> None:
    """One record from records of the same recordings over different settings (a
    perturbation run twice counts once; one this version would not make is left out)."""
    recs = [json.loads(Path(p).read_text()) for p in paths]
    # the defaults' outcomes must agree (the fingerprints differ where a setting left
    # OrderConfig between the runs: info["order"]["settings"] lists it no more)
    if any(r["recordings"] != recs[0]["recordings"] for r in recs):
        raise SystemExit("the records' defaults differ: not joinable")
    seen, rows = set(), []
    for row in (row for r in recs for row in r["rows"]):
        allowed = {json.dumps(fp._plain(v)) for v in variants(row["field"], _default([row], row["field"]))}
        key = (row["field"], json.dumps(row["value"]))
        if key[1] in allowed and key not in seen:
            seen.add(key)
            rows.append(row)
    current = [f.name for f in fields(OrderConfig)]
    names = list(dict.fromkeys([n for n in current if any(r["field"] == n for r in rows)] + [r["field"] for r in rows]))
    rows.sort(key=lambda row: names.index(row["field"]))
    knobs, inert = summarise(rows, names)
    record = {
        **recs[0],
        "code": sorted({r.get("code") or "?" for r in recs}),
        "fingerprint": sorted({r["fingerprint"] for r in recs}),
        "command": " & ".join(r["command"] for r in recs) + "; then --join of their records",
        "cpu_s": round(sum(r["cpu_s"] for r in recs) - sum(r["cpu_s_defaults"] for r in recs[1:]), 1),
        "wall_s": max(r["wall_s"] for r in recs),
        "screen_memo_hits": sum(r["screen_memo_hits"] for r in recs),
        "complete": all(
            v["variants_run"].split(" of ")[0] == v["variants_run"].split(" of ")[1] for v in knobs.values()
        ),
        "knobs": knobs,
        "inert": inert,
        "rows": rows,
    }
    Path(out).write_text(json.dumps(record, indent=1) + "\n")
    print("inert on the set:", " ".join(inert))
    print("matter:", ", ".join(f"{k} ({len(v['recordings_changed'])})" for k, v in knobs.items() if not v["inert"]))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", help="recording names (default: all the fingerprint's)")
    ap.add_argument("--fields", nargs="*", help="OrderConfig fields (default all)")
    ap.add_argument("--json", default=str(fp.ROOT / "benchmarks" / "records" / "ablate_order_config.json"))
    ap.add_argument("--join", nargs="*", help="join these records (runs over different --fields) into --json")
    args = ap.parse_args(argv)
    if args.join:
        return join(args.join, args.json)
    memo = ScreenMemo()
    order_mod._screen_scores = memo
    t_start, w_start = time.process_time(), time.time()
    recs = []
    base, base_hash = {}, {}
    for name, flight, tm, note in fp.recordings(args.only):
        rec = fp.Recording(name, flight, tm, note)
        est = rec.resolve(OrderConfig())
        base[name] = fp.summary(rec, est)
        base_hash[name] = fp.digest(fp.payload(est))
        recs.append(rec)
        print(f"{name:14s} {base[name]}", flush=True)
    t_base = time.process_time() - t_start
    default = OrderConfig()
    names = args.fields or [f.name for f in fields(OrderConfig) if f.name not in order_mod.NOT_STORED]
    rows = []
    record = {
        "script": "benchmarks/ablate_order_config.py",
        "command": "OMP_NUM_THREADS=1 PYTHONPATH=src python benchmarks/ablate_order_config.py"
        + (f" --only {' '.join(args.only)}" if args.only else "")
        + (f" --fields {' '.join(args.fields)}" if args.fields else ""),
        "method": order_mod.METHOD,
        "code": code_version(),
        "date_utc": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
        "thresholds": {"order_rel": ORDER_REL, "speed_rel": SPEED_REL},
        "cpu_s_defaults": round(t_base, 1),
        "fingerprint": fp.digest(base_hash),
        "recordings": {r.name: {"note": r.note, **base[r.name]} for r in recs},
        "defaults": tally(base),
    }
    for fname in names:
        value = getattr(default, fname)
        for alt in variants(fname, value):
            t0 = time.process_time()
            try:
                ocfg = replace(default, **{fname: alt})
            except ValueError as e:
                rows.append({"field": fname, "default": value, "value": alt, "invalid": str(e)})
                continue
            per, counts = {}, {"order": 0, "ambiguous": 0, "speed": 0, "error": 0}
            changed = []
            for rec in recs:
                s = fp.summary(rec, rec.resolve(ocfg))
                per[rec.name] = s
                ch = changes(base[rec.name], s)
                for k, v in ch.items():
                    counts[k] += int(v)
                if any(ch.values()):
                    changed.append(rec.name)
            row = {
                "field": fname,
                "default": value,
                "value": alt,
                **counts,
                **tally(per),
                "changed": changed,
                "cpu_s": round(time.process_time() - t0, 1),
            }
            rows.append(row)
            print(
                f"{fname:18s} {alt!s:12s} order {counts['order']:2d} ambiguous {counts['ambiguous']:2d} "
                f"speed {counts['speed']:2d} error {counts['error']:2d} within 2 % {row['within_2pct']:2d} "
                f"[{row['cpu_s']:.0f} s] {' '.join(changed)}",
                flush=True,
            )
        # written after every setting: a stopped run keeps what it did
        knobs, inert = summarise(rows, [n for n in names if any(r["field"] == n for r in rows)])
        record.update(
            {
                "cpu_s": round(time.process_time() - t_start, 1),
                "wall_s": round(time.time() - w_start, 1),
                "screen_memo_hits": memo.hits,
                "complete": fname == names[-1],
                "knobs": knobs,
                "inert": inert,
                "rows": rows,
            }
        )
        Path(args.json).write_text(json.dumps(fp._plain(record), indent=1) + "\n")
    print("inert on the set:", " ".join(inert))
    print("matter:", ", ".join(f"{k} ({len(v['recordings_changed'])})" for k, v in knobs.items() if not v["inert"]))
    print(f"fingerprint {record['fingerprint']}  cpu {record['cpu_s']:.0f} s  -> {args.json}")


if __name__ == "__main__":
    main()

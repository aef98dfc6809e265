"""Diagnose flight-zarr stores with whichever ``microdoppler`` is on ``PYTHONPATH`` (not run in CI).

For paired before/after comparisons: ``eval_diagnosis.py --before-src DIR`` writes its
catalog-cause flights as stores and runs this script with ``PYTHONPATH=DIR`` (the
``src/`` of an older checkout), so that the same bytes are diagnosed by both codes.
It imports only :func:`microdoppler.io.flightzarr.read_flight` and
:func:`microdoppler.diagnosis.diagnose_flight`, which every version since the
flight-zarr format has, and writes per flight: the causes named, their canonical
parameters and the reason a flight was skipped.

    PYTHONPATH=../old/src python benchmarks/diagnose_stores.py STORES_DIR --out before.json
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402


def diagnose(flight) -> tuple[list, dict, str | None]:
    """One flight through the diagnosis (no figures): (named causes, each cause's
    parameters, reason or None); a skip or a crash is recorded, not raised (an
    evaluation goes on). Also used by eval_diagnosis.py."""
    return diagnose_with_fit(flight)[:3]


#: the goodness of fit's numbers a benchmark row keeps
GOF_KEYS = ("largest_significant_db", "max_abs_residual_db", "excess_db", "band_hz", "margin_db", "missing_reason")


def diagnose_with_fit(flight) -> tuple[list, dict, str | None, dict]:
    """:func:`diagnose` and the goodness of fit's numbers (:data:`GOF_KEYS`, those the
    diagnosis reports; empty for a skipped flight)."""
    from microdoppler.diagnosis import Undiagnosable, diagnose_flight

    try:
        e = diagnose_flight(flight, config={"figures": False})  # sees the flight only
        named = [c["cause"] for c in e["causes"]]
        fits = {c["cause"]: (c.get("extension") or c).get("params", {}) for c in e["causes"]}
        gof = e.get("evidence", {}).get("goodness_of_fit", {})
        return named, fits, None, {k: gof[k] for k in GOF_KEYS if k in gof}
    except Undiagnosable as exc:
        return [], {}, f"skipped: {exc.reason}", {}
    except Exception as exc:  # noqa: BLE001 (an evaluation records a crash and goes on)
        return [], {}, f"error: {type(exc).__name__}: {exc}", {}


def diagnose_store(path: Path) -> dict:
    """One store: ``{"named", "fits", "reason", "seconds_diagnose"}``."""
    from microdoppler.io.flightzarr import read_flight

    flight = read_flight(path)
    t0 = time.perf_counter()
    named, fits, reason = diagnose(flight)
    return {
        "flight_id": flight.flight_id,
        "named": named,
        "fits": fits,
        "reason": reason,
        "seconds_diagnose": round(time.perf_counter() - t0, 2),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("stores", help="folder of *.zarr flight stores")
    ap.add_argument("--out", required=True, help="JSON file: {flight_id: result}")
    a = ap.parse_args(argv)
    stores = sorted(Path(a.stores).glob("*.zarr"))
    out = {}
    for i, s in enumerate(stores, 1):
        r = diagnose_store(s)
        out[r["flight_id"]] = r
        print(
            f"[{i}/{len(stores)}] {r['flight_id']} named={r['named']} {r['reason'] or ''} "
            f"({r['seconds_diagnose']:.1f} s)",
            flush=True,
        )
    Path(a.out).write_text(json.dumps(out, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

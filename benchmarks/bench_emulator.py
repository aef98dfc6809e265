"""Emulation throughput: seconds of flight emulated per second of wall time.

    python benchmarks/bench_emulator.py [--workers 2] [--profile test]

Prints per-class single-process throughput (emulate_flight only, incl. background)
and the whole-profile throughput of emulate_world (writing stores and measuring SNR)
with ``--workers`` processes.
"""

from __future__ import annotations

import argparse
import tempfile
import time

from microdoppler.emulator import FlightSpec, emulate_flight, emulate_world, plan_world


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--profile", default="test")
    ap.add_argument("--duration", type=float, default=30.0)
    a = ap.parse_args()
    specs = [
        FlightSpec("b_inspire", "drone", drone_model="inspire2", duration_s=a.duration, seed=1),
        FlightSpec("b_matrice", "drone", drone_model="matrice300", duration_s=a.duration, seed=2),
        FlightSpec("b_mini", "drone", drone_model="mini2", duration_s=a.duration, seed=3),
        FlightSpec("b_single", "bird", bird_kind="single", duration_s=a.duration, seed=4),
        FlightSpec("b_flock", "bird", bird_kind="large_flock", duration_s=a.duration, seed=5),
    ]
    print("single process, emulate_flight (iq + background/iq):")
    for s in specs:
        t0 = time.perf_counter()
        emulate_flight(s)
        dt = time.perf_counter() - t0
        print(f"  {s.flight_id:10s} {s.duration_s:5.0f} s of flight in {dt:6.2f} s: {s.duration_s / dt:6.1f} s/s")
    with tempfile.TemporaryDirectory() as d:
        n = len(plan_world(a.profile, 1))
        t0 = time.perf_counter()
        rows = emulate_world(a.profile, 1, d, progress=False, workers=a.workers)
        dt = time.perf_counter() - t0
        flown = sum(r["duration_s"] for r in rows)
        print(
            f"emulate_world profile={a.profile} ({n} flights, {flown:.0f} s of flight, {a.workers} workers): "
            f"{dt:.1f} s wall, {flown / dt:.1f} s of flight per s"
        )


if __name__ == "__main__":
    main()

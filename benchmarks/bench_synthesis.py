"""Synthesis benchmark: throughput on one core and peak memory of a 30-minute flight.

Run:  python benchmarks/bench_synthesis.py [--pulses N] [--json PATH] [--skip-memory]

* Throughput [pulses/s] of :func:`microdoppler.synthesis.model.synthesize` for 4 motors x
  2 blades (Inspire geometry, L-band, PRF 7300 Hz), with alpha > 0 (default: the
  harmonic envelope; and the FFT filter, ``Envelope("fft")``) and alpha = 0,
  best and median of ``--repeats``; the per-pulse Python reference
  :func:`~microdoppler.synthesis.model.reference_synthesize` (alpha = 0, 10 000 pulses)
  runs in every repeat, interleaved with the kernels, and the speed-up over it is
  taken per repeat (similar machine load), then the median over repeats.
* Agreement of the harmonic envelope with the FFT filter on these speeds (record
  interior, one FFT over the record with a long margin).
  One core: OMP/MKL/OPENBLAS threads = 1, scipy.fft workers = 1 (the kernel's default).
* Peak memory beyond the output for a 30-minute flight (13.14 M pulses at 7.3 kHz),
  in a fresh subprocess: speeds come from a Zarr array on disk (never loaded
  whole), the output buffer is allocated and touched first; we report the
  tracemalloc peak of the synthesis call and the process's peak RSS (VmHWM; Linux
  ru_maxrss would inherit the parent's peak across exec) minus its RSS just before
  the call (an upper bound: it also counts memory that imports touched and freed).
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_v] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

PRF = 7300.0
LAM = 299792458.0 / 1.35e9
KW = dict(prf_hz=PRF, wavelength_m=LAM, n_blades=2, blade_length_m=0.19)


def config(alpha: float, method: str = "auto", **kw):
    """The benchmark's SynthesisConfig (Inspire geometry, L-band): S_body = S_blade = 1."""
    from microdoppler.synthesis.model import Envelope, Scaling, SynthesisConfig

    margin = kw.pop("margin_pulses", 4096)
    return SynthesisConfig.of(
        scaling=Scaling(kw.pop("s_body", 1.0), 1.0, alpha), envelope=Envelope(method, margin_pulses=margin), **KW, **kw
    )


ALPHA = 5.5e-3  # Table IV, smallest Inspire alpha [s]


def speeds(n: int, i0: int = 0) -> np.ndarray:
    """Smoothly varying speeds of 4 motors [rev/s], float32 [n, 4] (pulses i0..i0+n)."""
    t = (i0 + np.arange(n)) / PRF
    base = np.array([85.0, 90.0, 95.0, 100.0])
    return (base + 5 * np.sin(2 * np.pi * t[:, None] / np.array([7.0, 9.0, 11.0, 13.0]))).astype(np.float32)


def track(duration_s: float):
    from microdoppler.synthesis.model import Track

    t = np.linspace(0, duration_s, max(16, int(duration_s)))
    return Track(t, 5000.0 - 2.0 * t + 0.5 * np.sin(t / 5))


def throughput(n: int, repeats: int) -> dict:
    from microdoppler.synthesis.model import reference_synthesize, synthesize

    rev = speeds(n)
    tr = track(n / PRF)
    out = np.empty(n, np.complex64)
    res = {}
    kernels = {"alpha>0": (ALPHA, "auto"), "alpha>0 fft": (ALPHA, "fft"), "alpha=0": (0.0, "auto")}
    for alpha, method in kernels.values():  # warm-up (tables for the speeds met, FFT plans)
        synthesize(config(alpha, method), tr, rev, seed=1, out=out)
    n_ref = 10000
    rref = rev[:n_ref]
    start = [0.1, 0.2, 0.3, 0.4]
    times = {name: [] for name in (*kernels, "reference")}
    for _ in range(repeats):  # interleaved: each repeat's ratio to the reference sees similar load
        for name, (alpha, method) in kernels.items():
            t0 = time.perf_counter()
            synthesize(config(alpha, method), tr, rev, seed=1, out=out)
            times[name].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        ref = reference_synthesize(config(0.0), tr, rref, initial_cycles=start)
        times["reference"].append(time.perf_counter() - t0)
    for name, ts in times.items():
        m = n_ref if name == "reference" else n
        res[name] = m / min(ts)
        res[name + " median"] = m / float(np.median(ts))
    for name in kernels:  # speed-up over the reference within each repeat, median over repeats
        res[name + " x reference median"] = float(
            np.median([(n / t) / (n_ref / tr_) for t, tr_ in zip(times[name], times["reference"])])
        )
    fast = synthesize(config(0.0), tr, rref, initial_cycles=start)
    res["max_abs_diff_vs_reference"] = float(np.max(np.abs(fast - ref)))
    res["max_abs_reference"] = float(np.max(np.abs(ref)))
    # harmonic envelope vs the FFT filter (one FFT over the record, long margin), interior
    n_cmp = min(n, 1 << 16)
    h = synthesize(config(ALPHA, "harmonic", s_body=0.0), tr, rev[:n_cmp], seed=1)
    f = synthesize(config(ALPHA, "fft", s_body=0.0, margin_pulses=16384, chunk_pulses=n_cmp), tr, rev[:n_cmp], seed=1)
    s = slice(n_cmp // 8, n_cmp - n_cmp // 8)
    d, r = np.abs(h - f)[s], np.abs(f[s])
    res["harmonic_vs_fft_max_rel"] = float(np.max(d) / np.max(r))
    res["harmonic_vs_fft_rms_rel"] = float(np.sqrt(np.mean(d**2) / np.mean(r**2)))
    return res


MEMORY_CHILD = r"""
import os, sys, json, time, tracemalloc, resource, tempfile
for v in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ[v] = "1"
sys.path.insert(0, os.path.dirname(sys.argv[1]))
import numpy as np, zarr
import bench_synthesis as B
from microdoppler.synthesis.model import synthesize
n = int(sys.argv[2]); alpha = float(sys.argv[3]); store = sys.argv[4]
z = zarr.open_array(store, mode="r")
out = np.empty(n, np.complex64); out[:] = 0          # the output, allocated and touched
tr = B.track(n / B.PRF)
def rss_now():
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
rss0 = rss_now()  # current RSS (imports + the touched output), bytes
def hwm():  # VmHWM: peak RSS of this process image (ru_maxrss would include the parent's peak)
    with open("/proc/self/status") as fh:
        return next(int(l.split()[1]) * 1024 for l in fh if l.startswith("VmHWM:"))
maxrss0 = hwm()
tracemalloc.start()
t0 = time.perf_counter()
synthesize(B.config(alpha), tr, z, seed=1, out=out)
dt = time.perf_counter() - t0
peak = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
maxrss1 = hwm()
print(json.dumps({"n_pulses": n, "alpha_s": alpha, "output_bytes": out.nbytes, "tracemalloc_peak_bytes": peak,
                  "rss_before_bytes": rss0, "maxrss_before_bytes": maxrss0, "maxrss_after_bytes": maxrss1,
                  "peak_rss_beyond_baseline_bytes": maxrss1 - rss0, "seconds_with_tracemalloc": dt}))
"""


def memory(n: int, workdir: str) -> list[dict]:
    import zarr

    store = os.path.join(workdir, "speeds.zarr")
    z = zarr.create_array(store, shape=(n, 4), dtype=np.float32, chunks=(1 << 18, 4), overwrite=True)
    step = 1 << 20
    for i0 in range(0, n, step):
        i1 = min(i0 + step, n)
        z[i0:i1] = speeds(i1 - i0, i0)
    child = os.path.join(workdir, "mem_child.py")
    with open(child, "w") as fh:
        fh.write(MEMORY_CHILD)
    results = []
    for alpha in (ALPHA, 0.0):
        env = dict(
            os.environ,
            PYTHONPATH=os.pathsep.join([os.path.dirname(os.path.abspath(__file__)), os.environ.get("PYTHONPATH", "")]),
        )
        r = subprocess.run(
            [sys.executable, child, os.path.abspath(__file__), str(n), str(alpha), store],
            capture_output=True,
            text=True,
            env=env,
            check=True,
        )
        results.append(json.loads(r.stdout.strip().splitlines()[-1]))
    return results


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pulses", type=int, default=1 << 22, help="pulses per throughput run (default 2**22)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--flight-min", type=float, default=30.0, help="flight length for the memory run [min]")
    ap.add_argument("--skip-memory", action="store_true")
    ap.add_argument("--json", help="write results as JSON here")
    args = ap.parse_args(argv)
    import tempfile

    res = {
        "machine": platform.processor() or platform.machine(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "pulses": args.pulses,
    }
    res["throughput_pulses_per_s"] = thr = throughput(args.pulses, args.repeats)
    print(f"synthesis, 4 motors x 2 blades, one core, {args.pulses} pulses ({args.repeats} repeats)")
    print(
        f"{'kernel':<36}{'best [pulses/s]':>16}{'median':>12}{'x real time':>13}{'x reference':>13}"
        "  (medians; x reference: per repeat, then median)"
    )
    for name in ("alpha>0", "alpha>0 fft", "alpha=0", "reference"):
        label = {
            "alpha>0": f"synthesize, alpha={ALPHA:g} s harmonic",
            "alpha>0 fft": f"synthesize, alpha={ALPHA:g} s fft",
            "alpha=0": "synthesize, alpha=0",
            "reference": "reference (per-pulse loop)",
        }[name]
        med = thr[name + " median"]
        print(
            f"{label:<36}{thr[name]:>16.4g}{med:>12.4g}{med / PRF:>13.1f}"
            f"{thr.get(name + ' x reference median', 1.0):>13.0f}"
        )
    print(
        f"max |fast - reference| = {thr['max_abs_diff_vs_reference']:.3g} "
        f"(|reference| <= {thr['max_abs_reference']:.3g}), alpha = 0"
    )
    print(
        f"harmonic envelope vs FFT filter (alpha={ALPHA:g} s): max |diff| / max |x| = "
        f"{thr['harmonic_vs_fft_max_rel']:.2e}, rms ratio = {thr['harmonic_vs_fft_rms_rel']:.2e}"
    )
    if not args.skip_memory:
        n = int(round(args.flight_min * 60 * PRF))
        with tempfile.TemporaryDirectory() as d:
            res["memory"] = mem = memory(n, d)
        print(
            f"\npeak memory beyond the output, {args.flight_min:g}-minute flight ({n / 1e6:.2f} M pulses, "
            f"output {mem[0]['output_bytes'] / 2**20:.0f} MiB), speeds from Zarr"
        )
        print(f"{'alpha [s]':<12}{'tracemalloc peak':>18}{'peak RSS - RSS before':>24}{'seconds':>10}")
        for m in mem:
            print(
                f"{m['alpha_s']:<12g}{m['tracemalloc_peak_bytes'] / 2**20:>14.1f} MiB"
                f"{m['peak_rss_beyond_baseline_bytes'] / 2**20:>20.1f} MiB{m['seconds_with_tracemalloc']:>10.1f}"
            )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(res, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())

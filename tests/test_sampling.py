"""Motor-speed sampling variants (paper §V.A.1, Fig. 8): measured continuity."""

from __future__ import annotations

import numpy as np
import pytest

from microdoppler.io.motorlog import MotorLog
from microdoppler.rotors.sampling import SamplingConfig, fixed_speeds, per_cpi, resample, sub_cpi

PRF = 7300.0
CFG = SamplingConfig()


def _log(rng, duration_s=12.0, rate_hz=30.0, n_motors=4):
    t = np.arange(0, duration_s, 1 / rate_hz) + rng.uniform(0, 0.005, int(np.ceil(duration_s * rate_hz)))
    rev_s = 80 + np.cumsum(rng.normal(0, 1.0, (len(t), n_motors)), axis=0)
    return MotorLog(np.sort(t), (rev_s * 60).astype(np.float32), "synthetic")


def boundary_steps(rev_s, n_fft):
    """(max |step| across CPI boundaries, max |step| elsewhere) [rev/s per pulse]."""
    d = np.abs(np.diff(rev_s.astype(np.float64), axis=0)).max(axis=1)
    at = np.zeros(len(d), bool)
    at[n_fft - 1 :: n_fft] = True  # step from pulse k*n_fft - 1 to k*n_fft
    return d[at].max(), d[~at].max()


def _check(log):
    n = int(log.duration_s * PRF)
    pc = per_cpi(log, n, PRF, CFG)
    sc = sub_cpi(log, n, PRF, CFG)
    pc_at, pc_else = boundary_steps(pc, CFG.n_fft)
    sc_at, sc_else = boundary_steps(sc, CFG.n_fft)
    # per-CPI: jumps at CPI boundaries, flat inside
    assert pc_else == 0.0 and pc_at > 0.1, (pc_at, pc_else)
    # sub-CPI: continuous: no larger step at boundaries than elsewhere, and tiny steps
    assert sc_at <= 1.5 * sc_else + 1e-6, (sc_at, sc_else)
    assert sc_at < 0.02 * pc_at, (sc_at, pc_at)
    # both follow the log: same mean speed within 2 %
    assert abs(sc.mean() / pc.mean() - 1) < 0.02
    return pc_at, sc_at, sc_else


def test_per_cpi_jumps_sub_cpi_continuous_synthetic(rng):
    _check(_log(rng))


def test_per_cpi_jumps_sub_cpi_continuous_real_log(ulog_path):
    from microdoppler.io.motorlog import read_ulog

    _check(read_ulog(ulog_path))


def test_sub_cpi_tracks_the_log(rng):
    log = _log(rng)
    n = int(log.duration_s * PRF)
    sc = sub_cpi(log, n, PRF, CFG)
    t = np.arange(n) / PRF
    ref = np.column_stack([np.interp(t, log.time_s, log.rev_s[:, m]) for m in range(4)])
    inner = slice(int(PRF), n - int(PRF))
    # smoothing (8/CPI and a 2500-pulse average) keeps the slow speed within 3 rev/s
    assert np.max(np.abs(sc[inner] - ref[inner])) < 3.0


def test_variants_shapes_and_fixed_speeds(rng):
    log = _log(rng, duration_s=3.0)
    n = 10000
    assert resample("single_motor", log, n, PRF).shape == (n, 1)
    a = resample("fixed_speeds", log, n, PRF, typical_hz=80.0, seed=3)
    b = resample("fixed_speeds", log, n, PRF, typical_hz=80.0, seed=3)
    np.testing.assert_array_equal(a, b)
    assert np.all(a == a[0, 0]) and 72 <= a[0, 0] <= 88
    assert fixed_speeds(4, n, 80.0, 4)[1] != fixed_speeds(4, n, 80.0, 5)[1]
    with pytest.raises(ValueError):
        resample("nope", log, n, PRF)

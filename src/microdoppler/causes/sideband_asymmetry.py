"""``sideband_asymmetry``: HERM sidebands above the body Doppler stronger (or weaker)
than their mirrors below.

- catalog: ``asymmetry_db`` [dB], 10 log10(upper / lower sideband power);
- test (:func:`test_asymmetry`): per CPI d = 10 log10(upper / lower sideband power)
  over the usable harmonic pairs; baseline N(0, s^2), extension N(a, s^2); re-read
  with a named floor partner in the floor's model (``reads_sidebands``);
- twins: ``envelope_gain(f)`` multiplies the alpha envelope H(f) by 10^(+a/40) above
  the body Doppler and 10^(-a/40) below it (:func:`asymmetry_envelope`);
- emulator: the blade signal is filtered with the same gains (:func:`world_envelope`).
"""

from __future__ import annotations

import numpy as np

from .base import CauseSpec, Param
from .heldout import CauseTest, _crossfit, _gauss_ll
from .measure import DB

NAME = "sideband_asymmetry"


def test_asymmetry(M, cfg, fold) -> CauseTest:
    use = M.usable_pairs
    ok = M.pair_ok & use[None, :]
    U = np.where(ok, M.up, 0).sum(1)
    L = np.where(ok, M.lo, 0).sum(1)
    m = M.valid & (U > 0) & (L > 0)
    res = CauseTest(NAME, statistic="upper/lower sideband power [dB]")
    if m.sum() < 2 * cfg.block_cpis:
        res.testable = False
        res.evidence = {
            "reason": f"usable sideband pairs (median >= {cfg.min_pair_snr:g} dB over the floor) "
            f"in {int(m.sum())} CPIs (expected >= {2 * cfg.block_cpis}, two folds)"
        }
        return res
    d = DB * np.log(U[m] / L[m])
    f = fold[m]

    def fit(sel):
        x = d[sel]
        return float(x.mean()), float(np.mean(x**2)) + 1e-6, float(x.var()) + 1e-6

    def score(th, sel):
        mu, vb, ve = th
        return _gauss_ll(d[sel], 0.0, vb), _gauss_ll(d[sel], mu, ve)

    _crossfit(f, fit, score, res)
    a = float(np.median(d))
    res.params = {"asymmetry_db": a}
    res.effect = abs(a)
    res.relevant = abs(a) >= cfg.margin_asymmetry_db
    per = {}
    for k, n in enumerate(M.harm):
        mk = M.valid & M.pair_ok[:, k] & (M.up[:, k] > 0) & (M.lo[:, k] > 0)
        if mk.sum() >= 4:
            per[f"h{int(n)}"] = round(float(np.median(DB * np.log(M.up[mk, k] / M.lo[mk, k]))), 2)
    res.evidence = {"asymmetry_db": round(a, 2), "asymmetry_per_harmonic_db": per, "n_pairs_used": int(use.sum())}
    res.series = {"t_s": M.t_s[m], "stat": d, "base": np.zeros_like(d), "ext": np.full_like(d, a)}
    return res


def asymmetry_envelope(asymmetry_db: float):
    """``envelope(f_hz) -> gain`` (float32): upper/lower sideband power 10^(a/10)."""
    up = np.float32(10.0 ** (asymmetry_db / 40.0))
    lo = np.float32(10.0 ** (-asymmetry_db / 40.0))

    def env(f_hz: np.ndarray) -> np.ndarray:
        f_hz = np.asarray(f_hz)
        g = np.where(f_hz > 0, up, lo).astype(np.float32)
        g[f_hz == 0] = 1.0
        return g

    return env


def world_envelope(asymmetry_db: float):
    """The emulator's envelope ``g(f)`` relative to the body Doppler: upper/lower
    power ratio 10^(a/10) (float32)."""
    up = 10.0 ** (asymmetry_db / 40.0)
    lo = 10.0 ** (-asymmetry_db / 40.0)

    def env(f_hz: np.ndarray) -> np.ndarray:
        g = np.where(f_hz > 0, up, lo)
        g = np.where(f_hz == 0, 1.0, g)
        return g.astype(np.float32)

    return env


class SidebandAsymmetry(CauseSpec):
    name = NAME
    meaning = "HERM sidebands above the body Doppler are stronger (or weaker) than their mirrors below"
    params = (
        Param(
            "asymmetry_db",
            "dB",
            "10 log10(power of upper sidebands / power of the mirror lower sidebands); positive = upper stronger",
            "|asymmetry_db| >= 3",
        ),
    )
    observations = ("up", "lo", "pair_ok", "usable_pairs", "valid", "harm", "t_s")
    line = "rotor"
    reads_sidebands = True
    margin_field = "margin_asymmetry_db"

    def test(self, M, cfg, fold, given=frozenset()):
        return test_asymmetry(M, cfg, fold)

    def model_extension(self, p, *, duration_s, seed):
        return {"envelope_gain": asymmetry_envelope(p["asymmetry_db"])}

    def world_envelope(self, p):
        return world_envelope(p["asymmetry_db"])


CAUSE = SidebandAsymmetry()

"""``blade_imbalance``: the blades of a propeller do not scatter alike.

- catalog: ``imbalance_db`` [dB], how far the weakest blade's scattering amplitude
  lies below the mean of the others;
- test (:func:`test_imbalance`): lines at the rotation harmonics that are not
  multiples of the blade count, relative to the blade-passing lines beside them;
- a floor partner: named, its rotation lines enter the model of the floor under the
  sidebands (:func:`.measure.given_imbalance`);
- twins: blade 0 of every rotor scatters 10^(-imbalance_db/20) of the others
  (:func:`twin_amplitudes`, amplitudes scaled to sum to the blade count);
- emulator: one weak blade on every rotor (:func:`imbalance_amplitudes`).
"""

from __future__ import annotations

import numpy as np

from .base import CauseSpec, Param
from .config import DiagnosisConfig
from .heldout import CauseTest, _crossfit, _gauss_ll, _ml_extra_var
from .measure import DB, given_imbalance

NAME = "blade_imbalance"


def imbalance_from_ratio(r: float, n_blades: int) -> float:
    """``imbalance_db`` of one blade of amplitude a (the others 1) whose lines at the
    non-multiples of the blade count stand r below the blade-passing lines.

    Rotation harmonic k of the rotor is the single blade's, c_k, times
    sum_b a_b exp(j 2 pi k b / B): B - 1 + a for k a multiple of B, a - 1 otherwise,
    so r = ((1 - a) / (B - 1 + a))^2 and a = (1 - (B - 1) q) / (1 + q), q = sqrt(r).
    Returns -20 log10(a) [dB] (0 for r <= 0); NaN when r >= 1 / (B - 1)^2, more than
    one blade alone can make (a <= 0)."""
    if not np.isfinite(r) or r <= 0:
        return 0.0
    q = float(np.sqrt(r))
    a = (1 - (n_blades - 1) * q) / (1 + q)
    return float(-20 * np.log10(a)) if a > 0 else float("nan")


#: the level of the imbalance's interval (its bootstrap resamples:
#: ``DiagnosisConfig.n_boot``)
INTERVAL_LEVEL = 0.95


def imbalance_interval(z, idx, n_blades: int, block_cpis: int, seed: int, n_boot: int | None = None) -> dict:
    """The interval of ``imbalance_db`` the flight's data allow: the median ratio of
    the non-multiple lines to the blade-passing lines (``z``, one per observation,
    ``idx`` its CPI) resampled by blocks of ``block_cpis`` CPIs (the CPIs of a block
    are correlated; the flight's blocks are the unit), through
    :func:`imbalance_from_ratio`, which is monotonic in the ratio; ``n_boot``
    resamples (default ``DiagnosisConfig.n_boot``).

    Returns ``{"low": dB, "high": dB or None, "bound": "two-sided" | "lower" |
    "upper", "level": 0.95, "meaning": ...}``. Where the ratio's upper end reaches what
    one blade alone makes (the non-multiple lines as strong as the blade-passing ones:
    one blade dominates), the data bound the imbalance from below only (``high`` None,
    ``bound`` "lower"); where its lower end reaches 0, from above only."""
    cpis = np.unique(idx)
    blocks = [cpis[i : i + block_cpis] for i in range(0, len(cpis), max(int(block_cpis), 1))]
    members = [np.flatnonzero(np.isin(idx, b)) for b in blocks]
    n_boot = DiagnosisConfig().n_boot if n_boot is None else n_boot
    rng = np.random.default_rng(seed)
    r = np.empty(n_boot)
    for i in range(n_boot):
        pick = rng.integers(0, len(members), len(members))
        r[i] = max(float(np.median(z[np.concatenate([members[j] for j in pick])])), 0.0)
    q = (1 - INTERVAL_LEVEL) / 2
    r_lo, r_hi = np.quantile(r, [q, 1 - q])
    lo, hi = imbalance_from_ratio(float(r_lo), n_blades), imbalance_from_ratio(float(r_hi), n_blades)
    top = not np.isfinite(hi)  # the ratio's upper end: more than one blade alone can make, or one blade alone
    if not np.isfinite(lo):  # even the lower end: the lines are no imbalance
        return {
            "low": None,
            "high": None,
            "bound": "none",
            "level": INTERVAL_LEVEL,
            "meaning": "the non-multiple lines stand at or above the blade-passing lines: no imbalance of "
            "one blade makes that",
        }
    bound = "lower" if top else ("upper" if lo <= 0 else "two-sided")
    meaning = {
        "lower": f"one blade dominates: its imbalance is at least {lo:.1f} dB; the noise does not let "
        "the data say how much more",
        "upper": f"the imbalance is at most {hi:.1f} dB; the data cannot tell it from none",
        "two-sided": f"{INTERVAL_LEVEL:.0%} interval of the weakest blade's amplitude below the others",
    }[bound]
    return {
        "low": round(float(lo), 2),
        "high": None if top else round(float(hi), 2),
        "bound": bound,
        "level": INTERVAL_LEVEL,
        "meaning": meaning,
    }


def imbalance_observations(M):
    """The blade-imbalance test's observations, one per (CPI, non-multiple order k,
    side): the measured power ``x`` of the rotors' lines of order k, its noise variance
    ``v0`` and variance per unit line power ``w``, and the reference ``ref``: the
    blade-passing lines on both sides of k (geometric mean), each divided by one thin
    wire's line power and the pair multiplied by order k's (:func:`.measure.thin_wire_line_power`),
    so the envelope exp(-alpha |f|) and the wire's own line powers cancel, scaled by
    the share of rotors whose line of order k is clear. Returns flat arrays and each
    observation's CPI index (:func:`non_multiple_observations` of ``M``'s rotation lines)."""
    return non_multiple_observations(
        M.rot_pow, M.rot_var, M.rot_cross, M.rot_n, M.rot_wire, M.info["n_blades"], M.log.n_motors
    )


def non_multiple_observations(P, V, W, R, c2, n_blades: int, n_motors: int, *, min_z: float = 0.0):
    """:func:`imbalance_observations` from the arrays of
    :func:`.measure.rotation_line_powers` (``P``, ``V``, ``W``, ``R``: [n_t, K, 2]) and one
    wire's line powers ``c2`` [K + 1]; with ``min_z`` > 0 only where both blade-passing
    lines stand ``min_z`` noise standard deviations above the floor."""
    B = int(n_blades)
    out = [[], [], [], [], []]
    for k in range(1, P.shape[1] + 1):
        n1 = (k // B) * B
        n2 = n1 + B
        if k % B == 0 or n1 < 1 or n2 > P.shape[1]:
            continue
        for s in (0, 1):
            a, b = P[:, n1 - 1, s], P[:, n2 - 1, s]
            with np.errstate(invalid="ignore", divide="ignore"):
                ref = (
                    np.sqrt(np.clip(a, 0, None) * np.clip(b, 0, None))
                    * c2[k]
                    / np.sqrt(c2[n1] * c2[n2])
                    * R[:, k - 1, s]
                    / n_motors
                )
                seen = (a > min_z * np.sqrt(V[:, n1 - 1, s])) & (b > min_z * np.sqrt(V[:, n2 - 1, s]))
            x = P[:, k - 1, s]
            ok = (
                np.isfinite(x)
                & np.isfinite(ref)
                & (ref > 0)
                & (R[:, n1 - 1, s] == n_motors)
                & (R[:, n2 - 1, s] == n_motors)
                & seen
            )
            i = np.flatnonzero(ok)
            for lst, arr in zip(out, (x[i], V[i, k - 1, s], W[i, k - 1, s], ref[i], i)):
                lst.append(arr)
    x, v0, w, ref, idx = (np.concatenate(z) if z else np.zeros(0) for z in out)
    return x, v0, w, ref, idx.astype(int)


def test_imbalance(M, cfg, fold) -> CauseTest:
    """Lines at non-multiples of the blade count (:func:`imbalance_observations`),
    relative to the blade-passing lines beside them: eq. (1)'s identical blades make
    none (base: mean 0), a weak or strong blade makes them r below (extended: mean r;
    :func:`imbalance_from_ratio` turns r into ``imbalance_db``). Both models carry the
    noise variance and an extra variance fitted on the training fold (ML); r is the
    training fold's median ratio."""
    res = CauseTest(NAME, statistic="non-multiple / blade-passing line power")
    B = M.info["n_blades"]
    if M.rot_pow is None:
        res.testable = False
        res.evidence = {"reason": "rotation harmonics not measured"}
        return res
    x, v0, w, ref, idx = imbalance_observations(M)
    f = fold[idx] if len(idx) else np.zeros(0, int)
    n_cpi = len(np.unique(idx))
    if n_cpi < cfg.block_cpis or len(np.unique(f)) < 2:
        res.testable = False
        res.evidence = {
            "reason": f"blade-passing lines on both sides of a non-multiple order, clear of "
            f"other lines, in {n_cpi} CPIs (expected >= {cfg.block_cpis}, two folds)"
        }
        return res
    z = x / ref
    vz0 = v0 / ref**2
    wz = w / ref

    def fit(sel):
        r = max(float(np.median(z[sel])), 0.0)
        vb = _ml_extra_var(z[sel], vz0[sel])
        ve = _ml_extra_var(z[sel] - r, vz0[sel] + wz[sel] * r)
        return r, vb, ve

    def score(th, sel):
        r, vb, ve = th
        return (
            _gauss_ll(z[sel], 0.0, vz0[sel] + vb + 1e-12),
            _gauss_ll(z[sel], r, vz0[sel] + wz[sel] * r + ve + 1e-12),
        )

    _crossfit(f, fit, score, res)
    r = max(float(np.median(z)), 0.0)
    imb = imbalance_from_ratio(r, B)
    res.params = {"imbalance_db": imb if np.isfinite(imb) else float("nan")}
    res.effect = imb if np.isfinite(imb) else 0.0
    res.relevant = bool(np.isfinite(imb) and imb >= cfg.margin_imbalance_db)
    res.evidence = {
        "ratio_db": round(float(DB * np.log(max(r, 1e-12))), 2),
        "n_blades": int(B),
        "n_cpis": int(n_cpi),
        "n_lines": int(len(z)),
        "intervals": {"imbalance_db": imbalance_interval(z, idx, B, cfg.block_cpis, cfg.seed, cfg.n_boot)},
    }
    if not np.isfinite(imb):
        res.evidence["reason"] = (
            f"the non-multiple lines stand {DB * np.log(r):.1f} dB from the blade-passing "
            "lines: more than one weak or strong blade can make, not an imbalance"
        )
    cpi_r = np.array([np.median(z[idx == i]) for i in np.unique(idx)])
    res.series = {
        "t_s": M.t_s[np.unique(idx)],
        "stat": DB * np.log(np.clip(cpi_r, 1e-6, None)),
        "base": np.full(n_cpi, -60.0),
        "ext": np.full(n_cpi, DB * np.log(max(r, 1e-6))),
    }
    return res


def twin_amplitudes(imbalance_db: float, n_blades: int) -> np.ndarray:
    """Each blade's scattering amplitude of a twin (float [n_blades]): blade 0 at
    10^(-imbalance_db/20) of the others, all scaled so that they sum to
    ``n_blades``, so the blade-passing lines (which sum the blades) keep the
    calibrated level and only the lines between them appear."""
    a = 10 ** (-imbalance_db / 20)
    amps = np.ones(int(n_blades))
    amps[0] = a
    return amps * n_blades / amps.sum()


def imbalance_amplitudes(imbalance_db: float, n_blades: int, weak_blade: int = 0) -> tuple:
    """Per-blade scattering amplitudes of a rotor with one weak blade: blade
    ``weak_blade`` at 10^(-imbalance_db/20) of the others, all scaled to sum to
    ``n_blades`` (float tuple [n_blades]). For two blades a weak blade is the same as a
    strong one (only the amplitude ratio shows)."""
    if n_blades < 1 or not 0 <= weak_blade < n_blades:
        raise ValueError(f"weak_blade={weak_blade} must index one of n_blades={n_blades} blades")
    amps = np.ones(int(n_blades))
    amps[weak_blade] = 10.0 ** (-float(imbalance_db) / 20.0)
    return tuple(float(a) for a in amps * n_blades / amps.sum())


class BladeImbalance(CauseSpec):
    name = NAME
    meaning = (
        "the blades of a propeller do not scatter alike (a tagged, chipped, bent or differently pitched "
        "blade): lines at multiples of the rotation rate that are not multiples of the blade-passing rate"
    )
    params = (
        Param(
            "imbalance_db",
            "dB",
            "how far the weakest blade's scattering amplitude lies below the mean of "
            "the propeller's other blades, 20 log10 of the amplitude ratio, positive",
            ">= 3",
        ),
    )
    observations = ("rot_pow", "rot_var", "rot_cross", "rot_n", "rot_wire", "log", "info", "t_s")
    line = "rotor"
    floor_partner = True
    floor_stage = 0  # its lines enter the floor's model before a skirt does
    margin_field = "margin_imbalance_db"

    def test(self, M, cfg, fold, given=frozenset()):
        return test_imbalance(M, cfg, fold)

    def floor_available(self, test) -> bool:
        # available when testable and favouring the imbalance on held-out data
        return bool(test is not None and test.testable and test.log_e > 0)

    def floor_model(self, M, test, *, clear_side=False):
        return given_imbalance(M)

    def floor_evidence(self, n_new):
        return {"rotation_lines_in_floor_model": True, "pairs_kept_beside_rotation_lines": n_new}

    def blade_amplitudes(self, p, n_blades):
        return twin_amplitudes(p["imbalance_db"], n_blades)

    def world_check(self, full):
        if not 0 <= full["imbalance_db"] <= 60:
            raise ValueError(f"{NAME}: imbalance_db={full['imbalance_db']} must be in [0, 60] dB")

    def world_blade_amplitudes(self, p, n_blades):
        return imbalance_amplitudes(p["imbalance_db"], n_blades)

    def calibration_measurement(self, M):
        # the model calibrated with the imbalance's rotation lines in the sidebands'
        # floor model (without it a weak blade can leave no pair to calibrate on)
        return given_imbalance(M)


CAUSE = BladeImbalance()

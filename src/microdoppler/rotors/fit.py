"""Rotor speeds by least squares on the slow-time I/Q: the harmonic-chirp model of one CPI.

:mod:`microdoppler.rotors.speed` reads each rotor's speed from the HERM lines of a
periodogram. Where rotors turn within a bin of each other and their speeds drift within
the CPI, their lines merge into one smeared band whose power does not tell how many
rotors it holds (the estimator's tail). This module fits the CPI's samples themselves.

A rotor of B blades turning with phase theta_r(t) returns a periodic function of
B theta_r (eq. (1): the blades flash in turn), so its echo is a Fourier series
sum_n c_rn exp(j n B theta_r(t)) riding on the body's Doppler phase psi(t). Over one CPI
both phases are taken quadratic (a speed and a rate of change):

    x(t) ~ exp(j psi(t)) [c_0 + sum_r sum_{0 < |n| <= N} c_rn exp(j n B theta_r(t))] + clutter,
    psi(t) = 2 pi (f_b t + a_b t^2 / 2),  theta_r(t) = 2 pi (f_r t + g_r t^2 / 2),

with t from the CPI's centre, the complex amplitudes c linear (projected out: variable
projection) and (f_b, a_b, f_r, g_r) fitted by Gauss-Newton with Levenberg damping
(Kaufman's Jacobian), the residual weighted by the STFT's Blackman-Harris window so
that f_r is the window^2-weighted mean speed a periodogram line measures. A weak
Gaussian prior ties each g_r to the group's rate from the neighbouring CPIs
(``chirp_sd_rev_s2``); a low-order polynomial absorbs the clutter at zero Doppler.
Every harmonic of every rotor shares its rotor's two parameters, so the rotor count per
line, the periodogram's ambiguity, is not a choice here: each of the M rotors is fitted.

Starts: the periodogram's lines (:mod:`microdoppler.rotors.speed`). With k < M distinct
lines every composition of M rotors on them is tried (at two spreads around each shared
line), first with ``harmonics[0]`` harmonics (a wide basin), the ``keep`` best carried on
to ``harmonics[-1]``. A fit whose weakest rotor has under ``min_power`` of the strongest
rotor's power holds a spare rotor (its true lines coincide with another rotor's) and
loses against one that does not; the weakest rotor is then re-seeded ``reseed`` times at
the strongest harmonic comb of the residual, and a spare rotor left at the end is put on
the strongest line (per rotor already there): the speed of a spare is not measured. At
the end a weak rotor counts as a spare only if the fit also loses little without it
(dropping its columns raises the residual by under ``min_power`` of the most any rotor
raises it): two rotors' models within a fraction of a bin trade large opposite
amplitudes, and beside their inflated powers a rotor on lines of its own looked weak and
was moved onto another line (1-5 % errors in the mean). A fit leaving the lines' range by
more than ``bound_bins`` is dropped (the periodogram's estimate stands).

A rotor the periodogram's lines missed (its line smeared below the pair threshold, or
shown as part of a split line) leaves every start with a rotor on a line that is not
its own; where no spare results, or the rotor turns beyond the re-seeding window, the
steps above stop there. Last, the residual's strongest harmonic comb within
``move_rel`` of the re-seeding window's centre (a quadcopter's rotors differ by up to ~15 % in a
manoeuvre) is tried in place of each of the ``move_tries`` weakest rotors, the best fit
kept where it lowers the cost, ``move_passes`` times (keep ``move_rel`` under 0.2: at
25 % a rotor settled at 4/5 of a true rotor's speed, its fifth harmonic on the true
rotor's fourth, and fitted better than the truth). The moves recover part of the fits
that a start at the true speeds would have bettered (``benchmarks/bound_rotorspeed.py``).
A re-seeded or moved rotor is kept only if it lights its harmonic orders as the other
rotors do (:func:`_comb_like`): the residual also holds lines the model does not (the
rotation-rate lines of unequal blades, the orders beyond ``harmonics[-1]`` of a wide
blade flash), and a comb placed on one of them matches it at one order only; kept, such
a rotor would move the mean several per cent off.

Cost: the model's columns reach the body's Doppler plus ``harmonics[-1]`` blade-passing
orders of the fastest rotor a fit may try; every product is formed on the CPI's samples
decimated to that band (:class:`_Model`: the data low-passed by an FFT mask, every D-th
sample kept, the power outside the band a constant of the residual), which gives the
full-rate cost and J^T J up to the window's leakage at 1 / D of the work; the residual's
comb is read at the full-rate FFT's bins, so the searches take the same paths (D = 3 for
4 two-blade rotors at 10 kHz PRF, 3.3 GHz, flying, which about halves the cost).

Uncertainty: the Gauss-Newton covariance (residual variance times the inverse of
J^T J with the prior), plus the spread of the mean over the lines a spare rotor could
share, plus a relative floor ``rel_floor`` for what the quadratic phase does not
capture, plus the composition's ambiguity. That covariance holds only if every rotor
sits on its own true lines; where it does not (two rotors within a fraction of a bin
fitted as one line, and another rotor on a line of its own that is not a rotor's), the
error is a large part of a bin, not a small multiple of sigma. The rotors of one drone
return about equal power, so the fit's balance (its weakest rotor's power over its
strongest's, in [0, 1]) tells how far to trust the composition: a balanced fit is
within a fraction of a bin, an unbalanced one may be off by about a bin. The ambiguity
term is ``ambiguity_bins`` x exp(-balance / ``ambiguity_scale``)
bins of the first harmonic for the mean speed, at most ``ambiguity_max_bins`` (where a
spare is left, the spread over the lines it could share is already in sigma), and
``ambiguity_rotor_*`` for each ranked rotor; calibrated on emulated flights so that
95 % of the errors lie within 2 sigma at every balance (``benchmarks/eval_rotorspeed.py``).
Sigma is then a scale, not a Gaussian one-sigma: the errors are a sharp core plus a
tail, and most of them lie well within 1 sigma.

Where the periodogram showed one sideband pair only (``n_pairs=1``), the composition is
far less certain at every balance: the rotors' lines are read from one harmonic, and a
rotor on another rotor's line or on a line that is none of theirs is off by one to
several bins (one bin at n = 1 is ~1.2 % of the speed). Such a fit adds
``one_pair_bins`` x exp(-balance / ``one_pair_scale``) bins to the mean's sigma and
``one_pair_rotor_*`` to each ranked rotor's, calibrated on the one-pair CPIs of
emulated flights so that 95 % of their errors lie within 2 sigma. Such a sigma is wide
(a few per cent of the speed for the mean) because the errors are.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.signal import czt
from scipy.linalg import cho_solve, cholesky
from scipy.linalg.blas import zgemm, zgemv, zherk
from threadpoolctl import threadpool_limits

from ..configfields import check_ranges, knob
from ..spectra.periodogram import window


@dataclass(frozen=True)
class FitConfig:
    """Settings of :func:`refine_cpi` (see the module docstring).

    The fields from ``iterations`` on are the fit's fixed settings, not physical knobs:
    its search effort and its calibrated uncertainty terms, each described by its field
    (how each was set: ``docs/experiments.md``, "Where the code's settings come from";
    the benchmark that measures the fit with them: ``benchmarks/eval_rotorspeed.py``;
    ``benchmarks/bound_rotorspeed.py --fit NAME=VALUE`` sets them for experiments).

    Parameters
    ----------
    harmonics : tuple of int
        Harmonics per rotor and side in the model: starts are screened with
        ``harmonics[0]`` (a wide basin), the best carried through the others; the last
        is the final model order (a non-empty tuple of integers >= 1).
    chirp_sd_rev_s2 : float
        Prior standard deviation of each rotor's rate of change about the group's
        [rev/s^2], > 0.
    min_power : float
        A rotor with under this fraction of the strongest rotor's sideband power (and of
        what the fit loses without the strongest) is a spare whose lines coincide with
        another's: a drone's rotors return about equal power. In [0, 1).
    reseed_rel : float
        Relative half-width around the lines' centre in which a spare rotor is
        re-seeded at the residual's strongest comb: the rotors' spread about the group
        speed.
    move_rel : float
        Relative half-width in which a rotor the periodogram missed is searched (a
        quadcopter's rotors differ by up to ~15 % in a manoeuvre); keep it under 0.2,
        where a rotor can settle at 4/5 of a true one's speed.
    """

    harmonics: tuple = (2, 5)
    chirp_sd_rev_s2: float = 10.0
    min_power: float = 0.15
    reseed_rel: float = 0.12
    move_rel: float = 0.16
    iterations: int = knob(
        10,
        "Gauss-Newton iterations per fit; a fit stops earlier once its cost falls by under ``tolerance`` (relative).",
        minimum=0,
        config=False,
    )
    screen_iterations: int = knob(
        4, "Gauss-Newton iterations per screening fit of a start (with ``harmonics[0]``).", minimum=0, config=False
    )
    tolerance: float = knob(1e-5, "A fit stops once its cost falls by under this (relative).", minimum=0, config=False)
    keep: int = knob(2, "Screened starts carried on to the full harmonics.", minimum=1, config=False)
    spreads_bins: tuple = knob(
        (0.6, 1.5), "Spreads [bins of the first harmonic] at which rotors sharing a line start.", config=False
    )
    bound_bins: float = knob(
        5.0,
        "A fit whose rotors leave the lines' range by more than this [bins] is dropped and the periodogram's "
        "estimate stands.",
        minimum=0,
        config=False,
    )
    reseed: int = knob(
        3, "Times the weakest rotor is re-seeded at the residual's strongest comb.", minimum=0, config=False
    )
    move_passes: int = knob(
        2,
        "The residual's comb is tried in place of each of the ``move_tries`` weakest rotors, at most "
        "``move_passes`` times (0: no moves).",
        minimum=0,
        config=False,
    )
    move_tries: int = knob(2, "Weakest rotors tried per pass of the moves (``move_passes``).", minimum=0, config=False)
    comb_similarity: float = knob(
        0.45,
        "A re-seeded or moved rotor's harmonic-order profile must match the other rotors' at least this well "
        "(Bhattacharyya coefficient), and spread over its orders at least ``comb_spread`` x the others' spread - "
        "``comb_slack`` (:func:`_comb_like`).",
        minimum=0,
        maximum=1,
        config=False,
    )
    comb_spread: float = knob(0.5, "See ``comb_similarity``.", minimum=0, config=False)
    comb_slack: float = knob(0.1, "See ``comb_similarity``.", minimum=0, config=False)
    rel_floor: float = knob(
        0.0004, "Relative uncertainty floor for what the quadratic phase does not capture.", minimum=0, config=False
    )
    ambiguity_bins: float = knob(
        5.3,
        "The composition's ambiguity by the fit's balance b (module docstring): the mean's sigma adds "
        "min(``ambiguity_bins`` exp(-b / ``ambiguity_scale``), ``ambiguity_max_bins``) bins, each ranked rotor's "
        "``ambiguity_rotor_bins`` exp(-b / ``ambiguity_rotor_scale``); calibrated on emulated flights so that "
        "95 % of errors lie within 2 sigma at every balance.",
        minimum=0,
        config=False,
    )
    ambiguity_scale: float = knob(0.13, "See ``ambiguity_bins``.", exclusive_minimum=0, config=False)
    ambiguity_max_bins: float = knob(2.0, "See ``ambiguity_bins``.", minimum=0, config=False)
    ambiguity_rotor_bins: float = knob(4.0, "See ``ambiguity_bins``.", minimum=0, config=False)
    ambiguity_rotor_scale: float = knob(0.21, "See ``ambiguity_bins``.", exclusive_minimum=0, config=False)
    one_pair_bins: float = knob(
        4.25,
        "The same as ``ambiguity_*`` for CPIs with one visible pair (in quadrature on top), calibrated on the "
        "one-pair CPIs of emulated flights to the same 95 % within 2 sigma.",
        minimum=0,
        config=False,
    )
    one_pair_scale: float = knob(0.8, "See ``one_pair_bins``.", exclusive_minimum=0, config=False)
    one_pair_rotor_bins: float = knob(13.0, "See ``one_pair_bins``.", minimum=0, config=False)
    one_pair_rotor_scale: float = knob(0.6, "See ``one_pair_bins``.", exclusive_minimum=0, config=False)
    band_margin: float = knob(
        1.0,
        "The fit runs on the CPI's samples decimated to the model's band (:class:`_Model`): its half-width is the "
        "body's Doppler plus ``harmonics[-1]`` blade-passing orders of the fastest rotor a fit may reach, times "
        "``band_margin``, plus ``band_bins`` bins (the Blackman-Harris window's main lobe and the chirps); 0 fits "
        "every sample (this changes the cost, not the result).",
        minimum=0,
        config=False,
    )
    band_bins: int = knob(16, "See ``band_margin``.", minimum=0, config=False)

    def __post_init__(self):
        check_ranges(self, "rotors.fit", all_fields=True)  # every knob's range, config=False ones too
        if not self.spreads_bins or any(not sp > 0 for sp in self.spreads_bins):
            raise ValueError(f"spreads_bins={self.spreads_bins} must be a non-empty tuple of numbers > 0")
        h = tuple(self.harmonics)
        if not h or any(int(n) != n or n < 1 for n in h):
            raise ValueError(f"harmonics={self.harmonics} must be a non-empty tuple of integers >= 1")
        if not self.chirp_sd_rev_s2 > 0:
            raise ValueError(f"chirp_sd_rev_s2={self.chirp_sd_rev_s2} must be > 0")
        if not 0 <= self.min_power < 1:
            raise ValueError(f"min_power={self.min_power} must be in [0, 1)")
        if not (0 <= self.reseed_rel < 1 and 0 <= self.move_rel < 1):
            raise ValueError(f"reseed_rel={self.reseed_rel} and move_rel={self.move_rel} must be in [0, 1)")


@dataclass(frozen=True)
class CpiFit:
    """One CPI's fit: rotor speeds [rev/s] ascending, their one-sigma, the mean's
    one-sigma, how the winning start was found, and the balance (the weakest fitted
    rotor's power over the strongest's, before a spare joins a line)."""

    speeds_rev_s: np.ndarray
    speeds_std_rev_s: np.ndarray
    mean_std_rev_s: float
    start: str
    balance: float


class _Model:
    """The harmonic-chirp model of one CPI (``x``: complex samples, ``prf``).

    With ``band_hz`` (the half-width about 0 Hz that holds every column the fit may
    build) the samples are decimated by the largest D with 2 ``band_hz`` < PRF / D: the
    data low-passed to the band (FFT mask) and every D-th sample, the window and the
    data scaled by sqrt(D). Inner products of band-limited columns with band-limited
    data are then the full-rate ones (the product's spectrum, within +-2 band, does not
    alias at PRF / D), and the data outside the band, orthogonal to every column, add a
    constant to the residual power (``out_power``): the cost, its gradient and J^T J
    are the full-rate ones up to the window's leakage (-92 dB), at 1 / D of the work."""

    def __init__(self, x: np.ndarray, prf: float, B: int, M: int, cfg: FitConfig, band_hz: float | None = None):
        n = len(x)
        tt = (np.arange(n) - n / 2) / prf
        w = window(n)
        y = np.asarray(x, np.complex128) * w
        self.out_power = 0.0
        D = int(np.ceil(prf / (2 * band_hz))) - 1 if band_hz and band_hz > 0 else 1
        if D > 1:
            Y = np.fft.fft(y)
            keep = np.abs(np.fft.fftfreq(n, 1 / prf)) <= band_hz
            self.out_power = float(np.sum(np.abs(Y[~keep]) ** 2)) / n
            y = np.sqrt(D) * np.fft.ifft(np.where(keep, Y, 0))[::D]
            tt, w = tt[::D], np.sqrt(D) * w[::D]
        self.decimation = max(D, 1)
        self.prf, self.n_full = float(prf), n
        self.tt, self.w, self.y = tt, w, y
        n = len(tt)
        # d(phase)/d(f_b, a_b, f_r, g_r) factors of the Jacobian's columns
        tt = self.tt
        self._dphase = (2j * np.pi * tt, 1j * np.pi * tt**2, 2j * np.pi * B * tt, 1j * np.pi * B * tt**2)
        self.B, self.M, self.cfg = B, M, cfg
        s = self.tt / self.tt.max()
        self.clutter = self.w[:, None] * np.column_stack([np.ones(n), s, s * s])
        self.g0 = 0.0
        self.s2 = 0.0
        self.power = np.ones(M)

    def build(self, p: np.ndarray, N: int) -> np.ndarray:
        """The model's columns at ``p`` with ``N`` harmonics [n, 1 + M 2N + 3], in
        Fortran order (each column contiguous: filled row by row of its transpose)."""
        tt, B, M = self.tt, self.B, self.M
        eb = self.w * np.exp(2j * np.pi * (p[0] * tt + 0.5 * p[1] * tt**2))
        K = 2 * N
        AT = np.empty((1 + M * K + 3, len(tt)), complex)
        AT[0] = eb
        pw = np.empty((N, len(tt)), complex)
        for r in range(M):
            e1 = np.exp(2j * np.pi * B * (p[2 + r] * tt + 0.5 * p[2 + M + r] * tt**2))
            pw[0] = e1
            for k in range(1, N):
                np.multiply(pw[k - 1], e1, out=pw[k])
            base = 1 + r * K
            np.multiply(eb, pw[::-1].conj(), out=AT[base : base + N])  # n = -N .. -1
            np.multiply(eb, pw, out=AT[base + N : base + K])  # n = 1 .. N
        AT[-3:] = self.clutter.T
        return AT.T

    def solve(self, A: np.ndarray):
        """Least squares of ``y`` on the columns of ``A`` by the normal equations (the
        Gram matrix from BLAS's Hermitian rank-k update, half a general product's work):
        (Cholesky factor as cho_solve takes it, amplitudes, residual, residual power)."""
        # A^H A's upper triangle (the lower is never read: Cholesky from the upper);
        # fastest on a Fortran-ordered A (what build returns: no copy)
        G = zherk(1.0, A, trans=2, lower=0)
        G[np.diag_indices_from(G)] += 1e-9 * np.trace(G).real / len(G)
        U = (cholesky(G, lower=False, check_finite=False), False)
        c = cho_solve(U, zgemv(1.0, A, self.y, trans=2), check_finite=False)  # A^H y
        r = self.y - A @ c
        return U, c, r, float(np.vdot(r, r).real) + self.out_power

    def prior(self, p: np.ndarray) -> float:
        d = (p[2 + self.M :] - self.g0) / self.cfg.chirp_sd_rev_s2
        return float(0.5 * self.s2 * np.sum(d * d))

    def _jacobian(self, p, A, L, c, ns):
        """Kaufman's Jacobian of the projected residual, stacked real/imaginary [2n, P]."""
        M, tt = self.M, self.tt
        K = len(ns)
        mb = A[:, : 1 + M * K] @ c[: 1 + M * K]
        D = np.empty((len(tt), 2 + 2 * M), complex, order="F")
        d = self._dphase
        np.multiply(d[0], mb, out=D[:, 0])
        np.multiply(d[1], mb, out=D[:, 1])
        for q in range(M):
            sl = slice(1 + q * K, 1 + (q + 1) * K)
            s = A[:, sl] @ (ns * c[sl])
            np.multiply(d[2], s, out=D[:, 2 + q])
            np.multiply(d[3], s, out=D[:, 2 + M + q])
        J = -(D - A @ cho_solve(L, zgemm(1.0, A, D, trans_a=2), check_finite=False))  # A^H D
        return np.vstack([J.real, J.imag])

    def fit(self, p: np.ndarray, N: int, iterations: int | None = None):
        """Gauss-Newton from ``p`` with ``N`` harmonics: (p, cost). Leaves J^T J (with
        the prior), the amplitudes, residual and per-rotor power at the result."""
        cfg, M = self.cfg, self.M
        iterations = cfg.iterations if iterations is None else iterations
        ns = np.r_[np.arange(-N, 0), np.arange(1, N + 1)].astype(float)
        K = len(ns)
        A = self.build(p, N)
        L, c, r, cost = self.solve(A)
        cost += self.prior(p)
        lam = 1e-3
        gi = np.arange(2 + M, 2 + 2 * M)
        prior_h = 0.5 * self.s2 / cfg.chirp_sd_rev_s2**2
        for _ in range(iterations):
            Jr = self._jacobian(p, A, L, c, ns)
            JtJ = Jr.T @ Jr
            JtJ[gi, gi] += prior_h
            g = Jr.T @ np.r_[r.real, r.imag]
            g[gi] += prior_h * (p[gi] - self.g0)
            sc = np.sqrt(np.diag(JtJ)) + 1e-30
            accepted, rel = False, 0.0
            for _try in range(6):
                d = -np.linalg.solve(JtJ / np.outer(sc, sc) + lam * np.eye(len(p)), g / sc) / sc
                pn = p + d
                An = self.build(pn, N)
                Ln, cn, rn, costn = self.solve(An)
                costn += self.prior(pn)
                if costn < cost:
                    rel = (cost - costn) / cost
                    p, A, L, c, r, cost = pn, An, Ln, cn, rn, costn
                    lam = max(lam / 4, 1e-8)
                    accepted = True
                    break
                lam *= 6
            if not accepted or rel < cfg.tolerance:
                break
        self.power = np.array([np.sum(np.abs(c[1 + q * K : 1 + (q + 1) * K]) ** 2) for q in range(M)])
        self.c, self.A, self.r, self._L, self._ns = c, A, r, L, ns
        return p, cost

    def information(self, p: np.ndarray) -> np.ndarray:
        """J^T J with the prior at ``p`` (after :meth:`fit` at ``p``)."""
        Jr = self._jacobian(p, self.A, self._L, self.c, self._ns)
        JtJ = Jr.T @ Jr
        gi = np.arange(2 + self.M, 2 + 2 * self.M)
        JtJ[gi, gi] += 0.5 * self.s2 / self.cfg.chirp_sd_rev_s2**2
        return JtJ

    def drop_power(self) -> np.ndarray:
        """What each rotor adds to the last :meth:`fit` [M]: the rise of its residual
        when the rotor's columns are dropped and the rest re-projected."""
        A, K = self.A, len(self._ns)
        base = float(np.vdot(self.r, self.r).real) + self.out_power
        out = np.empty(self.M)
        for q in range(self.M):
            keep = np.ones(A.shape[1], bool)
            keep[1 + q * K : 1 + (q + 1) * K] = False
            out[q] = self.solve(A[:, keep])[3] - base
        return out

    def comb_peak(self, r: np.ndarray, p: np.ndarray, N: int, lo: float, hi: float, step: float) -> float:
        """Speed [rev/s] in [lo, hi] where the residual's harmonic comb is strongest: the
        power of the residual (without the body's Doppler, each order's chirp removed) at
        the bins of a 4x zero-padded full-rate FFT nearest n B f (n = 1 .. ``N``, both
        signs), summed. Decimated, the same bins' values come from the chirp z-transform
        of the band-limited samples (their DTFT at those frequencies, over D)."""
        tt, B, D = self.tt, self.B, self.decimation
        z = r * np.exp(-2j * np.pi * (p[0] * tt + 0.5 * p[1] * tt**2))
        nfft = 4 * self.n_full
        prf = 1.0 / (tt[1] - tt[0]) if D == 1 else self.prf
        grid = np.arange(lo, hi, step)
        S = np.zeros(len(grid))
        for n in range(1, N + 1):
            for sign in (1, -1):
                zc = z * np.exp(-1j * sign * np.pi * n * B * self.g0 * tt**2)
                k = np.round(sign * n * B * grid / prf * nfft).astype(int)
                if D == 1:
                    S += (np.abs(np.fft.fft(zc, nfft)) ** 2)[k % nfft]
                else:
                    k0 = int(k.min())
                    Z = czt(
                        zc,
                        int(k.max()) - k0 + 1,
                        w=np.exp(-2j * np.pi * D / nfft),
                        a=np.exp(2j * np.pi * k0 * D / nfft),
                    )
                    S += np.abs(Z[k - k0]) ** 2
        return float(grid[np.argmax(S)])


def _compositions(M: int, k: int):
    for cut in itertools.combinations(range(1, M), k - 1):
        b = (0,) + cut + (M,)
        yield [b[i + 1] - b[i] for i in range(k)]


def refine_cpi(*args, **kwargs) -> CpiFit | None:
    """Fit the harmonic-chirp model to one CPI's samples (:func:`_refine_cpi`, same
    arguments) on one BLAS thread: the fit's products are tall and thin (4096 x ~44),
    where BLAS's threads cost more than they give (3.7x slower on two threads than on
    one, whatever ``OMP_NUM_THREADS`` the caller left)."""
    with threadpool_limits(limits=1, user_api="blas"):
        return _refine_cpi(*args, **kwargs)


def _refine_cpi(
    x: np.ndarray,
    prf: float,
    n_blades: int,
    n_motors: int,
    *,
    body_hz: float,
    body_rate_hz_s: float,
    lines_rev_s,
    rate_rev_s2: float,
    n_pairs: int | None = None,
    config: FitConfig | None = None,
) -> CpiFit | None:
    """Fit the harmonic-chirp model to one CPI's samples ``x``.

    Parameters
    ----------
    x : complex ndarray [n_fft]
        The CPI's slow-time samples.
    prf : float
        Pulse repetition frequency [Hz].
    n_blades, n_motors : int
    body_hz, body_rate_hz_s : float
        Start of the body's Doppler [Hz] and its rate [Hz/s].
    lines_rev_s : sequence of float
        The periodogram's distinct rotor lines [rev/s] (1 to ``n_motors`` of them).
    rate_rev_s2 : float
        The rotor group's rate of change [rev/s^2] (prior mean of each g_r).
    n_pairs : int, optional
        Sideband pairs the periodogram showed; 1 widens sigma (module docstring).

    Returns
    -------
    CpiFit or None
        None where no start stays within ``bound_bins`` of the lines.
    """
    cfg = config or FitConfig()
    B, M = int(n_blades), int(n_motors)
    lines = np.sort(np.asarray(lines_rev_s, float))
    k = len(lines)
    if k == 0 or k > M or not np.all(np.isfinite(lines)):
        return None
    bin_rev = prf / len(x) / B
    Ns = tuple(cfg.harmonics)
    lo, hi = lines[0] - cfg.bound_bins * bin_rev, lines[-1] + cfg.bound_bins * bin_rev
    mid = 0.5 * (lines[0] + lines[-1])
    # the fastest rotor a fit may reach: the bound, the re-seeding and the moves' windows
    f_top = max(hi, mid * (1 + max(cfg.reseed_rel, cfg.move_rel)))
    half_t = 0.5 * len(x) / prf
    band = cfg.band_margin * (
        abs(body_hz)
        + abs(body_rate_hz_s) * half_t
        + max(Ns) * B * (f_top + (abs(rate_rev_s2) + 3 * cfg.chirp_sd_rev_s2) * half_t)
    ) + cfg.band_bins * prf / len(x)
    F = _Model(x, prf, B, M, cfg, band if cfg.band_margin > 0 else None)
    p0 = np.r_[body_hz, body_rate_hz_s, np.resize(lines, M), np.full(M, rate_rev_s2)]
    F.g0 = float(rate_rev_s2)
    F.s2 = F.solve(F.build(p0, Ns[0]))[3] / len(x)

    def inside(p):
        f = p[2 : 2 + M]
        return bool(np.all((f >= lo) & (f <= hi)))

    starts = []
    for comp in _compositions(M, k) if k < M else [[1] * M]:
        for sp in cfg.spreads_bins if max(comp) > 1 else cfg.spreads_bins[:1]:
            f0 = np.concatenate([ln + (np.arange(m) - (m - 1) / 2) * sp * bin_rev for ln, m in zip(lines, comp)])
            starts.append((f0, "+".join(map(str, comp))))
    cands = []
    for f0, name in starts:
        p, cost = F.fit(np.r_[body_hz, body_rate_hz_s, f0, np.full(M, rate_rev_s2)], Ns[0], cfg.screen_iterations)
        if inside(p):
            cands.append((cost, name, p))
    cands.sort(key=lambda c: c[0])
    best = None
    for cost, name, p in cands[: cfg.keep]:
        for N in Ns[1:]:
            p, cost = F.fit(p, N)
        if not inside(p):
            continue
        key = (bool(np.any(_spare(F.power, cfg))), cost)
        if best is None or key < best[0]:
            best = (key, p, name)
    if best is None:
        return None
    (_, cost), p, name = best
    N = Ns[-1]
    K = 2 * N
    # re-seed the weakest rotor at the residual's strongest comb, searched over the
    # group's plausible spread (a rotor the periodogram missed lies outside the lines)
    wlo, whi = min(lo, mid * (1 - cfg.reseed_rel)), max(hi, mid * (1 + cfg.reseed_rel))
    for k_seed in range(cfg.reseed):
        F.fit(p, N, iterations=0)
        if k_seed > 0 and not _spare(F.power, cfg).any():
            break
        q = int(np.argmin(F.power))
        sl = slice(1 + q * K, 1 + (q + 1) * K)
        r = F.r + F.A[:, sl] @ F.c[sl]
        pm = p.copy()
        pm[2 + q] = F.comb_peak(r, p, N, wlo, whi, 0.1 * bin_rev)
        pm[2 + M + q] = F.g0
        pn, cn = F.fit(pm, N)
        f = pn[2 : 2 + M]
        if cn < cost and np.all((f >= wlo) & (f <= whi)) and _comb_like(F, q):
            p, cost, name = pn, cn, name + "/reseed"
        else:
            break
    # a rotor the lines missed (no spare to re-seed, or beyond the re-seeding window)
    p, cost, name = _move_to_missed(F, p, cost, name, N, wlo, whi, bin_rev, cfg)
    F.fit(p, N, iterations=0)
    dof = max(2 * len(x) - 2 * (1 + M * K + 3) - len(p), 1)
    s2 = (cost - F.prior(p)) / dof
    try:
        cov = s2 * np.linalg.inv(F.information(p))
    except np.linalg.LinAlgError:
        return None
    f = p[2 : 2 + M].copy()
    sd = np.sqrt(np.clip(np.diag(cov)[2 : 2 + M], 0, None))
    # a spare rotor (its lines coincide with another's) turns with the strongest line;
    # weak in power *and* in what the fit loses without it: two rotors' models on nearly
    # one line trade large opposite amplitudes, so beside them a rotor on lines of its
    # own looks weak in power, yet dropping it costs the fit its lines
    spare = _spare(F.power, cfg)
    if spare.any():
        dp = F.drop_power()  # the last fit is at p (above)
        spare &= dp < cfg.min_power * float(dp.max())
    balance = float(F.power.min() / F.power.max()) if F.power.max() > 0 else 0.0
    weight = np.ones(M)
    var_count = 0.0
    if spare.any():
        # which line a spare shares is not measured: the spread of the mean over the
        # lines it could share adds to the uncertainty
        strong = f[~spare]
        var_count = float(spare.sum() * np.var(strong)) / M**2
        joined = np.zeros(M)
        for q in np.flatnonzero(spare):
            j = int(np.argmax(np.where(spare, -np.inf, F.power / (1.0 + joined))))
            f[q], sd[q] = f[j], sd[j]
            joined[j] += 1
            weight[j] += 1
            weight[q] = 0
        name += f"/{int(spare.sum())} spare"
    a = np.zeros(len(p))
    a[2 : 2 + M] = weight / M
    # the composition's ambiguity, by the fit's balance (see the module docstring)
    amb = min(cfg.ambiguity_bins * np.exp(-balance / cfg.ambiguity_scale), cfg.ambiguity_max_bins) * bin_rev
    amb_rotor = cfg.ambiguity_rotor_bins * bin_rev * np.exp(-balance / cfg.ambiguity_rotor_scale)
    if n_pairs == 1:
        amb = np.hypot(amb, cfg.one_pair_bins * bin_rev * np.exp(-balance / cfg.one_pair_scale))
        amb_rotor = np.hypot(amb_rotor, cfg.one_pair_rotor_bins * bin_rev * np.exp(-balance / cfg.one_pair_rotor_scale))
    sd = np.sqrt(sd**2 + (cfg.rel_floor * f) ** 2 + amb_rotor**2)
    mean_sd = float(np.sqrt(max(a @ cov @ a, 0.0) + var_count + (cfg.rel_floor * f.mean()) ** 2 + amb**2))
    order = np.argsort(f)
    return CpiFit(f[order], sd[order], mean_sd, name, balance)


def _move_to_missed(
    F: _Model, p: np.ndarray, cost: float, name: str, N: int, lo: float, hi: float, bin_rev: float, cfg: FitConfig
):
    """A rotor the periodogram's lines missed (module docstring): the residual's
    strongest harmonic comb within ``move_rel`` of the window's centre, tried in place
    of each of the ``move_tries`` weakest rotors; the best fit that lowers the cost is
    kept, up to ``move_passes`` times. Returns (p, cost, name)."""
    M = F.M
    mid = 0.5 * (lo + hi)
    mlo, mhi = min(lo, mid * (1 - cfg.move_rel)), max(hi, mid * (1 + cfg.move_rel))
    for _ in range(cfg.move_passes):
        F.fit(p, N, iterations=0)
        peak = F.comb_peak(F.r, p, N, mlo, mhi, 0.1 * bin_rev)
        best = None
        for q in np.argsort(F.power)[: cfg.move_tries]:
            pm = p.copy()
            pm[2 + q], pm[2 + M + q] = peak, F.g0
            pn, cn = F.fit(pm, N)
            f = pn[2 : 2 + M]
            if cn < cost and np.all((f >= mlo) & (f <= mhi)) and (best is None or cn < best[1]) and _comb_like(F, q):
                best = (pn, cn)
        if best is None:
            break
        p, cost = best
        name += "/miss"
    return p, cost, name


def _comb_like(F: _Model, q: int) -> bool:
    """Whether rotor ``q`` of the last :meth:`_Model.fit` lights its harmonic orders as
    the other rotors do (one drone's blades light the same orders). Its order profile
    (power per order n = 1 .. ``N``, both signs, normalised) must match the other
    rotors' mean profile (Bhattacharyya coefficient >= ``comb_similarity``), and where
    the others spread their power over several orders it must too: its share outside
    its strongest order >= ``comb_spread`` x the others' median share - ``comb_slack``
    (the slack keeps rotors whose blades light one order, all near zero, out of the
    test). A comb placed on lines the model does not hold (the rotation-rate lines of
    unequal blades; the harmonics of a blade flash wider than ``harmonics[-1]`` orders,
    where (N + 1) / N of a rotor's speed puts order N on its order N + 1) matches them
    at one order only: a low similarity (unequal blades) or a low share (a wide flash).
    How the thresholds were set: ``docs/experiments.md``."""
    if F.M < 2:
        return True
    N = len(F._ns) // 2
    K = 2 * N
    cq = np.abs(F.c[1 : 1 + F.M * K].reshape(F.M, K)) ** 2
    orders = cq[:, :N][:, ::-1] + cq[:, N:]  # n = 1 .. N, both signs
    prof = orders / np.maximum(orders.sum(axis=1, keepdims=True), 1e-300)
    share = 1.0 - prof.max(axis=1)
    others = np.delete(prof, q, axis=0)
    similar = float(np.sqrt(prof[q] * others.mean(axis=0)).sum()) >= F.cfg.comb_similarity
    spread = share[q] >= F.cfg.comb_spread * float(np.median(np.delete(share, q))) - F.cfg.comb_slack
    return similar and spread


def _spare(power: np.ndarray, cfg: FitConfig) -> np.ndarray:
    """bool [M]: rotors with under ``min_power`` of the strongest rotor's power."""
    return power < cfg.min_power * power.max()

"""Model extensions: the catalog's causes as options of the synthesis stage.

Each cause of :data:`microdoppler.synthesis.catalog.CAUSES` (except ``none``) extends the
paper's model (eq. 2, :func:`microdoppler.synthesis.model.synthesize`) with the catalog's
parameter names, units and signs:

``sideband_asymmetry``  {asymmetry_db}
    ``envelope_gain(f)`` multiplies the alpha envelope H(f) by 10^(+a/40) above the body
    Doppler and 10^(-a/40) below it: upper/lower sideband power = 10^(a/10).
``sideband_fading``     {fading_std_db, timescale_s}
    ``blade_hook`` multiplies the blade signal by 10^(x(t)/20), x an
    Ornstein-Uhlenbeck process in dB (std ``fading_std_db``, correlation time
    ``timescale_s``).
``body_fluctuation``    {body_std_db, timescale_s}
    ``body_hook`` multiplies the body amplitude by 10^(y(t)/20), y OU in dB with std
    ``body_std_db`` and correlation time ``timescale_s`` (default
    :data:`BODY_TIMESCALE_S` when not given, e.g. in files written before it existed).
``motor_log_lag``       {lag_s}
    A log row stamped t reports the speed at t - lag_s, so the corrected log is the
    logged one with its times moved by -lag_s (:meth:`ExtensionSet.transform_log`).
``motor_speed_scale``   {scale}
    true speed = scale * logged speed (:meth:`ExtensionSet.transform_log`).
``blade_imbalance``     {imbalance_db}
    :meth:`ExtensionSet.blade_amplitudes`: blade 0 of every rotor scatters
    10^(-imbalance_db/20) of the others (amplitudes scaled to sum to the blade count),
    so lines appear at the multiples of the rotation rate that are not multiples of
    the blade count (``BladeModel.blade_amplitudes``).
``phase_noise``         {rms_rad, skirt_dbc_hz}
    :meth:`ExtensionSet.post` multiplies the echo by exp(j theta(t)), theta Gaussian
    with a flat spectrum on |f| < 100 Hz and rms ``rms_rad``. ``skirt_dbc_hz`` (the
    single-sideband density at 50 Hz [dBc/Hz]) is derived from ``rms_rad`` when not
    given (:func:`microdoppler.synthesis.catalog.flat_skirt_dbc_hz`) and vice versa; when both
    are given (a diagnosis of a non-flat skirt) both are kept and ``rms_rad`` drives
    the synthesis. Optional ``skirt_profile`` (a diagnosis's measured skirt,
    ``{band_edges_hz, dbc_hz}``, :func:`profile_phase_noise`) drives it instead where
    given; it is not a catalog parameter (twins built from a population leave it out).

Stochastic extensions (fading, body fluctuation, phase noise) draw their processes
from the ``seed`` given to :meth:`~ExtensionSet.model_extensions` / :meth:`~ExtensionSet.post`;
the same seed gives the same result.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np
import scipy.fft as sfft
import yaml

from .catalog import CAUSES, PHASE_NOISE_BANDWIDTH_HZ, flat_rms_rad, flat_skirt_dbc_hz
from ..errors import InputError
from ..io.outputs import atomic_file
from ..io.motorlog import MotorLog
from .model import ModelExtensions
from .processes import ou_process

SCHEMA = "extensions/1"
#: default correlation time of the body fluctuation [s] when ``timescale_s`` is not given
BODY_TIMESCALE_S = 0.3
#: default of the fading correlation time [s] when not given
DEFAULT_FADING_TIMESCALE_S = 1.5
#: sampling interval of the slow gain processes before interpolation [s]
GAIN_DT_S = 0.01
#: sub-seeds of the stochastic extensions (independent streams from one seed)
_STREAM = {"sideband_fading": 1, "body_fluctuation": 2, "phase_noise": 3}


def check_params(cause: str, params: Mapping | None, *, source="extensions") -> dict:
    """Validate one cause's parameters against the catalog; returns floats.

    Raises
    ------
    InputError
        Unknown cause or parameter, missing or out-of-range value.
    """
    if cause not in CAUSES or cause == "none":
        raise InputError(source, f"extensions.{cause}", "is not a catalog cause",
                         f"one of {[c for c in CAUSES if c != 'none']}")
    params = dict(params or {})
    names = [p.name for p in CAUSES[cause].params]
    profile = params.pop("skirt_profile", None) if cause == "phase_noise" else None
    for k in params:
        if k not in names:
            raise InputError(source, f"extensions.{cause}.{k}", "unknown parameter", f"one of {names}")
    if cause == "sideband_fading":
        params.setdefault("timescale_s", DEFAULT_FADING_TIMESCALE_S)
    if cause == "body_fluctuation":
        params.setdefault("timescale_s", BODY_TIMESCALE_S)  # files written before timescale_s existed
    if cause == "phase_noise":
        # either parameter defines the other for the flat process (an old file has rms_rad only)
        if "rms_rad" not in params and "skirt_dbc_hz" in params:
            v = _number(source, cause, "skirt_dbc_hz", params["skirt_dbc_hz"])
            params["rms_rad"] = flat_rms_rad(v)
        elif "skirt_dbc_hz" not in params and "rms_rad" in params:
            v = _number(source, cause, "rms_rad", params["rms_rad"])
            params["skirt_dbc_hz"] = flat_skirt_dbc_hz(v) if v > 0 else -300.0
    out = {}
    for k in names:
        if k not in params:
            raise InputError(source, f"extensions.{cause}.{k}", "missing", "a number")
        out[k] = _number(source, cause, k, params[k])
    bad = {
        ("sideband_fading", "fading_std_db"): out.get("fading_std_db", 0) < 0,
        ("sideband_fading", "timescale_s"): out.get("timescale_s", 1) <= 0,
        ("body_fluctuation", "body_std_db"): out.get("body_std_db", 0) < 0,
        ("body_fluctuation", "timescale_s"): out.get("timescale_s", 1) <= 0,
        ("motor_speed_scale", "scale"): out.get("scale", 1) <= 0,
        ("phase_noise", "rms_rad"): out.get("rms_rad", 0) < 0,
    }
    for (c, k), is_bad in bad.items():
        if c == cause and is_bad:
            raise InputError(source, f"extensions.{cause}.{k}", f"is {out[k]}",
                             "> 0" if k in ("timescale_s", "scale") else ">= 0")
    if profile is not None:
        out["skirt_profile"] = check_skirt_profile(profile, source)
    return out


def check_skirt_profile(profile, source="extensions") -> dict:
    """Validate a phase-noise ``skirt_profile`` (``{"band_edges_hz": [n + 1],
    "dbc_hz": [n]}``: the measured skirt, piecewise constant per band of offset;
    :func:`microdoppler.diagnosis.measure.skirt_profile`); returns it as floats."""
    key = "extensions.phase_noise.skirt_profile"
    want = "{band_edges_hz: [n + 1 increasing offsets > 0 Hz], dbc_hz: [n levels, dBc/Hz]}"
    if not isinstance(profile, Mapping) or "band_edges_hz" not in profile or "dbc_hz" not in profile:
        raise InputError(source, key, f"is {profile!r}", want)
    try:
        e = np.asarray(profile["band_edges_hz"], float)
        v = np.asarray(profile["dbc_hz"], float)
    except (TypeError, ValueError):
        raise InputError(source, key, "holds values that are not numbers", want) from None
    if (e.ndim != 1 or v.ndim != 1 or len(e) != len(v) + 1 or len(v) < 1 or not np.all(np.isfinite(e))
            or not np.all(np.isfinite(v)) or e[0] <= 0 or np.any(np.diff(e) <= 0) or np.any(v > 0)):
        raise InputError(source, key, f"has {len(e)} edges and {len(v)} levels", want + ", levels finite and <= 0")
    out = {"band_edges_hz": [float(x) for x in e], "dbc_hz": [float(x) for x in v]}
    if "n_ordinates" in profile:
        out["n_ordinates"] = [int(x) for x in profile["n_ordinates"]]
    return out


def _number(source, cause: str, k: str, x) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InputError(source, f"extensions.{cause}.{k}", f"is {x!r}", "a number") from None
    if not np.isfinite(v):
        raise InputError(source, f"extensions.{cause}.{k}", f"is {v}", "a finite number")
    return v


def flat_phase_noise(n: int, prf_hz: float, rms_rad: float, rng: np.random.Generator,
                     bandwidth_hz: float = PHASE_NOISE_BANDWIDTH_HZ) -> np.ndarray:
    """Gaussian phase error theta: float64 [n] [rad], flat spectrum on 0 < |f| <
    ``bandwidth_hz``, standard deviation ``rms_rad``."""
    if n == 0 or rms_rad == 0:
        return np.zeros(n)
    th = _gaussian_series(n, prf_hz, lambda f: ((f > 0) & (f < bandwidth_hz)).astype(np.float64), rng)
    s = th.std()
    return th * (rms_rad / s) if s > 0 else th


def _gaussian_series(n: int, prf_hz: float, amplitude, rng: np.random.Generator) -> np.ndarray:
    """A real Gaussian series [n] drawn in the frequency domain over the whole record:
    complex white noise times ``amplitude(f)`` on the real FFT's frequencies [Hz]
    (of the next fast length), transformed back."""
    m = sfft.next_fast_len(n, real=True)
    f = sfft.rfftfreq(m, 1.0 / prf_hz)
    spec = (rng.standard_normal(len(f)) + 1j * rng.standard_normal(len(f))) * amplitude(f)
    return sfft.irfft(spec, m, workers=1)[:n]


def profile_phase_noise(n: int, prf_hz: float, band_edges_hz, dbc_hz, rng: np.random.Generator) -> np.ndarray:
    """Gaussian phase error theta: float64 [n] [rad] whose two-sided spectrum is the
    measured skirt (first order, L(f) = S_theta(f)): 10^(dbc/10) [rad^2/Hz] in each
    band of |f| (``band_edges_hz``), the first band's level below its lower edge (the
    skirt within the clutter notch is not measured; flat there as the catalog's
    process), none beyond the last edge."""
    if n == 0:
        return np.zeros(n)
    m = sfft.next_fast_len(n, real=True)
    e = np.asarray(band_edges_hz, float)
    lev = 10 ** (np.asarray(dbc_hz, float) / 10)

    def amplitude(f):
        j = np.clip(np.searchsorted(e, f, side="right") - 1, 0, len(lev) - 1)
        S = np.where(f < e[-1], lev[j], 0.0)
        S[0] = 0.0
        # rfft coefficients of a real series with two-sided PSD S: variance S prf m / 2 per part
        return np.sqrt(S * prf_hz * m / 2)

    return _gaussian_series(n, prf_hz, amplitude, rng)


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


class _GainHook:
    """``hook(i0, i1, t_s, x)`` multiplying ``x`` by a slow dB gain process."""

    def __init__(self, duration_s: float, std_db: float, tau_s: float, rng: np.random.Generator):
        n = int(np.ceil(duration_s / GAIN_DT_S)) + 3
        self.x_db = ou_process(n, GAIN_DT_S, std_db, tau_s, rng)
        self.grid = GAIN_DT_S * np.arange(n)

    def amplitude(self, t_s: np.ndarray) -> np.ndarray:
        return (10.0 ** (np.interp(t_s, self.grid, self.x_db) / 20.0)).astype(np.float32)

    def __call__(self, i0, i1, t_s, x):
        x *= self.amplitude(t_s)


@dataclass(frozen=True)
class ExtensionSet:
    """A set of model extensions with their parameters.

    Parameters
    ----------
    effects : mapping
        ``{cause: {param: value}}`` with the catalog's names (``none`` not allowed);
        empty = the paper's model.
    meta : mapping
        Free-form provenance (e.g. how the parameters were aggregated); preserved by
        :func:`~microdoppler.synthesis.save_extensions`.

    Raises
    ------
    microdoppler.errors.InputError
        For an unknown cause or parameter, or a value out of the catalog's range.

    See Also
    --------
    load_extensions, microdoppler.diagnosis.aggregate

    Examples
    --------
    >>> from microdoppler.synthesis import ExtensionSet
    >>> ext = ExtensionSet({"motor_speed_scale": {"scale": 1.02}})
    >>> "motor_speed_scale" in ext, "phase_noise" in ext
    (True, False)
    """

    effects: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    meta: Mapping = field(default_factory=dict)

    def __post_init__(self):
        checked = {c: check_params(c, p) for c, p in dict(self.effects).items()}
        object.__setattr__(self, "effects", checked)

    def __contains__(self, cause: str) -> bool:
        return cause in self.effects

    def transform_log(self, log: MotorLog) -> MotorLog:
        """Motor log corrected by lag and scale: the speeds that drive the blades."""
        t, rpm = log.time_s, log.rpm
        if "motor_log_lag" in self.effects:
            t = t - self.effects["motor_log_lag"]["lag_s"]
        if "motor_speed_scale" in self.effects:
            rpm = (rpm.astype(np.float64) * self.effects["motor_speed_scale"]["scale"]).astype(np.float32)
        return MotorLog(np.asarray(t, np.float64), rpm, log.source)

    def model_extensions(self, *, prf_hz: float, n_pulses: int, seed: int) -> ModelExtensions:
        """The extensions that act inside :func:`microdoppler.synthesis.synthesize`
        (``SynthesisConfig.extensions``: envelope gain, blade and body hooks; None where
        not in use) for a record of ``n_pulses`` at ``prf_hz``."""
        if not prf_hz > 0:
            raise ValueError(f"prf_hz={prf_hz} must be > 0")
        if n_pulses < 0:
            raise ValueError(f"n_pulses={n_pulses} must be >= 0")
        kw = {}
        dur = n_pulses / prf_hz
        e = self.effects
        if "sideband_asymmetry" in e:
            kw["envelope_gain"] = asymmetry_envelope(e["sideband_asymmetry"]["asymmetry_db"])
        if "sideband_fading" in e:
            p = e["sideband_fading"]
            rng = np.random.default_rng([int(seed), _STREAM["sideband_fading"]])
            kw["blade_hook"] = _GainHook(dur, p["fading_std_db"], p["timescale_s"], rng)
        if "body_fluctuation" in e:
            rng = np.random.default_rng([int(seed), _STREAM["body_fluctuation"]])
            p = e["body_fluctuation"]
            kw["body_hook"] = _GainHook(dur, p["body_std_db"], p["timescale_s"], rng)
        return ModelExtensions(**kw)

    def blade_amplitudes(self, n_blades: int) -> np.ndarray | None:
        """Each blade's scattering amplitude for ``blade_imbalance`` (float [n_blades];
        None without it): blade 0 at 10^(-imbalance_db/20) of the others, all scaled so
        that they sum to ``n_blades``, so the blade-passing lines (which sum the blades)
        keep the calibrated level and only the lines between them appear."""
        if "blade_imbalance" not in self.effects:
            return None
        a = 10 ** (-self.effects["blade_imbalance"]["imbalance_db"] / 20)
        amps = np.ones(int(n_blades))
        amps[0] = a
        return amps * n_blades / amps.sum()

    def post(self, iq: np.ndarray, *, prf_hz: float, seed: int) -> np.ndarray:
        """Post-step on the synthesised echo (phase noise); returns a new array
        (complex64 [n_pulses]), or ``iq`` itself when no post-step is in use."""
        if "phase_noise" not in self.effects:
            return iq
        rng = np.random.default_rng([int(seed), _STREAM["phase_noise"]])
        p = self.effects["phase_noise"]
        if "skirt_profile" in p:
            th = profile_phase_noise(len(iq), prf_hz, p["skirt_profile"]["band_edges_hz"],
                                     p["skirt_profile"]["dbc_hz"], rng)
        else:
            th = flat_phase_noise(len(iq), prf_hz, p["rms_rad"], rng)
        return (iq * np.exp(1j * th)).astype(np.complex64)

    def to_dict(self) -> dict:
        return {"schema": SCHEMA,
                "extensions": {c: dict(p) for c, p in self.effects.items()},
                "meta": dict(self.meta)}


def read_yaml(path, expected: str):
    """The parsed YAML file at ``path`` ({} when empty); a missing file or one that is
    not YAML is an :class:`InputError` naming ``expected``."""
    path = Path(path)
    if not path.exists():
        raise InputError(path, "file", "does not exist", expected)
    try:
        return yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as exc:
        raise InputError(path, "file", f"is not YAML ({type(exc).__name__})", expected) from None


def load_extensions(path_yaml) -> ExtensionSet:
    """Read an extensions YAML (as written by :func:`~microdoppler.synthesis.save_extensions`).

    Parameters
    ----------
    path_yaml : str or path-like
        The YAML file (``schema: extensions/1``).

    Returns
    -------
    ExtensionSet
        The extensions with their parameters and ``meta``.

    Raises
    ------
    microdoppler.errors.InputError
        Naming the file and the field (a missing file, a wrong schema, an unknown cause).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from microdoppler.synthesis import ExtensionSet, load_extensions, save_extensions
    >>> path = save_extensions(ExtensionSet({"motor_speed_scale": {"scale": 1.02}}),
    ...                        Path(tempfile.mkdtemp()) / "extended.yaml")
    >>> load_extensions(path).effects
    {'motor_speed_scale': {'scale': 1.02}}
    """
    path = Path(path_yaml)
    return extensions_from_dict(read_yaml(path, f"an {SCHEMA} YAML file"), path)


def extensions_from_dict(d, path) -> ExtensionSet:
    """An ``extensions/1`` mapping (read from ``path``, named in errors) -> ExtensionSet."""
    if not isinstance(d, dict) or d.get("schema") != SCHEMA:
        raise InputError(path, "schema", f"is {d.get('schema') if isinstance(d, dict) else d!r}", repr(SCHEMA))
    ext = d.get("extensions") or {}
    if not isinstance(ext, dict):
        raise InputError(path, "extensions", f"is a {type(ext).__name__}", "a mapping cause -> params")
    return ExtensionSet({c: check_params(c, p, source=path) for c, p in ext.items()}, d.get("meta") or {})


def save_extensions(ext: ExtensionSet, path_yaml) -> Path:
    """Write ``ext`` as YAML, atomically (temporary sibling, then rename).

    Parameters
    ----------
    ext : ExtensionSet
        The extensions with their parameters and ``meta``.
    path_yaml : str or path-like
        The file to write (``schema: extensions/1``).

    Returns
    -------
    pathlib.Path
        ``path_yaml``.

    See Also
    --------
    load_extensions

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from microdoppler.synthesis import ExtensionSet, save_extensions
    >>> path = save_extensions(ExtensionSet({"sideband_asymmetry": {"asymmetry_db": 3.0}}),
    ...                        Path(tempfile.mkdtemp()) / "extended.yaml")
    >>> print(path.read_text().splitlines()[0])
    schema: extensions/1
    """
    path = Path(path_yaml)
    with atomic_file(path) as tmp:
        tmp.write_text(yaml.safe_dump(yaml_plain(ext.to_dict()), sort_keys=False))
    return path


def yaml_plain(x):
    """Mappings, sequences and numpy scalars -> plain Python (YAML-safe)."""
    if isinstance(x, Mapping):
        return {str(k): yaml_plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [yaml_plain(v) for v in x]
    if isinstance(x, np.generic):
        return x.item()
    return x

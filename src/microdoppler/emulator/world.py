"""Flights, profiles and worlds: the measured world the pipeline is tested against.

:func:`emulate_flight` turns a :class:`FlightSpec` into a flight-zarr/1
:class:`~microdoppler.io.flightzarr.Flight` and a truth dict; :func:`plan_world` lists
the flights of a profile; :func:`emulate_world` writes them with the manifest, the
motor-log exports and the key file.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from ..synthesis import model as synthesis
from ..io.flightzarr import SCHEMA, Flight
from ..synthesis.radar import DRONE_MODELS
from ..spectra.snr import flight_body_snr_db
from . import background as bg
from .bird import KINDS, plan_group, render
from .drone import DYNAMICS, loop_path, motor_speeds, write_log
from ..causes import registry
from .knobs import SlowGain, ou_process, validate_effects
from .radars import radar_site

TARGETS = ("drone", "bird")
#: body SNR [dB] (spectrogram line over median floor in thermal noise) of a class at
#: 1 km on radar 1 for a median-RCS target; calibrated so that the measured per-class
#: means of the paper profile come out near Table III (see tests/test_emulator.py)
SNR_REF_DB = {"bird": 42.8, "inspire2": 57.8, "matrice300": 60.5, "mini2": 51.4}
#: per-flight RCS scatter [dB]
RCS_STD_DB = {"bird": 7.0, "inspire2": 8.0, "matrice300": 8.0, "mini2": 6.0}
TRACK_HZ = 20.0
#: blade current taper: the blade echo is the sum of thin wires of these fractions of
#: the blade length, all from the hub (current 4:3:2:1 from hub to tip)
BLADE_TAPER = (1.0, 0.75, 0.5, 0.25)
#: large drones' further sideband fall-off per harmonic [dB], drawn log-uniformly
FALLOFF_DB = (4.0, 16.0)
#: maximal range-straddle loss as the target crosses resolution cells [dB]
STRADDLE_LOSS_DB = 1.5
#: share of large-drone flights whose blades echo weakly (payload, propeller type,
#: polarisation at the flight's aspect) and the first sideband's level below the body
#: on those flights [dB]: the paper's far sidebands "fluctuated in their appearance and
#: power" and its real large drones were called birds 6 % of the time (Table V);
#: calibrated against the real-trained row only (docs/experiments.md, "World v3")
WEAK_BLADE_SHARE = 0.4
WEAK_BLADE_DB = (30.0, 50.0)
#: the Mini pilot's wander about the plan [m], drawn log-uniformly per flight
MINI_WANDER_M = (0.5, 4.0)
#: the Mini's body scintillation (a 250 g airframe, hand-flown attitude changes):
#: std [dB] drawn uniformly per flight, over MINI_SCINT_S (large drones: 1 dB over 4 s)
MINI_SCINT_DB = (1.5, 4.5)
MINI_SCINT_S = 1.5


@dataclass(frozen=True)
class FlightSpec:
    """Everything that defines one emulated flight.

    Parameters
    ----------
    flight_id : str
    target : {"drone", "bird"}
    drone_model : str
        ``inspire2``, ``matrice300`` or ``mini2`` (drones).
    bird_kind : str
        ``single``, ``pair``, ``small_flock`` or ``large_flock`` (birds).
    radar_id : {"radar1", "radar2"}
    duration_s : float
    mean_range_m : float
        Horizontal distance of the loop centre (drones) or of the mid-track point (birds).
    height_m : float
    speed_mps : float
        Ground speed.
    effects : mapping
        ``{cause: {param: value}}`` with the catalog's names (see ``microdoppler.emulator.knobs``).
    seed : int
        Everything random in the flight derives from it.
    snr_db : float, optional
        Body SNR after the STFT (line over median floor in thermal noise); default
        from the range model (R^-4, radar gain, RCS scatter).
    wind_mps : float, optional
        Mean wind; default drawn.
    direction : int
        +1 forward, -1 reverse loop.
    first_sideband_db, harmonic_falloff_db : float, optional
        Drones: first HERM sideband (per motor line) below the body [dB] and further
        fall-off per harmonic [dB]; default drawn (large drones 7-10, with
        ``weak_blades`` ``WEAK_BLADE_DB``, and 4-16 (log-uniform) dB per motor line, which measures ~2 dB less against the body line as motor lines overlap; the
        Mini's blades sit below the noise).
    clutter_scale_db : float
        Added to every clutter cell's clutter-to-noise ratio.
    with_background : bool
        Also record ``background/iq``.
    site_seed : int
        Seed of the radar sites' clutter maps (shared by all flights of a world).
    path : {"loop", "straight"}
        Drones: the stadium loops of the trials, or one straight leg near the line of
        sight (no turns, body Doppler far from the notch; for diagnosis tests).
    weak_blades : bool
        Large drones: the blades echo weakly, the first sideband
        ``WEAK_BLADE_DB`` below the body (drawn) instead of 7-10 dB; the worlds
        draw it for ``WEAK_BLADE_SHARE`` of their large-drone flights.
    airframe : str
        Drones: the airframe that flies the flight (worlds: one of a few per model,
        ``profiles.plan_airframes``); a label for the key, what the airframe
        carries (a blade imbalance) is in ``effects``.

    Raises
    ------
    ValueError
        When a field is out of its range (an unknown target, drone model, bird kind
        or radar, a duration under 1 s, a range outside 100-20000 m, unknown effects).

    See Also
    --------
    emulate_flight

    Examples
    --------
    >>> from microdoppler.emulator import FlightSpec
    >>> spec = FlightSpec("demo", "drone", drone_model="inspire2", duration_s=2.0, seed=1)
    >>> spec.cls, spec.radar_id, spec.mean_range_m
    ('inspire2', 'radar1', 1500.0)
    >>> FlightSpec("demo", "drone", drone_model="inspire2", duration_s=0.5)
    Traceback (most recent call last):
    ...
    ValueError: duration_s=0.5 must be >= 1
    """

    flight_id: str
    target: str
    drone_model: str = ""
    bird_kind: str = ""
    radar_id: str = "radar1"
    duration_s: float = 40.0
    mean_range_m: float = 1500.0
    height_m: float = 80.0
    speed_mps: float = 8.0
    effects: Mapping = field(default_factory=dict)
    seed: int = 0
    snr_db: float | None = None
    wind_mps: float | None = None
    direction: int = 1
    first_sideband_db: float | None = None
    harmonic_falloff_db: float | None = None
    clutter_scale_db: float = 0.0
    with_background: bool = True
    site_seed: int = 0
    path: str = "loop"
    weak_blades: bool = False
    airframe: str = ""

    def __post_init__(self):
        if self.path not in ("loop", "straight"):
            raise ValueError(f"path={self.path!r} must be 'loop' or 'straight'")
        if self.target not in TARGETS:
            raise ValueError(f"target={self.target!r} must be one of {TARGETS}")
        if self.target == "drone" and self.drone_model not in DYNAMICS:
            raise ValueError(f"drone_model={self.drone_model!r} must be one of {list(DYNAMICS)}")
        if self.target == "bird" and self.bird_kind not in KINDS:
            raise ValueError(f"bird_kind={self.bird_kind!r} must be one of {list(KINDS)}")
        radar_site(self.radar_id)
        if not self.duration_s >= 1.0:
            raise ValueError(f"duration_s={self.duration_s} must be >= 1")
        if not 100.0 <= self.mean_range_m <= 20_000.0:
            raise ValueError(f"mean_range_m={self.mean_range_m} must be in [100, 20000]")
        if not self.height_m > 0:
            raise ValueError(f"height_m={self.height_m} must be > 0")
        if not self.speed_mps > 0:
            raise ValueError(f"speed_mps={self.speed_mps} must be > 0")
        if self.direction not in (1, -1):
            raise ValueError(f"direction={self.direction} must be +1 or -1")
        validate_effects(self.effects)

    @property
    def cls(self) -> str:
        return self.drone_model if self.target == "drone" else "bird"


def _rng(seed: int, stream: int) -> np.random.Generator:
    return np.random.default_rng([int(seed) & 0xFFFFFFFF, stream])


def _straddle_gain(range_m: np.ndarray) -> np.ndarray:
    frac = np.mod(range_m, bg.RANGE_CELL_M) / bg.RANGE_CELL_M
    loss_db = STRADDLE_LOSS_DB * (1 - np.cos(2 * np.pi * frac)) / 2
    return (10 ** (-loss_db / 20)).astype(np.float32)


def nominal_snr_db(spec: FlightSpec, rng: np.random.Generator) -> float:
    """The range model: class reference - 40 log10(R / 1 km) + radar gain + RCS scatter."""
    site = radar_site(spec.radar_id)
    r = np.hypot(spec.mean_range_m, spec.height_m)
    return float(
        SNR_REF_DB[spec.cls] - 40 * np.log10(r / 1000.0) + site.snr_offset_db + rng.normal(0, RCS_STD_DB[spec.cls])
    )


def draw_conditions(spec: FlightSpec) -> tuple[float, float, float]:
    """Wind during the flight and during the background recording [m/s], and the
    body SNR [dB] (spec values where given, else drawn from ``spec.seed``)."""
    r_misc = _rng(spec.seed, 0)
    wind = float(spec.wind_mps if spec.wind_mps is not None else 9.0 * r_misc.uniform() ** 1.5)
    wind_bg = float(9.0 * r_misc.uniform() ** 1.5)
    snr_db = float(spec.snr_db if spec.snr_db is not None else nominal_snr_db(spec, r_misc))
    return wind, wind_bg, snr_db


def emulate_flight(spec: FlightSpec) -> tuple[Flight, dict]:
    """Emulate one measured flight.

    The emulator is the measured world the pipeline is tested against: physics beyond
    the paper's model (tapered blades, motor dynamics, clutter, phase noise, ...), and
    no code shared with the synthesis' eq. (2).

    Parameters
    ----------
    spec : FlightSpec
        The flight; everything random derives from ``spec.seed``.

    Returns
    -------
    flight : Flight
        ``iq``, ``track/*``, ``background/iq`` (unless disabled) and, for the Inspire
        and Matrice, ``motors/*`` as logged.
    truth : dict
        The effects applied, the SNR and scaling used, the true per-motor speed
        summary, the wind, bird group details; JSON-serialisable.

    See Also
    --------
    FlightSpec, microdoppler.io.write_flight

    Examples
    --------
    >>> from microdoppler.emulator import FlightSpec, emulate_flight
    >>> flight, truth = emulate_flight(FlightSpec("demo", "drone", drone_model="inspire2", duration_s=1.0, seed=1))
    >>> flight.attrs["radar_id"], flight.iq.shape, flight.motors_rpm.shape[1]
    ('radar1', (7300,), 4)
    >>> truth["drone_model"], truth["effects"]
    ('inspire2', {})
    """
    effects = validate_effects(spec.effects)
    site = radar_site(spec.radar_id)
    radar = site.radar
    prf, lam = radar.prf_hz, radar.wavelength_m
    n = int(round(spec.duration_s * prf))
    t = np.arange(n) / prf
    wind, wind_bg, snr_db = draw_conditions(spec)
    a_body = bg.pulse_amplitude(snr_db, radar.n_fft)
    truth: dict = {
        "flight_id": spec.flight_id,
        "target": spec.target,
        "class": spec.cls,
        "radar_id": spec.radar_id,
        "effects": effects,
        "snr_db_nominal": snr_db,
        "wind_mps": wind,
        "background_wind_mps": wind_bg,
    }
    attrs = {
        "schema": SCHEMA,
        "flight_id": spec.flight_id,
        "target": spec.target,
        "radar_id": spec.radar_id,
        "prf_hz": float(prf),
        "carrier_hz": float(radar.carrier_hz),
        "source": "microdoppler.emulator",
    }
    tt = np.arange(0.0, spec.duration_s, 1.0 / TRACK_HZ)
    motors_t = motors_rpm = None
    if spec.target == "drone":
        model = DRONE_MODELS[spec.drone_model]
        dyn = DYNAMICS[spec.drone_model]
        # flight-level draws added in world v3 come from their own stream, so that
        # every earlier draw of the flight stays as it was
        r_v3 = _rng(spec.seed, 8)
        wander_m = float(np.exp(r_v3.uniform(*np.log(MINI_WANDER_M))))
        weak_blades = spec.weak_blades and spec.drone_model != "mini2"
        weak_db = float(r_v3.uniform(*WEAK_BLADE_DB))
        scint_db = float(r_v3.uniform(*MINI_SCINT_DB)) if dyn.hand_flown else 1.0
        path = loop_path(
            spec.duration_s,
            mean_range_m=spec.mean_range_m,
            height_m=spec.height_m,
            speed_mps=spec.speed_mps,
            direction=spec.direction,
            hand_flown=dyn.hand_flown,
            rng=_rng(spec.seed, 1),
            straight=spec.path == "straight",
            wander_m=wander_m,
        )
        r_mot = _rng(spec.seed, 2)
        hover_scale = float(r_mot.uniform(0.93, 1.07))
        mt = motor_speeds(path, dyn, wind_mps=wind, rng=r_mot, hover_scale=hover_scale)
        rev = mt.at(t)
        rng_ctrl = path.range_m
        track = synthesis.Track(path.t_s, rng_ctrl)
        range_tt = np.interp(tt, path.t_s, rng_ctrl)
        vr_tt = np.interp(tt, path.t_s, path.radial_velocity_mps)
        az_tt = np.interp(tt, path.t_s, np.arctan2(path.pos_m[:, 1], path.pos_m[:, 0]))
        # blades: first sideband per motor line first_db below the body, then falloff per harmonic
        r_bl = _rng(spec.seed, 3)
        f_rot = dyn.hover_rev_s * hover_scale
        B = model.n_blades
        if spec.drone_model == "mini2":
            first_db = spec.first_sideband_db if spec.first_sideband_db is not None else snr_db + r_bl.uniform(6, 12)
            falloff = spec.harmonic_falloff_db if spec.harmonic_falloff_db is not None else 6.0
        else:
            first_db = r_bl.uniform(7.0, 10.0)
            if weak_blades:
                first_db = weak_db
            if spec.first_sideband_db is not None:
                first_db = spec.first_sideband_db
            # log-uniform 4-16 dB per harmonic: the paper's text gives 3-8 dB at short range,
            # its Table IV alphas (5.5e-3 to 8e-2 s) flights whose sidebands end after one pair
            falloff = (
                spec.harmonic_falloff_db
                if spec.harmonic_falloff_db is not None
                else float(np.exp(r_bl.uniform(np.log(FALLOFF_DB[0]), np.log(FALLOFF_DB[1]))))
            )
        # tapered blade current: nested thin wires from the hub (eq. 1 kernel at
        # lengths BLADE_TAPER x L) give a current that falls towards the tip, whose
        # own HERM harmonics roll off; an exp(-alpha |f|) filter supplies the rest of
        # the per-harmonic fall-off
        coef = (
            np.fft.fft(
                sum(
                    synthesis.BladeModel(B, model.blade_length_m * fr, lam).table().astype(np.complex128)
                    for fr in BLADE_TAPER
                )
            )
            / synthesis.TABLE_SIZE
        )
        harm = 20 * np.log10(np.abs(coef[[B, 2 * B, 3 * B, 4 * B]]) + 1e-30)
        natural = float(max(0.0, (harm[0] - harm[3]) / 3))
        alpha_s = float(max(falloff - natural, 0.5) / (20 * np.log10(np.e) * B * f_rot))
        cB = abs(coef[B])
        s_blade = float(a_body * 10 ** (-first_db / 20) / (cB * np.exp(-alpha_s * B * f_rot)))
        knobs = [(s, effects[s.name]) for s in registry.specs() if s.name in effects]
        envs = [e for e in (s.world_envelope(p) for s, p in knobs) if e is not None]

        def envelope(f_hz):
            g = np.ones(np.shape(f_hz), np.float32)  # no knob: the paper's envelope alone
            for k, env in enumerate(envs):
                g = env(f_hz) if k == 0 else g * env(f_hz)
            g[f_hz == 0] = 0.0  # the blades' mean return is part of the body RCS
            return g

        # slow natural variations and the knobs' gains
        aspect = SlowGain(spec.duration_s + 1, 1.0, 4.0, r_bl)  # drawn for every drone: r_bl's later draws stay
        if dyn.hand_flown:
            aspect = SlowGain(spec.duration_s + 1, scint_db, MINI_SCINT_S, r_v3)
        blade_nat = SlowGain(spec.duration_s + 1, 0.5, 5.0, r_bl)
        # the knobs' slow gains, drawn from r_bl in the registry's order: the blades', then the body's
        blade_gains = [g for g in (s.world_blade_gain(p, spec.duration_s + 1, r_bl) for s, p in knobs) if g is not None]
        body_gains = [g for g in (s.world_body_gain(p, spec.duration_s + 1, r_bl) for s, p in knobs) if g is not None]

        def blade_hook(i0, i1, ts, x):
            g = blade_nat.amplitude(ts)
            for gain in blade_gains:
                g *= gain.amplitude(ts)
            x *= g

        def body_hook(i0, i1, ts, x):
            g = aspect.amplitude(ts)
            for gain in body_gains:
                g *= gain.amplitude(ts)
            x *= g

        start = r_bl.uniform(0, 1, model.n_motors)  # rotor angles at t = 0 [rev]
        # unequal blades (a blade imbalance): one weak blade on every rotor, the same
        # amplitudes for each nested wire of the tapered blade; no draw (flights
        # without it are unchanged)
        amps = next((a for a in (s.world_blade_amplitudes(p, B) for s, p in knobs) if a is not None), None)
        target = None
        hooks = synthesis.ModelExtensions(envelope_gain=envelope, blade_hook=blade_hook, body_hook=body_hook)
        for k, fr in enumerate(BLADE_TAPER):
            cfg = synthesis.SynthesisConfig.of(
                prf_hz=prf,
                wavelength_m=lam,
                n_blades=B,
                blade_length_m=model.blade_length_m * fr,
                scaling=synthesis.Scaling(a_body if k == 0 else 0.0, s_blade, alpha_s),
                blade_amplitudes=amps,
                extensions=hooks,
            )
            part = synthesis.synthesize(cfg, track, rev, initial_cycles=start)
            target = part if target is None else target.__iadd__(part)
        target *= _straddle_gain(track.range_at(t))
        attrs.update(
            {
                "drone_model": spec.drone_model,
                "n_motors": int(model.n_motors),
                "n_blades": int(B),
                "blade_length_m": float(model.blade_length_m),
            }
        )
        if dyn.log_rate_hz > 0:
            log_kw = {"lag_s": 0.0, "scale": 1.0}  # a log on the radar's clock, at the true speed
            for s, p in knobs:
                log_kw.update(s.world_log(p))
            motors_t, motors_rpm = write_log(mt, spec.duration_s, dyn.log_rate_hz, _rng(spec.seed, 4), **log_kw)
        inflight = (mt.t_s >= 0) & (mt.t_s <= spec.duration_s)
        rv = mt.rev_s[inflight]
        truth.update(
            {
                "drone_model": spec.drone_model,
                "alpha_s": alpha_s,
                "s_body": a_body,
                "s_blade": s_blade,
                "first_sideband_db": float(first_db),
                "harmonic_falloff_db": float(falloff),
                "blade_taper": list(BLADE_TAPER),
                "natural_falloff_db": natural,
                "hover_rev_s": float(f_rot),
                "weak_blades": bool(weak_blades and spec.first_sideband_db is None),
                "airframe": spec.airframe,
                "blade_amplitudes": list(amps) if amps else None,
                "wander_m": wander_m if dyn.hand_flown else 0.0,
                "body_scint_db": scint_db,
                "motors": {
                    "mean_rev_s": rv.mean(0).tolist(),
                    "std_rev_s": rv.std(0).tolist(),
                    "min_rev_s": rv.min(0).tolist(),
                    "max_rev_s": rv.max(0).tolist(),
                    "spread_rel": float(np.mean(rv.std(1) / rv.mean(1))),
                },
                "log_rate_hz": dyn.log_rate_hz,
            }
        )
    else:
        group = plan_group(
            spec.bird_kind,
            spec.duration_s,
            mean_range_m=spec.mean_range_m,
            height_m=spec.height_m,
            speed_mps=spec.speed_mps,
            rng=_rng(spec.seed, 1),
            manoeuvre_rng=_rng(spec.seed, 8),
        )
        target = render(group, n, prf, lam, a_body, _rng(spec.seed, 3))
        centre = group.centre_range_m
        target *= _straddle_gain(np.interp(t, group.t_s, centre))
        range_tt = np.interp(tt, group.t_s, centre)
        vr_tt = np.interp(tt, group.t_s, np.gradient(centre, group.t_s))
        az_tt = np.interp(tt, group.t_s, group.azimuth_rad)
        truth.update(
            {
                "bird_kind": spec.bird_kind,
                "species": group.species,
                "n_birds": group.n_birds,
                "wingbeat_hz": group.wingbeat_hz.tolist(),
                "turn_rate_sd_rad_s": group.turn_rate_sd,
                "speed_surge": group.speed_surge,
                "body_scint_db": group.scint_db,
                "glide_share": group.glide_share,
                "glide_time_s": group.glide_time_s,
                "body_doppler_offsets_hz": (
                    -2
                    * (np.gradient(group.range_m, group.t_s, axis=0) - np.gradient(centre, group.t_s)[:, None]).mean(0)
                    / lam
                ).tolist(),
            }
        )
    cells = bg.cell_ids(range_tt, az_tt)
    # a flat phase error on the whole flight echo (a phase-noise knob; rms of the sum for several)
    pn = [
        r for r in (s.world_phase_rms(effects[s.name]) for s in registry.specs() if s.name in effects) if r is not None
    ]
    knob_pn = 0.0 if not pn else pn[0] if len(pn) == 1 else float(np.sqrt(np.sum(np.square(pn))))
    iq, info = bg.record(
        target,
        n,
        t_track_s=tt,
        cells=cells,
        site=site,
        site_seed=spec.site_seed,
        wind_mps=wind,
        rng=_rng(spec.seed, 5),
        knob_phase_rms_rad=knob_pn,
        clutter_scale_db=spec.clutter_scale_db,
    )
    del target
    bgiq = None
    if spec.with_background:
        bgiq, _ = bg.record(
            None,
            n,
            t_track_s=tt,
            cells=cells,
            site=site,
            site_seed=spec.site_seed,
            wind_mps=wind_bg,
            rng=_rng(spec.seed, 6),
            clutter_scale_db=spec.clutter_scale_db,
        )
    truth.update(info)
    # the tracker's output: true track plus a small smooth error
    r_tr = _rng(spec.seed, 7)
    verr = ou_process(len(tt), 1.0 / TRACK_HZ, 0.03 if spec.drone_model != "mini2" else 0.08, 5.0, r_tr)
    err = np.cumsum(verr) / TRACK_HZ
    track_r = range_tt + err
    track_v = vr_tt + verr
    flight = Flight(
        attrs=attrs,
        iq=iq,
        track_time_s=tt.astype(np.float64),
        track_range_m=track_r,
        track_radial_velocity_mps=track_v,
        motors_time_s=motors_t,
        motors_rpm=motors_rpm,
        background_iq=bgiq,
    )
    return flight, truth


def measured_snr_db(flight: Flight) -> tuple[float, float]:
    """Mean and std over timesteps of the body line SNR with the pipeline's chain
    (:func:`microdoppler.spectra.snr.flight_body_snr_db`, the project's one SNR measure)."""
    s = flight_body_snr_db(flight)
    s = s[np.isfinite(s)]
    return float(np.mean(s)), float(np.std(s))

"""Birds: a body plus two flapping wings per bird; singles, pairs and flocks.

Each bird is a body scatterer at range R_i(t) and a wing scatterer whose range
oscillates at the wingbeat frequency (radial excursion ~ 0.15 x wingspan, so the wing
Doppler swings by 2 (2 pi f_wb A) / lambda) with an amplitude that changes with the
wing posture. The body RCS is also modulated by the wingbeat (small sidebands a few
Hz from the body, never HERM-like) and scintillates slowly. Some species alternate
flapping and gliding. In a flock the birds fly with slightly different radial
velocities, so the spectrogram shows several body lines.
"""

from __future__ import annotations

from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from .knobs import SlowGain, ou_process

CONTROL_HZ = 100.0
#: wing return below the body's [dB] (drawn uniformly per bird): at L band a bird's
#: wings scatter far less than its body, and the paper's birds "lack significant
#: micro-Doppler" (§III)
WING_BELOW_BODY_DB = (8.0, 22.0)
#: how much a group manoeuvres (world v3), drawn per group: the std of its turn rate
#: [rad/s] (log-uniform; urban gulls circle and pigeons wheel round buildings) and its
#: speed surge over the flap-glide cycle, relative (uniform; for species that do not
#: glide, a 1 s speed process of that size)
TURN_RATE_SD_RAD_S = (0.05, 0.5)
SPEED_SURGE = (0.0, 0.3)
#: body scintillation std [dB] over 1.5 s, drawn uniformly per group with the
#: manoeuvres (without: 4.5 dB); with the turns' notch crossings it sets the birds'
#: per-flight SNR std against Table III's 5.5 +- 1.5 dB (docs/experiments.md,
#: "World v3")
SCINT_DB = (2.0, 6.0)
#: flap-glide cycle of the species that glide (world v3d), drawn per group with the
#: manoeuvres: the share of time spent gliding (uniform) and the cycle's correlation
#: time [s] (log-uniform). A gliding bird's wings hold still: its return is a bare
#: body line, with neither the wings' Doppler swing nor the wingbeat's sidebands
#: (without: 27 % gliding, 2 s)
GLIDE_SHARE = (0.25, 0.65)
GLIDE_TIME_S = (2.0, 8.0)
#: the flap-glide cycle without drawn manoeuvres (as before v3d): share, time [s]
GLIDE_FIXED = (NormalDist().cdf(-0.6), 2.0)


@dataclass(frozen=True)
class Species:
    name: str
    wingbeat_hz: tuple[float, float]
    wingspan_m: float
    glides: bool


SPECIES = {
    "gull": Species("gull", (2.8, 3.8), 1.2, True),
    "crow": Species("crow", (3.5, 4.8), 0.9, True),
    "pigeon": Species("pigeon", (5.0, 7.0), 0.65, False),
    "starling": Species("starling", (10.0, 13.0), 0.38, True),
}

#: bird kinds: (min, max) number of birds, velocity spread within the group [m/s], species
KINDS = {
    "single": ((1, 1), 0.0, ("gull", "crow", "pigeon", "starling")),
    "pair": ((2, 2), 1.5, ("gull", "crow", "pigeon")),
    "small_flock": ((3, 8), 2.0, ("pigeon", "starling", "gull")),
    "large_flock": ((12, 30), 3.0, ("starling", "pigeon")),
}


@dataclass
class BirdGroup:
    """Everything needed to render a group: control-grid trajectories and wing params."""

    t_s: np.ndarray
    range_m: np.ndarray  # [n_ctrl, n_birds]
    azimuth_rad: np.ndarray  # [n_ctrl]
    amp: np.ndarray  # [n_birds] body amplitude relative to the leader
    wingbeat_hz: np.ndarray  # [n_birds]
    wing_phase: np.ndarray  # [n_birds]
    wing_rel: np.ndarray  # [n_birds] wing amplitude / body amplitude
    wing_excursion_m: np.ndarray
    flapping: np.ndarray  # [n_ctrl, n_birds] 0..1
    species: str
    turn_rate_sd: float = 0.0
    speed_surge: float = 0.0
    scint_db: float = 4.5
    glide_share: float = 0.0
    glide_time_s: float = 0.0

    @property
    def n_birds(self) -> int:
        return len(self.amp)

    @property
    def centre_range_m(self) -> np.ndarray:
        w = self.amp**2
        return self.range_m @ w / w.sum()


def plan_group(
    kind: str,
    duration_s: float,
    *,
    mean_range_m: float,
    height_m: float,
    speed_mps: float,
    rng: np.random.Generator,
    manoeuvre_rng: np.random.Generator | None = None,
) -> BirdGroup:
    """A group's trajectories, wings and flapping; with ``manoeuvre_rng`` the group also
    turns, surges and scintillates as drawn from :data:`TURN_RATE_SD_RAD_S`,
    :data:`SPEED_SURGE` and :data:`SCINT_DB` (from that generator only, so the other
    draws do not move)."""
    if kind not in KINDS:
        raise ValueError(f"bird_kind={kind!r} must be one of {list(KINDS)}")
    (nlo, nhi), vspread, species_opts = KINDS[kind]
    sp = SPECIES[species_opts[int(rng.integers(len(species_opts)))]]
    nb = int(rng.integers(nlo, nhi + 1))
    dt = 1.0 / CONTROL_HZ
    t = np.arange(0, duration_s + 1.0, dt)
    n = len(t)
    # tracked birds keep a clear radial component (the tracker loses tangential ones)
    az0 = rng.uniform(-np.pi / 4, np.pi / 4)
    h0 = az0 + rng.choice([0.0, np.pi]) + rng.uniform(-1.0, 1.0)
    heading = h0 + np.cumsum(ou_process(n, dt, 0.03, 5.0, rng)) * dt
    turn_sd = surge = 0.0
    scint = 4.5
    glide_share, glide_time = GLIDE_FIXED if sp.glides else (0.0, 0.0)
    if manoeuvre_rng is not None:
        turn_sd = float(np.exp(manoeuvre_rng.uniform(*np.log(TURN_RATE_SD_RAD_S))))
        surge = float(manoeuvre_rng.uniform(*SPEED_SURGE))
        scint = float(manoeuvre_rng.uniform(*SCINT_DB))
        heading = heading + np.cumsum(ou_process(n, dt, turn_sd, 5.0, manoeuvre_rng)) * dt
        # drawn for every species, so a pigeon's stream stays aligned with a gull's
        share = float(manoeuvre_rng.uniform(*GLIDE_SHARE))
        time_s = float(np.exp(manoeuvre_rng.uniform(*np.log(GLIDE_TIME_S))))
        if sp.glides:
            glide_share, glide_time = share, time_s
    speed = speed_mps * (1 + ou_process(n, dt, 0.08, 3.0, rng))
    p0 = mean_range_m * np.array([np.cos(az0), np.sin(az0)])
    # start so the group passes near mean_range half-way through
    vx, vy = speed * np.cos(heading), speed * np.sin(heading)
    x = np.cumsum(vx) * dt
    y = np.cumsum(vy) * dt
    x += p0[0] - x[n // 2]
    y += p0[1] - y[n // 2]
    ground = np.hypot(x, y)
    rng_c = np.sqrt(ground**2 + height_m**2)
    az = np.arctan2(y, x)
    # individual birds: offsets along the line of sight and their own radial velocities
    dv = rng.normal(0, vspread, nb) if nb > 1 else np.zeros(1)
    if nb > 1:
        dv -= dv.mean()
    off = rng.normal(0, 5.0 + 1.5 * nb, nb) if nb > 1 else np.zeros(1)
    r = rng_c[:, None] + off[None, :] + dv[None, :] * (t[:, None] - t[n // 2])
    for i in range(nb):
        r[:, i] += np.cumsum(ou_process(n, dt, 0.3, 2.0, rng)) * dt  # individual velocity wander
    amp = np.ones(nb)
    if nb > 1:
        amp[1:] = 10 ** (-rng.uniform(0, 8, nb - 1) / 20)
    f_wb = rng.uniform(*sp.wingbeat_hz, nb)
    flap = np.ones((n, nb))
    if sp.glides:
        # flapping while a unit OU process is above the glide share's quantile
        edge = NormalDist().inv_cdf(glide_share)
        for i in range(nb):
            x_ = ou_process(n, dt, 1.0, glide_time, rng)
            flap[:, i] = 1 / (1 + np.exp(-4 * (x_ - edge)))
    if surge > 0:
        # flapping speeds the bird up, gliding slows it: a radial velocity surge along
        # the group's line-of-sight component of the heading
        radial = np.gradient(rng_c, dt) / np.maximum(speed, 1e-3)
        for i in range(nb):
            cyc = flap[:, i] - flap[:, i].mean() if sp.glides else ou_process(n, dt, 0.5, 1.0, manoeuvre_rng)
            r[:, i] += np.cumsum(surge * speed * cyc * radial) * dt
    return BirdGroup(
        t,
        r,
        az,
        amp,
        f_wb,
        rng.uniform(0, 2 * np.pi, nb),
        10 ** (-rng.uniform(*WING_BELOW_BODY_DB, nb) / 20),
        0.15 * sp.wingspan_m * rng.uniform(0.7, 1.3, nb),
        flap,
        sp.name,
        turn_sd,
        surge,
        scint,
        glide_share,
        glide_time,
    )


def render(
    group: BirdGroup,
    n_pulses: int,
    prf_hz: float,
    wavelength_m: float,
    body_amp: float,
    rng: np.random.Generator,
    chunk: int = 1 << 16,
) -> np.ndarray:
    """Echo of the group at pulse rate: complex64 [n_pulses] (no noise)."""
    out = np.zeros(n_pulses, np.complex64)
    k = 4 * np.pi / wavelength_m
    dur = n_pulses / prf_hz
    # body RCS scintillation (aspect, wing-body shadowing) over 1.5 s
    scint = [SlowGain(dur + 1, group.scint_db, 1.5, rng) for _ in range(group.n_birds)]
    for i0 in range(0, n_pulses, chunk):
        i1 = min(n_pulses, i0 + chunk)
        t = np.arange(i0, i1) / prf_hz
        acc = np.zeros(i1 - i0, np.complex128)
        for b in range(group.n_birds):
            rb = np.interp(t, group.t_s, group.range_m[:, b])
            fl = np.interp(t, group.t_s, group.flapping[:, b])
            ph = 2 * np.pi * group.wingbeat_hz[b] * t + group.wing_phase[b]
            a = body_amp * group.amp[b] * scint[b].amplitude(t)
            body = a * (1 + 0.15 * fl * np.cos(ph)) * np.exp(-1j * k * (rb + 0.01 * fl * np.sin(ph)))
            wr = rb + group.wing_excursion_m[b] * fl * np.sin(ph)
            wing = a * group.wing_rel[b] * (0.6 + 0.4 * fl * np.cos(ph + 0.5)) * np.exp(-1j * k * wr)
            acc += body + wing
        out[i0:i1] = acc
    return out

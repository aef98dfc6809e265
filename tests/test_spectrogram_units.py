"""Spectrogram and image settings in physical units (issue 33 §2): the CPI in seconds,
the image's Doppler span in Hz, m/s or blade tips, resolved for a radar's PRF and
carrier; the paper's radar resolves to today's 4096 pulses and 480 bins."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from snakemake.utils import validate

from conftest import make_flight
from microdoppler.datasets.imaging import flight_radars, resolve_for_flights, spectrogram_for_flights
from microdoppler.datasets.tiles import tile_record
from microdoppler.emulator.radars import RADARS
from microdoppler.errors import ConfigError, InputError
from microdoppler.io.flightzarr import write_flight
from microdoppler.spectra.spectrogram import (
    C_MPS,
    SpectrogramConfig,
    SpectrogramSettings,
    blade_tip_doppler_hz,
    spectrogram,
)

REPO = Path(__file__).resolve().parents[1]
SCHEMA = REPO / "workflow" / "schemas" / "config.schema.yaml"


def paper_radar():
    r = RADARS["radar1"].radar
    return r.prf_hz, r.carrier_hz


def test_paper_radar_defaults_resolve_to_4096_and_480():
    for site in RADARS.values():
        cfg = SpectrogramSettings().resolve(site.radar.prf_hz, site.radar.carrier_hz)
        assert (cfg.n_fft, cfg.n_bins) == (4096, 480)
        assert cfg == SpectrogramConfig()  # and every other setting is today's


def test_schema_defaults_without_bins_resolve_to_4096_and_480():
    """config.yaml without n_fft/n_bins, validated (defaults filled in) as the pipeline does."""
    config = yaml.safe_load((REPO / "config" / "config.yaml").read_text())
    for key in ("n_fft", "n_bins", "window_s", "doppler_span_mps"):
        config["spectrogram"].pop(key, None)
    validate(config, schema=str(SCHEMA))
    assert config["spectrogram"]["window_s"] is None and config["spectrogram"]["doppler_span_mps"] is None
    assert SpectrogramSettings.from_config(config["spectrogram"]).resolve(*paper_radar()) == SpectrogramConfig()
    config["spectrogram"].update(window_s=0.56, doppler_span_mps=95.0)
    validate(config, schema=str(SCHEMA))
    assert SpectrogramSettings.from_config(config["spectrogram"]).resolve(*paper_radar()) == SpectrogramConfig()


def test_explicit_bins_override_the_radar():
    s = SpectrogramSettings.from_config({"n_fft": 4096, "n_bins": 480})
    assert s.resolve(5000.0, 3.3e9) == SpectrogramConfig()


def test_window_follows_prf():
    s = SpectrogramSettings(window_s=0.56)
    for prf in (2000.0, 5000.0, 7300.0, 10000.0, 20000.0):
        n = s.resolve(prf, 1.35e9).n_fft
        assert n & (n - 1) == 0
        # the nearest power of two on a log scale: within a factor sqrt(2) of the target
        assert abs(math.log2(n / (0.56 * prf))) <= 0.5


def test_velocity_span_follows_carrier():
    """The default image keeps ±47.5 m/s at any carrier: to within one bin each side."""
    prf, carrier = 5000.0, 3.3e9
    cfg = SpectrogramSettings().resolve(prf, carrier)
    span_hz = 2 * 95.0 * carrier / C_MPS
    assert cfg.n_fft == 2048
    assert abs(cfg.doppler_span_hz(prf) - span_hz) <= cfg.doppler_bin_hz(prf)
    # at 24 GHz and 2 kHz 95 m/s is 15 kHz: the default is clipped to the whole PRF
    assert SpectrogramSettings().resolve(2000.0, 24e9).n_bins == SpectrogramSettings().resolve(2000.0, 24e9).n_fft


def test_blade_tips_span_at_5khz_3_3ghz_is_clipped_to_the_prf():
    prf, carrier = 5000.0, 3.3e9
    tip_hz = 4 * math.pi * 160 * 0.19 * carrier / C_MPS
    assert blade_tip_doppler_hz(160, 0.19, carrier) == pytest.approx(tip_hz, rel=1e-12)
    cfg = SpectrogramSettings(blade_tip_rev_s=160).resolve(prf, carrier, blade_length_m=0.19)
    assert tip_hz > prf / 2 and cfg.n_bins == cfg.n_fft
    spec = spectrogram(np.ones(3 * cfg.n_fft, np.complex64), prf, cfg)
    assert spec.doppler_hz[0] == -prf / 2 and spec.doppler_hz[-1] == pytest.approx(prf / 2 - prf / cfg.n_fft)


def _tip_echo(prf, carrier, rev_s, blade_length_m, body_mps, n):
    """Echo of a point scatterer at a blade tip (radial excursion L cos) plus the body."""
    t = np.arange(n) / prf
    lam = C_MPS / carrier
    r = body_mps * t + blade_length_m * np.cos(2 * np.pi * rev_s * t)
    return np.exp(-4j * np.pi * r / lam).astype(np.complex64)


@pytest.mark.parametrize(
    "prf, carrier, rev_s, L, body_mps",
    [
        (20000.0, 1.3e9, 100.0, 0.1, 0.0),
        (20000.0, 1.3e9, 100.0, 0.1, -8.0),
        (7300.0, 1.35e9, 90.0, 0.19, 0.0),  # the paper's radar and drones
        (20000.0, 9.4e9, 20.0, 0.25, 3.0),
    ],
)
def test_blade_tips_span_covers_the_tip_echo(prf, carrier, rev_s, L, body_mps):
    """Physics: the image holds the tip echo's power (Carson's rule: ~98 %); an image
    of half that reach loses most of it."""
    cfg = SpectrogramSettings(blade_tip_rev_s=rev_s, highpass_hz=0.0).resolve(
        prf, carrier, blade_length_m=L, body_mps=body_mps
    )
    reach = 4 * math.pi * rev_s * L * carrier / C_MPS + rev_s + 2 * abs(body_mps) * carrier / C_MPS
    assert reach < prf / 2
    iq = _tip_echo(prf, carrier, rev_s, L, body_mps, 4 * cfg.n_fft)
    f = spectrogram(iq, prf, cfg).doppler_hz
    assert f[0] <= -reach and f[-1] >= reach
    assert -f[0] - 2 * cfg.doppler_bin_hz(prf) < reach  # the fewest bins that do
    full = spectrogram(iq, prf, SpectrogramConfig(n_fft=cfg.n_fft, n_bins=0, highpass_hz=0.0))
    p = 10 ** (full.power_db.astype(np.float64) / 10)
    inside = (full.doppler_hz >= f[0]) & (full.doppler_hz <= f[-1])
    assert p[:, ~inside].sum() / p.sum() < 0.04
    half = np.abs(full.doppler_hz) <= reach / 2
    assert p[:, ~half].sum() / p.sum() > 0.5


def test_physical_config_reproduces_bin_config_tiles_bit_for_bit(tmp_path, rng):
    """At the paper's 7.3 kHz, window_s/doppler_span_mps give the same tiles as n_fft/n_bins."""
    n = SpectrogramConfig().n_fft + 41 * SpectrogramConfig().hop
    fl = make_flight("f1", n=n, rng=rng)
    t = np.arange(n) / fl.prf_hz
    fl.iq = (
        fl.iq
        + 30 * np.exp(2j * np.pi * (-2 * 5.0 / fl.wavelength_m) * t)
        + 10 * np.exp(4j * np.pi * 0.19 / fl.wavelength_m * np.cos(2 * np.pi * 80 * t))
    ).astype(np.complex64)
    write_flight(tmp_path / "f1.zarr", fl)
    bins = SpectrogramSettings.from_config({"n_fft": 4096, "n_bins": 480}).resolve(fl.prf_hz, fl.carrier_hz)
    phys = spectrogram_for_flights(
        {"window_s": 0.56, "doppler_span_mps": 95.0, "n_fft": None, "n_bins": None}, tmp_path, log=lambda m: None
    )
    a, snr_a, _ = tile_record(fl, fl.iq, bins)
    b, snr_b, _ = tile_record(fl, fl.iq, phys)
    assert a.shape == (2, 20, 480)
    assert a.dtype == b.dtype and a.tobytes() == b.tobytes() and np.array_equal(snr_a, snr_b, equal_nan=True)


def test_flights_of_two_radars_need_an_explicit_cpi(tmp_path, rng):
    a, b = make_flight("a", rng=rng), make_flight("b", rng=rng)
    b.attrs["prf_hz"] = 3000.0
    write_flight(tmp_path / "a.zarr", a)
    write_flight(tmp_path / "b.zarr", b)
    with pytest.raises(InputError, match=r"attrs\.prf_hz.*2048 and 4096|attrs\.prf_hz.*4096 and 2048"):
        spectrogram_for_flights({}, tmp_path, log=lambda m: None)
    assert spectrogram_for_flights({"n_fft": 4096}, tmp_path, log=lambda m: None).n_fft == 4096


def test_blade_tips_from_the_drone_flights(tmp_path, rng):
    fl = make_flight("d", rng=rng)  # 0.19 m blades, 5 m/s radial
    write_flight(tmp_path / "d.zarr", fl)
    radars = flight_radars(tmp_path)
    assert radars[0]["blade_length_m"] == 0.19 and radars[0]["max_speed_mps"] == 5.0
    cfg = resolve_for_flights({"blade_tip_rev_s": 100.0}, radars, log=lambda m: None)
    reach = blade_tip_doppler_hz(100.0, 0.19, fl.carrier_hz) + 100.0 + 2 * 5.0 / fl.wavelength_m
    assert cfg.n_bins == 2 * (math.ceil(reach / cfg.doppler_bin_hz(fl.prf_hz)) + 1)
    birds = [dict(r, target="bird", blade_length_m=None) for r in radars]
    with pytest.raises(ConfigError, match=r"spectrogram\.blade_tip_rev_s"):
        resolve_for_flights({"blade_tip_rev_s": 100.0}, birds, log=lambda m: None)


@pytest.mark.parametrize(
    "settings, radar, key",
    [
        ({"window_s": -0.1}, (7300.0, 1.35e9), "window_s"),
        ({"window_s": 0.0}, (7300.0, 1.35e9), "window_s"),
        ({"window_s": 0.001}, (7300.0, 1.35e9), "window_s"),  # 7 pulses
        ({"window_s": "long"}, (7300.0, 1.35e9), "window_s"),
        ({"doppler_span_hz": 6000.0}, (5000.0, 3.3e9), "doppler_span_hz"),
        ({"doppler_span_hz": -10.0}, (5000.0, 3.3e9), "doppler_span_hz"),
        ({"doppler_span_hz": 0.5}, (5000.0, 3.3e9), "doppler_span_hz"),  # under two bins
        ({"doppler_span_mps": 300.0}, (5000.0, 3.3e9), "doppler_span_mps"),  # 6.6 kHz
        ({"doppler_span_mps": 95.0}, (2000.0, 24e9), "doppler_span_mps"),
        ({"blade_tip_rev_s": 0.0}, (5000.0, 3.3e9), "blade_tip_rev_s"),
        ({"blade_tip_rev_s": 160.0}, (5000.0, 3.3e9), "blade_tip_rev_s"),  # no blade length
        ({"n_bins": 5000}, (7300.0, 1.35e9), "n_bins"),
        ({"n_bins": -1}, (7300.0, 1.35e9), "n_bins"),
        ({"n_fft": 8}, (7300.0, 1.35e9), "n_fft"),
        ({"n_fft": 4096.5}, (7300.0, 1.35e9), "n_fft"),
        ({"window_s": 0.5, "n_fft": 4096}, (7300.0, 1.35e9), "window_s"),
        ({"doppler_span_hz": 800.0, "doppler_span_mps": 90.0}, (7300.0, 1.35e9), "doppler_span_mps"),
        ({"n_bins": 480, "doppler_span_hz": 800.0}, (7300.0, 1.35e9), "n_bins"),
        ({"overlap": 1.0}, (7300.0, 1.35e9), "overlap"),
        ({"bins": 480}, (7300.0, 1.35e9), "bins"),
    ],
)
def test_bad_settings_name_the_key(settings, radar, key):
    with pytest.raises(ConfigError, match=rf"config: spectrogram\.{key}:"):
        SpectrogramSettings.from_config(settings).resolve(*radar)

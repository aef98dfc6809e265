"""``microdoppler show STORE.zarr [STORE.zarr ...] --out DIR``: look at flight-zarr/1 stores.

Per store, ``DIR/<flight_id>.png``: the spectrogram over the whole PRF and over the
span the pipeline's images keep (Doppler in Hz and radial velocity in m/s, time in s),
and the rotor speeds per rotor over time with their ±2 sigma band and any alternative
order where the store holds rotor speeds (estimated from the radar or logged). A table
of the rotor speeds (one row per rotor of each store) is printed and written as
``DIR/rotor_speeds.csv``; a drone store's declared fields that its recording cannot
test (a factor 2 off would pass every check: ``setup_not_testable`` of the diagnosis)
are printed with the reason.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from . import add_overwrite

#: the table's file name in the output folder
TABLE_NAME = "rotor_speeds.csv"


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "show",
        help="draw the spectrogram and rotor speeds of flight-zarr/1 stores",
        description=__doc__.split("\n\n")[1],
    )
    p.add_argument("stores", nargs="+", help="flight-zarr/1 stores (directories)")
    p.add_argument("--out", required=True, help="folder for <flight_id>.png and " + TABLE_NAME)
    p.add_argument(
        "--config",
        default="",
        help="YAML whose spectrogram: section sets the CPI and the images' span (the pipeline's config "
        "file); default the paper's (0.56 s, ±47.5 m/s)",
    )
    add_overwrite(p)
    p.set_defaults(func=run)


def _settings(path):
    import yaml

    from ..spectra.spectrogram import SpectrogramSettings

    if not path:
        return SpectrogramSettings()
    try:
        d = yaml.safe_load(Path(path).read_text())
    except OSError as exc:
        raise InputError(path, "file", f"cannot be read ({exc.strerror})", "a YAML file") from None
    except yaml.YAMLError as exc:
        raise InputError(path, "yaml", f"is not valid YAML ({type(exc).__name__})", "a YAML mapping") from None
    if not isinstance(d, dict):
        raise InputError(path, "yaml", f"is a {type(d).__name__}", "a mapping with a spectrogram: section")
    return SpectrogramSettings.from_config(d.get("spectrogram"), source=path)


def _is_own(entry: Path) -> bool:
    return entry.is_file() and (entry.suffix == ".png" or entry.name == TABLE_NAME)


def _untestable(flight) -> dict:
    """The declared fields the store's recording cannot test, at its rotor speeds
    (:func:`microdoppler.rotors.plausibility.setup_testability`; ``{}`` without them)."""
    from ..rotors.plausibility import flight_rates, setup_testability

    rates, source = flight_rates(flight)
    if not rates:
        return {}
    return setup_testability(flight, rates[0], log_independent=source == "the motor log")


def run(args) -> int:
    from ..io.flightzarr import read_flight
    from ..io.outputs import atomic_file, check_output
    from ..views import plot_store, rotor_table, table_csv, table_text

    out = check_output(args.out, kind="folder", overwrite=args.overwrite, is_own=_is_own)
    settings = _settings(args.config)
    flights, seen = [], {}
    for store in args.stores:  # every store read (and checked) before anything is written
        f = read_flight(store)
        if f.flight_id in seen:
            raise InputError(
                store,
                "flight_id",
                f"{f.flight_id!r} is also the flight id of {seen[f.flight_id]}",
                "one store per flight id (the figures are named by it)",
            )
        seen[f.flight_id] = store
        flights.append((store, f))
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for store, f in flights:
        png = plot_store(f, out / f"{f.flight_id}.png", settings=settings)
        t = rotor_table(f)
        note = (
            ""
            if t
            else (
                ": no rotor speeds in the store (import it with `microdoppler import "
                "--estimate-motors` to estimate them from the radar, or --motor-log)"
                if f.attrs.get("target") == "drone"
                else ""
            )
        )
        print(f"wrote {png}{note}")
        for field, why in _untestable(f).items():
            print(f"{f.flight_id}: {field} not testable from this recording: {why}")
        rows += t
    with atomic_file(out / TABLE_NAME) as tmp:
        tmp.write_text(table_csv(rows))
    if rows:
        print(table_text(rows))
    print(f"wrote {out / TABLE_NAME} ({len(rows)} rotor{'s' if len(rows) != 1 else ''})")
    return 0

"""Bad input and outputs that already exist: one line, exit 2, no traceback, nothing
lost and nothing written. One parametrised case per row of the reliability issue."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO, make_flight, one_line, run_cli
from microdoppler.io.flightzarr import write_flight
from microdoppler.io.outputs import check_output, commit_dir, is_tool_store

SIM = ["--motor-hz", "80,85", "--duration-s", "0.3", "--quiet"]


@pytest.fixture
def user_dir(tmp_path):
    """A directory of the user's, holding a file the tool must never touch."""
    d = tmp_path / "mine"
    d.mkdir()
    (d / "notes.txt").write_text("precious")
    return d


def _intact(d: Path):
    assert (d / "notes.txt").read_text() == "precious"


# ---- data loss -------------------------------------------------------------------


@pytest.mark.parametrize("overwrite", [[], ["--overwrite"]])
@pytest.mark.parametrize("command", ["ingest", "simulate"])
def test_out_on_a_users_directory_is_refused_and_kept(capsys, user_dir, ulog_path, command, overwrite):
    argv = ["ingest", ulog_path] if command == "ingest" else ["simulate", *SIM]
    rc, err = run_cli(capsys, [*argv, "--out", user_dir, *overwrite])
    one_line(rc, err, str(user_dir))
    _intact(user_dir)
    assert sorted(p.name for p in user_dir.iterdir()) == ["notes.txt"]
    assert not [p for p in user_dir.parent.iterdir() if p.name.startswith(".")]  # no temporary left


@pytest.mark.parametrize("where", [".", "..", "home", "repo"])
@pytest.mark.parametrize("command", ["ingest", "simulate", "emulate", "diagnose"])
def test_never_valid_outputs(capsys, tmp_path, monkeypatch, good_store, ulog_path, where, command):
    work = tmp_path / "work"
    work.mkdir()
    (work / "keep.txt").write_text("x")
    monkeypatch.chdir(work)
    target = {".": ".", "..": "..", "home": str(Path.home()), "repo": str(REPO)}[where]
    argv = {
        "ingest": ["ingest", ulog_path],
        "simulate": ["simulate", *SIM],
        "emulate": ["emulate", "--profile", "test", "--quiet"],
        "diagnose": ["diagnose", good_store],
    }[command]
    rc, err = run_cli(capsys, [*argv, "--out", target, "--overwrite"])
    one_line(rc, err, "--out")
    assert (work / "keep.txt").read_text() == "x"


def test_overwrite_replaces_only_the_tools_own_store(capsys, tmp_path):
    out = tmp_path / "sim.zarr"
    assert run_cli(capsys, ["simulate", *SIM, "--out", out])[0] == 0
    assert is_tool_store(out)
    rc, err = run_cli(capsys, ["simulate", *SIM, "--out", out])
    one_line(rc, err, "already exists", "--overwrite")
    rc, _ = run_cli(capsys, ["simulate", *SIM, "--seed", "5", "--out", out, "--overwrite"])
    assert rc == 0 and is_tool_store(out)
    # a foreign file inside our own store makes it not ours any more
    (out / "readme.txt").write_text("mine")
    rc, err = run_cli(capsys, ["simulate", *SIM, "--out", out, "--overwrite"])
    one_line(rc, err, "readme.txt")
    assert (out / "readme.txt").read_text() == "mine"


def test_library_commit_never_replaces_a_foreign_directory(tmp_path, user_dir):
    from microdoppler.errors import InputError

    with pytest.raises(InputError, match="not a store written by microdoppler"):
        write_flight(user_dir, make_flight())
    _intact(user_dir)
    tmp = tmp_path / "t"
    tmp.mkdir()
    with pytest.raises(InputError):
        commit_dir(tmp, user_dir)
    _intact(user_dir)


def test_emulate_overwrite_only_its_own_world(capsys, tmp_path, user_dir):
    rc, err = run_cli(capsys, ["emulate", "--profile", "test", "--quiet", "--out", user_dir, "--overwrite"])
    one_line(rc, err, "notes.txt")
    _intact(user_dir)


def test_ci_script_deletes_only_what_it_created():
    """`.ci/run` works in a temporary directory of its own: every `rm` in it targets
    that directory, never `results/` or anything else of a user's checkout."""
    text = (REPO / ".ci" / "run").read_text()
    rms = [ln.strip() for ln in text.splitlines() if ln.strip().startswith("rm ") or " rm -" in ln]
    assert "rm -rf results" not in text
    assert all('"$CI_WORK' in ln for ln in rms), rms


# ---- one line, exit 2, nothing written ---------------------------------------------


def _bad_yaml(d):
    p = d / "bad.yaml"
    p.write_text("diagnosis: {alpha: [1,\n")
    return p


def _yaml(d, text):
    p = d / "c.yaml"
    p.write_text(text)
    return p


@pytest.mark.parametrize(
    "case, argv, field",
    [
        ("ulg is a directory", lambda d, s: ["ingest", d / "dir.ulg"], "is a directory"),
        ("duration inf", lambda d, s: ["simulate", *SIM, "--duration-s", "inf"], "--duration-s"),
        ("prf inf", lambda d, s: ["simulate", *SIM, "--prf-hz", "inf"], "--prf-hz"),
        ("snr -inf", lambda d, s: ["simulate", *SIM, "--snr-db=-inf"], "--snr-db"),
        ("snr nan", lambda d, s: ["simulate", *SIM, "--snr-db", "nan"], "--snr-db"),
        ("seed -1", lambda d, s: ["simulate", *SIM, "--seed=-1"], "--seed"),
        ("carrier inf", lambda d, s: ["simulate", *SIM, "--carrier-hz", "inf"], "--carrier-hz"),
        ("window 0", lambda d, s: ["simulate", *SIM, "--window-pulses", "0"], "--window-pulses"),
        ("motor 7000", lambda d, s: ["simulate", "--motor-hz", "7000", "--duration-s", "0.3"], "--motor-hz"),
        (
            "typical -5",
            lambda d, s: ["simulate", "--motor-log", s["ulog"], "--variant", "fixed_speeds", "--typical-hz=-5"],
            "--typical-hz",
        ),
        (
            "log shorter than duration",
            lambda d, s: ["simulate", "--motor-log", s["ulog"], "--duration-s", "60"],
            "--duration-s",
        ),
        ("diagnose invalid yaml", lambda d, s: ["diagnose", s["store"], "--config", _bad_yaml(d)], "yaml"),
        (
            "diagnose alpha 2",
            lambda d, s: ["diagnose", s["store"], "--config", _yaml(d, "diagnosis: {alpha: 2}\n")],
            "diagnosis.alpha",
        ),
        (
            "diagnose n_fft big",
            lambda d, s: ["diagnose", s["store"], "--config", _yaml(d, "n_fft: big\n")],
            "diagnosis.n_fft",
        ),
        ("emulate seed -1", lambda d, s: ["emulate", "--profile", "test", "--seed=-1"], "--seed"),
    ],
)
def test_bad_option_one_line_nothing_written(capsys, tmp_path, ulog_path, good_store, case, argv, field):
    (tmp_path / "dir.ulg").mkdir()
    out = tmp_path / ("report.json" if "diagnose" in case else "out.zarr")
    argv = argv(tmp_path, {"ulog": ulog_path, "store": good_store})
    before = sorted(p.name for p in tmp_path.iterdir())
    rc, err = run_cli(capsys, [*argv, "--out", out])
    one_line(rc, err, field)
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written, no temporaries


@pytest.mark.parametrize("command", ["ingest", "simulate", "emulate", "diagnose"])
@pytest.mark.parametrize("target", ["existing file", "below a file", "unwritable"])
def test_out_existing_file_or_unwritable(capsys, tmp_path, ulog_path, good_store, command, target):
    f = tmp_path / "taken.txt"
    f.write_text("mine")
    out = {"existing file": f, "below a file": f / "x.zarr", "unwritable": Path("/proc/self/x.zarr")}[target]
    argv = {
        "ingest": ["ingest", ulog_path],
        "simulate": ["simulate", *SIM],
        "emulate": ["emulate", "--profile", "test", "--quiet"],
        "diagnose": ["diagnose", good_store],
    }[command]
    rc, err = run_cli(capsys, [*argv, "--out", out])
    one_line(rc, err, str(out) if target != "unwritable" else "x.zarr")
    assert f.read_text() == "mine"


def test_diagnose_out_existing_directory(capsys, tmp_path, good_store, user_dir):
    rc, err = run_cli(capsys, ["diagnose", good_store, "--out", user_dir, "--overwrite"])
    one_line(rc, err, "--out", "directory")
    _intact(user_dir)


def test_diagnose_accepts_the_pipelines_config(capsys, tmp_path):
    bird = make_flight("b1", with_log=False)
    bird.attrs = {
        k: v for k, v in bird.attrs.items() if k not in ("drone_model", "n_motors", "n_blades", "blade_length_m")
    } | {"target": "bird"}
    store = write_flight(tmp_path / "b1.zarr", bird)
    rc, err = run_cli(
        capsys, ["diagnose", store, "--config", REPO / "config" / "config.yaml", "--out", tmp_path / "r.json"]
    )
    assert rc == 0, err
    assert (tmp_path / "r.json").exists()


# ---- validation that reads the data ------------------------------------------------


def _store(tmp_path, name="s", background=True):
    f = make_flight(name, n=8192)
    if background:
        f.background_iq = f.iq.copy()
    return write_flight(tmp_path / f"{name}.zarr", f, chunk_pulses=2048)


def _set(store, path, values):
    import zarr

    zarr.open_array(str(store / path), mode="r+")[...] = values


def _nan(path):
    def make(store):
        import zarr

        a = zarr.open_array(str(store / path), mode="r+")
        a[3000] = np.nan

    return make


def _two_d(store):
    import zarr

    g = zarr.open_group(str(store), mode="r+")
    iq = np.asarray(g["iq"][...])
    del g["iq"]
    g.create_array("iq", data=np.stack([iq, iq], axis=1).astype(np.complex64))


def _missing_chunk(store):
    os.remove(store / "iq" / "c" / "2")


def _truncated_chunk(store):
    p = store / "iq" / "c" / "1"
    p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])


@pytest.mark.parametrize(
    "case, damage, field",
    [
        ("iq NaN", _nan("iq"), "iq: contains NaN"),
        ("background NaN", _nan("background/iq"), "background/iq: contains NaN"),
        ("iq 2-D", _two_d, "iq: has 2 dimensions"),
        ("missing chunk", _missing_chunk, "chunk files missing"),
        ("truncated chunk", _truncated_chunk, "cannot be read"),
    ],
)
def test_validate_reads_the_data(capsys, tmp_path, case, damage, field):
    store = _store(tmp_path)
    assert run_cli(capsys, ["validate", store])[0] == 0
    damage(store)
    rc, err = run_cli(capsys, ["validate", store])
    one_line(rc, err, str(store), field)
    if case in ("iq NaN", "missing chunk"):  # --quick reads metadata only
        assert run_cli(capsys, ["validate", "--quick", store])[0] == 0


@pytest.mark.parametrize(
    "damage, field", [(_missing_chunk, "chunk files missing"), (_truncated_chunk, "cannot be read")]
)
def test_diagnose_and_read_refuse_a_damaged_store(capsys, tmp_path, damage, field):
    store = _store(tmp_path)
    damage(store)
    rc, err = run_cli(capsys, ["diagnose", store, "--out", tmp_path / "r.json"])
    one_line(rc, err, str(store), field)
    assert not (tmp_path / "r.json").exists()


def test_validate_streams_chunk_by_chunk(tmp_path, monkeypatch):
    """Content validation reads one chunk at a time (a 30-minute flight stays in memory)."""
    import microdoppler.io.flightzarr as fz

    store = _store(tmp_path)
    sizes = []
    real = fz._read

    def spy(s, p, node, sel=Ellipsis):
        out = real(s, p, node, sel)
        sizes.append((p, out.size))
        return out

    monkeypatch.setattr(fz, "_read", spy)
    fz.validate_store(store)
    assert max(n for p, n in sizes if p in ("iq", "background/iq")) == 2048


def test_check_output_kinds(tmp_path):
    from microdoppler.errors import InputError

    new = tmp_path / "new" / "deeper" / "x.zarr"
    assert check_output(new, kind="store") == new and not new.exists()
    (tmp_path / "empty").mkdir()
    assert check_output(tmp_path / "empty", kind="folder")
    with pytest.raises(InputError, match="not empty"):
        (tmp_path / "empty" / "a").write_text("a")
        check_output(tmp_path / "empty", kind="folder")
    rep = tmp_path / "r.json"
    rep.write_text('{"schema": "diagnosis-report/2"}')
    assert check_output(rep, kind="report", overwrite=True)
    rep.write_text('{"my": "data"}')
    with pytest.raises(InputError, match="not a report"):
        check_output(rep, kind="report", overwrite=True)
    shutil.rmtree(tmp_path / "empty")


# --- unknown configuration keys: rejected everywhere, in one line -------------------


def test_an_unknown_config_key_is_named_with_its_section():
    import yaml

    from microdoppler.classifier.training import TrainConfig
    from microdoppler.errors import ConfigError, check_config_keys

    repo = Path(__file__).resolve().parents[1]
    schema = yaml.safe_load((repo / "workflow/schemas/config.schema.yaml").read_text())
    for f in sorted((repo / "config").glob("*.yaml")):  # the shipped configs hold no unknown key
        cfg = yaml.safe_load(f.read_text())
        check_config_keys(cfg, schema, source=f)
        TrainConfig.from_config(cfg.get("classifier", {}))
    cfg = yaml.safe_load((repo / "config/config.yaml").read_text())
    for section, key in (("classifier", "lerning_rate"), ("spectrogram", "nfft"), ("datasets", "splitt")):
        bad = {**cfg, section: {**cfg[section], key: 1}}
        with pytest.raises(ConfigError) as err:
            check_config_keys(bad, schema, source="my.yaml")
        msg = str(err.value)
        assert "\n" not in msg and msg.startswith(f"my.yaml: {section}.{key}: unknown key in section {section}"), msg
    with pytest.raises(ConfigError, match=r"classifier\.lerning_rate: unknown key"):
        TrainConfig.from_config({**cfg["classifier"], "lerning_rate": 0.1})
    with pytest.raises(ConfigError, match="top level"):
        check_config_keys({**cfg, "clasifier": {}}, schema)

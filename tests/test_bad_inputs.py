"""Bad files and values, each the way a user meets them: one line naming the file (or the option)
and what is wrong, exit 2, before any work starts and with nothing written. One test per case
found by trying the commands on real mistakes (a truncated copy, a text file named .h5, a folder,
a missing session in a campaign, ...)."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from snrmon.cli import build_parser, iter_parsers, main
from tests.acquisition.session_factory import write_session

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def files(module_tmp) -> dict[str, Path]:
    d = module_tmp("bad-inputs")
    session = write_session(d / "s.h5", ranges_m=(120.0,), hover_s=2.0, transit_s=1.0).path
    data = session.read_bytes()
    (d / "truncated.h5").write_bytes(data[: len(data) // 2])
    (d / "empty.h5").write_bytes(b"")
    (d / "text.h5").write_text("notes from the field\n")
    (d / "notes.txt").write_text("notes from the field\n")
    with h5py.File(d / "plain.h5", "w") as f:
        f["x"] = np.arange(3)
    (d / "folder").mkdir()
    return {p.name: p for p in d.iterdir()} | {"dir": d}


def _one_line(capsys, argv: list[str], *needles: str) -> str:
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse's own refusal
        code = exc.code
    err = capsys.readouterr().err.strip()
    assert code == 2, f"snrmon {' '.join(map(str, argv))} -> exit {code}: {err}"
    lines = err.splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("snrmon ") and ": error: " in lines[0], lines[0]
    for n in needles:
        assert n in lines[0], f"{lines[0]!r} does not say {n!r}"
    assert "Errno" not in lines[0] and "HDF5 library" not in lines[0]
    return lines[0]


@pytest.mark.parametrize(
    "argv",
    [
        ["replay", "{f}"],
        ["report", "{f}", "-o", "{dir}/r.pdf"],
        ["psf", "{f}", "--camera", "lwir", "--stop", "1"],
        ["characterize", "{f}", "--camera", "lwir", "--stop", "1"],
        ["campaign", "{f}", "--out", "{dir}/c", "--workers", "0"],
        ["gps-import", "{f}", "{dir}/notes.txt"],
    ],
    ids=lambda a: a[0],
)
def test_truncated_session_is_named_truncated(files, capsys, argv) -> None:
    f, d = files["truncated.h5"], files["dir"]
    line = _one_line(capsys, [a.format(f=f, dir=d) for a in argv], str(f), "truncated HDF5 file")
    assert "stored_eof" in line  # the library's own reason, on the same one line
    assert not (d / "c").exists() and not (d / "r.pdf").exists()


@pytest.mark.parametrize(
    "name, says", [("empty.h5", "is empty (0 bytes)"), ("text.h5", "not an HDF5 file")]
)
def test_empty_or_text_file_named_h5_is_not_a_session(files, capsys, name, says) -> None:
    """It used to say "give --at X,Y": as if it were another tool's recording."""
    line = _one_line(capsys, ["replay", files[name]], str(files[name]), says)
    assert "--at" not in line


@pytest.mark.parametrize(
    "argv",
    [
        ["replay", "{d}"],
        ["record", "--config", "{d}", "--out", "{out}"],
        ["measure", "{d}", "--at", "1,1"],
        ["psf", "{d}", "--camera", "lwir", "--stop", "1"],
        ["report", "{d}", "-o", "{out}.pdf"],
        ["gps-import", "{s}", "{d}"],
    ],
    ids=lambda a: a[0],
)
def test_a_folder_is_named_a_folder(files, capsys, argv) -> None:
    d, out = files["folder"], files["dir"] / "new.h5"
    argv = [a.format(d=d, out=out, s=files["s.h5"]) for a in argv]
    _one_line(capsys, argv, str(d), "is a folder, not a file")


def test_campaign_checks_every_session_before_a_cluster_and_writes_nothing(files, capsys) -> None:
    """It started a two-worker cluster, exited 1 and left an empty stops.parquet and report."""
    out = files["dir"] / "campaign-out"
    missing = files["dir"] / "missing.h5"
    _one_line(capsys, ["campaign", files["s.h5"], missing, "--out", out], str(missing))
    assert not out.exists()


def test_campaign_out_that_is_a_file(files, capsys) -> None:
    notes = files["notes.txt"]
    before = notes.read_bytes()
    _one_line(
        capsys,
        ["campaign", files["s.h5"], "--out", notes],
        str(notes),
        "is a file, not a folder",
    )
    assert notes.read_bytes() == before


def test_gps_import_into_an_hdf5_file_that_is_not_a_session(files, capsys) -> None:
    """It was `internal error: KeyError`."""
    plain = files["plain.h5"]
    _one_line(
        capsys,
        ["gps-import", plain, files["notes.txt"]],
        str(plain),
        "not a snrmon session",
    )


def test_a_session_without_the_camera_asked(files, capsys) -> None:
    s = files["s.h5"]
    _one_line(
        capsys,
        ["psf", s, "--camera", "swir", "--stop", "1"],
        str(s),
        "no camera 'swir'",
        "lwir, mwir",
    )


def test_negative_numbers_are_values_not_options(capsys) -> None:
    """argparse said "expected one argument" before the command could look at the value."""
    line = _one_line(capsys, ["hil", "--stops", "-100,200"], "--stops", "-100", "negative")
    assert "expected one argument" not in line


def test_a_malformed_at_is_refused(files, capsys) -> None:
    """`replay s.h5 --at abc` ran to the end and exited 0, the value ignored."""
    _one_line(capsys, ["replay", files["s.h5"], "--at", "abc"], "--at", "'abc'")


def test_every_command_takes_quiet_verbose_and_log_file() -> None:
    """`campaign -q` was "unrecognized": its own --quiet hid the common -q."""
    parser = build_parser()
    for p in iter_parsers(parser):
        flags = set(p._option_string_actions)
        assert {"-q", "--quiet", "-v", "--verbose", "--log-file"} <= flags, p.prog
    args = parser.parse_args(["campaign", "-q", "s.h5", "--out", "d"])
    assert args.quiet is True


def _guide_config(folder: Path) -> Path:
    """The operator guide's own session TOML, exactly as the guide prints it."""
    text = (REPO / "docs" / "operator-guide.md").read_text()
    block = text.split("```toml\n", 1)[1].split("```", 1)[0]
    assert '[cameras.mwir]\nsource = "aravis"' in block
    path = folder / "session.toml"
    path.write_text(block)
    return path


@pytest.mark.slow
def test_doctor_without_pygobject_fails_the_backend_row_and_goes_on(
    tmp_path, capsys, monkeypatch
) -> None:
    """With the guide's TOML (an Aravis camera) and no PyGObject, doctor aborted with one line
    and no check list; --json printed nothing."""
    import json

    monkeypatch.setitem(sys.modules, "gi", None)  # PyGObject not installed
    config = _guide_config(tmp_path)
    argv = ["doctor", "--config", str(config), "--headless", "--wait", "0.2"]
    argv += ["--disk-test-mb", "1", "--record-dir", str(tmp_path)]
    code = main([*argv, "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 1 and out["ok"] is False
    rows = {c["name"]: c for c in out["checks"]}
    for name in ("aravis", "camera:mwir"):
        assert rows[name]["label"] == "FAIL", rows[name]
        assert "PyGObject" in rows[name]["fix"] and "gir1.2-aravis-0.8" in rows[name]["fix"]
    # ... and every other check ran: the other camera, the model, the disk.
    assert {"camera:lwir", "model:lwir", "disk-speed", "disk-space"} <= set(rows)
    code = main(argv)
    text = capsys.readouterr().out
    assert code == 1 and "FAIL  aravis" in text and "fix: Aravis cameras need PyGObject" in text
    assert "checks, NOT ready" in text


def test_campaign_on_good_sessions_still_runs_quietly(files, capsys) -> None:
    """The checks refuse only what is wrong: the same session and -q run to the end."""
    out = files["dir"] / "quiet"
    copy = files["dir"] / "copy.h5"
    shutil.copyfile(files["s.h5"], copy)
    code = main(
        ["campaign", "-q", str(copy), "--out", str(out), "--workers", "0", "--report", "none"]
    )
    assert code == 0 and (out / "stops.parquet").is_file()
    assert capsys.readouterr().err == ""

"""analysis.toml: checked key by key, applied to every task, recorded in the outputs.
On small sessions from the recorder (two cameras, 40x56 px), run serially: no HIL needed."""

from __future__ import annotations

import json

import pyarrow.parquet as pq
import pytest

from snrmon.campaign.settings import load_settings, settings_from_dict
from snrmon.campaign.tables import read_metadata
from snrmon.cli import main
from tests.acquisition.session_factory import write_session


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"measurement": {"box": 7}}, "[measurement]: unknown key 'box'"),
        ({"measurement": {"box_px": 6}}, "box"),
        ({"measurement": {"background": "sky"}}, 'expected "rim" or [x0, y0, x1, y1]'),
        ({"model": {"background_temp_k": -3}}, "background_temp_k = -3"),
        ({"replay": {"track": "maybe"}}, "expected one of recorded, on, off"),
        ({"calibration": {"mwir": 3}}, "[calibration] mwir = 3"),
        ({"extra": {}}, "analysis settings: unknown key 'extra'"),
    ],
)
def test_bad_settings_name_the_key_and_value(data, message):
    with pytest.raises(ValueError) as err:
        settings_from_dict(data)
    assert message in str(err.value)


def test_relative_calibration_paths_are_relative_to_the_file(tmp_path):
    toml = tmp_path / "analysis.toml"
    toml.write_text(
        '[calibration]\nmwir = "cal/mwir.npz"\n[measurement]\nbackground = [1, 2, 9, 8]\n'
    )
    s = load_settings(toml)
    assert s.calibrations == {"mwir": str(tmp_path / "cal" / "mwir.npz")}
    assert s.measurement == {"background": (1, 2, 9, 8)} and s.source == str(toml)


@pytest.fixture(scope="module")
def small_sessions(module_tmp):
    """Two sessions named s.h5 in two folders (as two days of a campaign would be)."""
    folder = module_tmp("small")
    paths = []
    for i in (1, 2):
        (folder / f"day{i}").mkdir()
        paths.append(write_session(folder / f"day{i}" / "s.h5", seed=i).path)
    return paths


def _run(argv, capsys) -> tuple[int, dict]:
    code = main(["campaign", *argv, "--json", "--quiet"])
    return code, json.loads(capsys.readouterr().out)


@pytest.mark.slow
def test_settings_change_the_measurement_and_are_recorded(small_sessions, tmp_path, capsys):
    sessions = list(map(str, small_sessions))
    code, base = _run([*sessions, "--out", str(tmp_path / "a"), "--workers", "0"], capsys)
    assert code == 0 and base["executor"] == "serial"
    # Same file name in two folders: the table names them by their folders.
    assert sorted(base["labels"].values()) == ["day1/s", "day2/s"]
    assert {(t["session"], t["camera"]) for t in base["tasks"]} == {
        (d, c) for d in ("day1/s", "day2/s") for c in ("mwir", "lwir")
    }
    toml = tmp_path / "analysis.toml"
    toml.write_text(
        '[measurement]\nbox_px = 5\ndetrend = true\n[model]\ntarget = "uav2"\n'
        "background_temp_k = 250.0\n"
    )
    code, _ = _run(
        [
            *sessions,
            "--out",
            str(tmp_path / "b"),
            "--workers",
            "0",
            "--settings",
            str(toml),
            "--report",
            str(tmp_path / "b.png"),
        ],
        capsys,
    )
    assert code == 0
    a = pq.read_table(tmp_path / "a" / "stops.parquet").to_pylist()
    b = pq.read_table(tmp_path / "b" / "stops.parquet").to_pylist()
    assert len(a) == len(b) >= 4
    for ra, rb in zip(a, b, strict=True):
        assert (ra["session"], ra["camera"], ra["stop"]) == (
            rb["session"],
            rb["camera"],
            rb["stop"],
        )
        assert (ra["box_px"], ra["background_method"], ra["target"]) == (7, "rim", "uav1")
        assert (rb["box_px"], rb["background_method"], rb["target"]) == (5, "rim+detrend", "uav2")
        assert rb["model_sky_temp_k"] == 250.0 and ra["model_sky_temp_k"] != 250.0
        if ra["n_frames"]:
            assert rb["snr_mean"] != ra["snr_mean"]  # a 5x5 box's 16-pixel rim, detrended
            assert rb["model_small"] != ra["model_small"]
    meta = read_metadata(tmp_path / "b" / "stops.parquet")
    assert meta["settings"]["measurement"] == {"box_px": 5, "detrend": True}
    assert meta["settings"]["model_options"] == {"background_temp_k": 250.0}
    assert meta["settings"]["source"] == str(toml)
    assert (tmp_path / "b.png").stat().st_size > 10_000


def test_a_missing_calibration_fails_that_camera_only(small_sessions, tmp_path, capsys):
    toml = tmp_path / "analysis.toml"
    toml.write_text('[calibration]\nmwir = "nope.npz"\n')
    code, out = _run(
        [
            str(small_sessions[0]),
            "--out",
            str(tmp_path / "o"),
            "--workers",
            "0",
            "--settings",
            str(toml),
            "--report",
            "none",
        ],
        capsys,
    )
    assert code == 1
    assert [(f["camera"], "nope.npz" in f["error"]) for f in out["failures"]] == [("mwir", True)]
    assert {r["camera"] for r in out["stops"]} == {"lwir"} and out["report"] is None

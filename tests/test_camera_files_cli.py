"""``snrmon noise``, ``measure`` and ``replay`` on the real FLIR recording and frame: the 3D noise
against the reference written from its definitions, Eq. (4) at a real point against the same
equation on the counts decoded byte by byte here, and damaged files as one line or a warning."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from snrmon.cli import main
from tests.acquisition.measure.test_noise3d import reference_figures
from tests.acquisition.replay.test_flir import reference_frames
from tests.helpers import strict_json

DATA = Path(__file__).parent / "data" / "field-formats" / "flir"
FFF = DATA / "flirpy-frame_000000.fff"
PEAK = (363, 92)  # the brightest pixel of frame 0 (x column, y row)


@pytest.fixture(scope="session")
def seq(flir_files) -> Path:
    """The real FLIR Duo Pro R recording (7 frames 640x512)."""
    return flir_files / "flirpy-test.seq"


@pytest.fixture(scope="module")
def counts(seq) -> np.ndarray:
    return np.stack([f.pixels for f in reference_frames(seq.read_bytes())]).astype(float)


def eq4(frame: np.ndarray, x: int, y: int) -> float:
    """Paper Eq. (4) at a peak: (peak - mean(rim)) / std(rim, ddof 1), the 24 rim pixels of
    the 7x7 box centred on it."""
    box = frame[y - 3 : y + 4, x - 3 : x + 4]
    rim = np.concatenate([box[0], box[-1], box[1:-1, 0], box[1:-1, -1]])
    return (frame[y, x] - rim.mean()) / rim.std(ddof=1)


def test_noise_of_the_seq_is_the_reference_3d_noise(seq, counts, capsys):
    assert main(["noise", str(seq), "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    assert (out["frames"], out["rows"], out["cols"]) == (7, 512, 640)
    sigma, corrected = reference_figures(counts)
    assert out["mean_dn"] == pytest.approx(counts.mean(), rel=1e-12)
    for k, value in sigma.items():
        assert out["sigma_dn"][k] == pytest.approx(value, rel=1e-9)
        assert out["sigma_corrected_dn"][k] == pytest.approx(corrected[k], rel=1e-9)
    total = out["sigma_dn"]["total"]
    assert math.isfinite(total) and total > 0  # 14.41 DN: the scene's spread
    assert 0 < out["sigma_corrected_dn"]["tvh"] < out["sigma_corrected_dn"]["vh"]
    assert main(["noise", str(seq)]) == 0
    assert "flirpy-test.seq: frames 0-6, camera Duo Pro R;" in capsys.readouterr().out


def test_noise_of_one_fff_frame_is_one_line_exit_2(capsys):
    assert main(["noise", str(FFF)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "snrmon noise: error: flirpy-frame_000000.fff: frames 0-0, camera Duo Pro R: 3D noise "
        "needs at least 2 frames"
    ]


def test_measure_at_a_real_point_is_eq4_on_the_counts(seq, counts, capsys):
    x, y = PEAK
    assert main(["measure", str(seq), "--at", f"{x},{y}", "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    assert out["n"] == 7
    for i, frame in enumerate(out["frames"]):
        assert (frame["peak_x"], frame["peak_y"]) == PEAK
        assert frame["peak"] == counts[i, y, x]
        assert frame["snr"] == pytest.approx(eq4(counts[i], x, y), rel=1e-12)
        assert frame["snr"] > 0
    assert out["snr_mean"] == pytest.approx(np.mean([eq4(c, x, y) for c in counts]), rel=1e-12)
    # the .fff is the recording's first frame: the same measurement
    assert main(["measure", str(FFF), "--at", f"{x},{y}", "--json"]) == 0
    one = strict_json(capsys.readouterr().out)
    assert one["n"] == 1 and one["frames"][0]["snr"] == out["frames"][0]["snr"]


def test_replay_of_the_seq_tracks_from_the_point(seq, counts, capsys):
    x, y = PEAK
    assert main(["replay", str(seq), "--at", f"{x},{y}", "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    assert out["n"] == 7
    assert [f["track_state"] for f in out["frames"]] == ["tracking"] * 7
    first = out["frames"][0]
    assert (first["peak_x"], first["peak_y"]) == PEAK
    assert first["snr"] == pytest.approx(eq4(counts[0], x, y), rel=1e-12)


def test_a_recording_cut_in_half_is_measured_to_its_last_whole_frame(seq, tmp_path, capsys):
    cut = tmp_path / "cut.seq"
    data = seq.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    assert main(["noise", str(cut), "--json"]) == 0
    captured = capsys.readouterr()
    assert strict_json(captured.out)["frames"] == 3
    (warning,) = captured.err.strip().splitlines()
    assert warning.startswith(f"snrmon noise: warning: {cut}: the file is cut short in frame 3")
    assert warning.endswith("read its 3 whole frames")
    frame = tmp_path / "cut.fff"
    frame.write_bytes(FFF.read_bytes()[:300_000])
    assert main(["measure", str(frame), "--at", "363,92"]) == 2
    (error,) = capsys.readouterr().err.strip().splitlines()
    assert error.startswith(f"snrmon measure: error: {frame}: truncated FFF frame 0")

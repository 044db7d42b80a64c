"""``snrmon replay`` on other tools' recordings: the real thermal clip (8-bit AGC'd video)."""

from __future__ import annotations

from snrmon.cli import main
from tests.helpers import strict_json


def test_replay_of_a_video_measures_every_frame_from_the_click(shared_data, capsys):
    clip = shared_data / "ir_small_targets" / "videos" / "IR_DRONE_138.mp4"
    # frames.csv: frame 1 box at x=270, y=146 (1-based MATLAB corner), 8x8 -> centre ~ (273, 149)
    assert main(["replay", str(clip), "--at", "273,149", "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    assert out["n"] == 301
    first = out["frames"][0]
    assert abs(first["peak_x"] - 273) <= 4 and abs(first["peak_y"] - 149) <= 4
    assert first["snr"] > 5  # the drone stands out of the sky in the first frame
    assert all("track_state" in f for f in out["frames"])


def test_replay_of_a_foreign_file_needs_the_click(shared_data, capsys):
    clip = shared_data / "ir_small_targets" / "videos" / "IR_DRONE_138.mp4"
    assert main(["replay", str(clip)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--at X,Y" in err[0]


def test_replay_of_a_missing_file(tmp_path, capsys):
    assert main(["replay", str(tmp_path / "nope.h5")]) == 2
    assert "does not exist" in capsys.readouterr().err

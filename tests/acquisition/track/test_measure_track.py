"""``snrmon measure --track``: the gated tracker behind the same JSON contract, plus track_state."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.acquisition.track.tracker import track_stack
from snrmon.cli import main
from tests.helpers import strict_json

FRAME_KEYS = ["index", "peak_x", "peak_y", "peak", "bg_mean", "bg_std", "snr", "flags"]
TRACK_KEYS = ["background", "extent_w_px", "extent_h_px", "track_state"]
DRONE_Y = 24


def _spot(xx, yy, x, y, amplitude):
    return amplitude * np.exp(-((xx - x) ** 2 + (yy - y) ** 2) / (2 * 0.8**2))


def _drifting_drone_with_bird(fade: range | None = None) -> np.ndarray:
    """40 frames: the drone drifts 1 px right every 5 frames from (20, 24); frames 10-19 a
    bird 7x brighter crosses 5 px above it, inside the untracked 11x11 search window."""
    rng = np.random.default_rng(7)
    n, h, w = 40, 48, 64
    yy, xx = np.mgrid[0:h, 0:w]
    stack = rng.normal(1000.0, 5.0, (n, h, w))
    for i in range(n):
        if fade is None or i not in fade:
            stack[i] += _spot(xx, yy, 20 + i // 5, DRONE_Y, 120.0)
        if fade is None and 10 <= i < 20:
            stack[i] += _spot(xx, yy, 14 + (i - 10), DRONE_Y - 5, 900.0)
    return np.rint(stack).astype(np.uint16)


def _run(capsys, path, *extra) -> dict:
    assert main(["measure", str(path), "--at", "20,24", "--json", *extra]) == 0
    return strict_json(capsys.readouterr().out)


@pytest.fixture
def bird_stack(tmp_path):
    stack = _drifting_drone_with_bird()
    path = tmp_path / "bird.npy"
    np.save(path, stack)
    return path, stack


def test_track_stays_on_the_drone_while_the_untracked_window_takes_the_bird(bird_stack, capsys):
    path, _ = bird_stack
    tracked = _run(capsys, path, "--track")
    fixed = _run(capsys, path)
    assert list(tracked) == ["n", "snr_mean", "snr_std", "frames"] and tracked["n"] == 40
    for i, f in enumerate(tracked["frames"]):
        assert list(f) == [*FRAME_KEYS, *TRACK_KEYS]
        assert f["background"] == "rim" and 1 <= f["extent_w_px"] <= 5
        assert (f["peak_x"], f["peak_y"]) == (20 + i // 5, DRONE_Y), i
        assert f["track_state"] == "tracking"
    # Without --track the contract has no track_state and the bird captures the fixed window.
    assert all(list(f) == FRAME_KEYS for f in fixed["frames"])
    assert any(f["peak_y"] == DRONE_Y - 5 for f in fixed["frames"][10:20])


def test_track_output_is_the_trackers_own(bird_stack, capsys):
    path, stack = bird_stack
    out = _run(capsys, path, "--track")
    steps = track_stack(stack, (20, 24))
    for f, s in zip(out["frames"], steps, strict=True):
        r = s.peak_snr
        assert f["snr"] == pytest.approx(r.snr, rel=0, abs=0)
        assert set(f["flags"]) == set(r.flags)
        assert f["track_state"] == s.state.value
    snr = np.array([s.peak_snr.snr for s in steps])
    assert out["snr_mean"] == pytest.approx(snr.mean(), rel=1e-12)
    assert out["snr_std"] == pytest.approx(snr.std(ddof=1), rel=1e-12)


def test_a_faded_drone_is_a_lost_state_with_lost_flags(tmp_path, capsys):
    stack = _drifting_drone_with_bird(fade=range(15, 40))
    path = tmp_path / "fade.npy"
    np.save(path, stack)
    frames = _run(capsys, path, "--track")["frames"]
    assert [f["track_state"] for f in frames[:15]] == ["tracking"] * 15
    # 10 consecutive misses (lost_frames) -> LOST from frame 24 on, every frame flagged lost.
    assert all(f["track_state"] == "lost" and "lost" in f["flags"] for f in frames[24:])
    # The window holds at the last good position instead of walking after noise peaks.
    assert all(abs(f["peak_x"] - 22) <= 5 and abs(f["peak_y"] - DRONE_Y) <= 5 for f in frames[24:])


def test_track_table_shows_the_state_column(bird_stack, capsys):
    path, _ = bird_stack
    assert main(["measure", str(path), "--at", "20,24", "--track"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[-3:] == ["background", "state", "flags"]
    assert lines[1].split()[7:9] == ["rim", "tracking"]
    assert lines[-1].startswith("running, last ")


def test_a_click_on_a_saturated_region_is_one_clear_message(tmp_path, capsys):
    stack = _drifting_drone_with_bird()
    stack[:, 36:, :] = 65535  # a saturated band: nothing compact in it
    path = tmp_path / "sat.npy"
    np.save(path, stack)
    assert main(["measure", str(path), "--at", "30,40", "--track"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "--at 30,40: no compact object within 8 px" in err[0]
    assert "saturated region (65535 DN)" in err[0]
    # The same click without --track is Eq. (4) at a fixed point, which needs no object.
    assert main(["measure", str(path), "--at", "30,40", "--json"]) == 0

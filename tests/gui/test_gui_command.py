"""``snrmon gui``: a session TOML on a simulated shm camera runs headless and saves a screenshot;
a recording replays headless; a missing file or config is a one-line error."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import time
import uuid

import pytest
from PySide6.QtCore import QTimer
from PySide6.QtGui import QImage

from snrmon.cli import main
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.acquisition.session_factory import write_session
from tests.gui.test_console import H, W, console_render


@pytest.mark.slow
def test_gui_command_headless_runs_the_config_and_saves_a_screenshot(qtbot, tmp_path):
    ring = f"snrmon-guicli-{uuid.uuid4().hex[:10]}"
    toml = tmp_path / "session.toml"
    toml.write_text(
        f'[cameras.mwir]\nsource = "shm"\naddress = "{ring}"\nwidth_px = {W}\nheight_px = {H}\n'
    )
    png = tmp_path / "gui.png"
    with ShmProducer(ring, W, H, console_render(), fps=30.0):
        rc = main(
            [
                "gui",
                "--config",
                str(toml),
                "--headless",
                "--duration",
                "1",
                "--screenshot",
                str(png),
            ]
        )
    assert rc == 0
    img = QImage(str(png))
    assert not img.isNull() and img.width() > 400


def test_gui_replay_missing_file_is_one_line(capsys, tmp_path):
    missing = tmp_path / "x.h5"
    assert main(["gui", "--replay", str(missing)]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(missing) in err[0]


def test_gui_replay_runs_headless_with_the_model_and_saves_a_screenshot(tmp_path):
    rec = write_session(tmp_path / "flight.h5", cameras=("mwir",), hover_s=4.0)
    shot = tmp_path / "replay.png"
    code = main(
        [
            "gui",
            "--replay",
            str(rec.path),
            "--headless",
            "--duration",
            "1.5",
            "--screenshot",
            str(shot),
        ]
    )
    assert code == 0
    img = QImage(str(shot))
    assert not img.isNull() and img.width() > 400


def test_sigterm_closes_the_console_cleanly(qtbot, tmp_path):
    """``kill`` on a running console closes its window the way Ctrl-C does (screenshot taken,
    session stopped, exit 0), long before its --duration; Python's default would kill it."""
    rec = write_session(tmp_path / "flight.h5", cameras=("mwir",), hover_s=4.0)
    shot = tmp_path / "killed.png"
    before = signal.getsignal(signal.SIGTERM)
    QTimer.singleShot(300, lambda: os.kill(os.getpid(), signal.SIGTERM))
    t0 = time.monotonic()
    code = main(
        [
            "gui",
            "--replay",
            str(rec.path),
            "--headless",
            "--duration",
            "60",
            "--screenshot",
            str(shot),
        ]
    )
    assert code == 0 and time.monotonic() - t0 < 60
    assert not QImage(str(shot)).isNull()
    assert signal.getsignal(signal.SIGTERM) is before  # the handlers are put back


def test_gui_missing_config_names_the_file(capsys, tmp_path):
    missing = tmp_path / "nope.toml"
    assert main(["gui", "--config", str(missing)]) == 2
    assert str(missing) in capsys.readouterr().err


def test_offscreen_noise_is_dropped_and_other_qt_messages_kept(capsys):
    from snrmon.gui.app import _offscreen_messages

    _offscreen_messages(None, None, "This plugin does not support propagateSizeHints()")
    _offscreen_messages(None, None, "QPainter::begin: Paint device returned engine == 0")
    err = capsys.readouterr().err
    assert err == "QPainter::begin: Paint device returned engine == 0\n"


def test_bad_view_options_are_one_line_each_and_exit_2(capsys, tmp_path):
    """--size, --font-scale and the replay's --speed are checked before a window opens."""
    rec = write_session(tmp_path / "flight.h5", cameras=("mwir",), hover_s=4.0)
    replay = ["gui", "--replay", str(rec.path), "--headless", "--duration", "1"]
    for extra, named in (
        (["--window-size", "1366by768"], "'1366by768'"),
        (["--window-size", "100x768"], "'100x768'"),
        (["--font-scale", "5"], "got 5.0"),
        (["--speed", "0"], "got 0.0"),
        (["--theme", "sepia"], "'sepia'"),
    ):
        with contextlib.suppress(SystemExit):  # argparse's own refusal (the theme's choices)
            assert main([*replay, *extra]) == 2, extra
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) <= 3 and named in err[-1], (extra, err)


def test_gui_replay_opens_at_the_size_and_theme_asked(tmp_path):
    rec = write_session(tmp_path / "flight.h5", cameras=("mwir",), hover_s=4.0)
    shot, status = tmp_path / "replay.png", tmp_path / "status.json"
    argv = ["gui", "--replay", str(rec.path), "--headless", "--duration", "1.5"]
    argv += ["--screenshot", str(shot), "--window-size", "1366x768", "--theme", "daylight"]
    assert main([*argv, "--status-file", str(status)]) == 0
    assert json.loads(status.read_text())["view"]["theme"] == "daylight"
    img = QImage(str(shot))
    assert (img.width(), img.height()) == (1366, 768)
    # daylight: the window's panels light grey (the status bar's), not the dark theme's
    assert img.pixelColor(img.width() // 2, img.height() - 4).name() == "#eeeeee"


@pytest.mark.slow
def test_a_flir_sequence_replays_in_the_console_as_a_session(flir_files, tmp_path, capsys):
    """``snrmon gui --replay FILE.seq``: the real FLIR Duo Pro R sequence (7 frames 640x512)
    written as a session (every frame, bit for bit, at the file's own times) and played in the
    console: its one camera, named for the default LWIR sensor, plays to its 7th frame."""
    import json

    import numpy as np

    from snrmon.acquisition.record.reader import open_session
    from snrmon.acquisition.replay.stack_io import read_stack
    from snrmon.acquisition.replay.stack_session import session_from_stack

    seq = flir_files / "flirpy-test.seq"
    status = tmp_path / "status.json"
    argv = ["gui", "--replay", str(seq), "--headless", "--duration", "8", "--status-file"]
    assert main([*argv, str(status)]) == 0
    assert "replayed as camera 'lwir' with the lwir sensor model" in capsys.readouterr().err
    shown = json.loads(status.read_text())
    assert list(shown["cameras"]) == ["lwir"] and shown["cameras"]["lwir"]["shape"] == [512, 640]
    assert (shown["replay"]["length"], shown["replay"]["index"]) == (7, 6)
    # The session it played: the file's frames and times.
    stack = read_stack(seq)
    with open_session(
        session_from_stack(seq, tmp_path / "s.h5", sensor="lwir", camera="lwir")
    ) as f:
        cam = f.cameras["lwir"]
        assert np.array_equal(np.stack([cam.frame(k) for k in range(7)]), stack.frames)
        assert np.array_equal(cam.utc_ns, stack.utc.astype("datetime64[ns]").astype(np.int64))


def test_a_camera_file_that_does_not_say_its_camera_needs_a_sensor(tmp_path, capsys):
    import numpy as np

    stack = tmp_path / "frames.npy"
    np.save(stack, np.zeros((3, 8, 8), np.uint16))
    assert main(["gui", "--replay", str(stack), "--headless", "--duration", "1"]) == 2
    err = capsys.readouterr().err
    assert "give --sensor (mwir, lwir or a sensor TOML)" in err and str(stack) in err

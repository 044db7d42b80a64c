"""``snrmon gui``: a session TOML on a simulated shm camera runs headless and saves a screenshot;
a recording replays headless; a missing file or config is a one-line error."""

from __future__ import annotations

import os
import signal
import time
import uuid

from PySide6.QtCore import QTimer
from PySide6.QtGui import QImage

from snrmon.cli import main
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.acquisition.session_factory import write_session
from tests.gui.test_console import H, SpotOnNoise, W


def test_gui_command_headless_runs_the_config_and_saves_a_screenshot(qtbot, tmp_path):
    ring = f"snrmon-guicli-{uuid.uuid4().hex[:10]}"
    toml = tmp_path / "session.toml"
    toml.write_text(
        f'[cameras.mwir]\nsource = "shm"\naddress = "{ring}"\nwidth_px = {W}\nheight_px = {H}\n'
    )
    png = tmp_path / "gui.png"
    with ShmProducer(ring, W, H, SpotOnNoise(), fps=30.0):
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

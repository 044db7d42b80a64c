"""Shared fixtures. GUI tests run offscreen; every random generator is seeded by the test."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

REPO = Path(__file__).resolve().parent.parent
# The real data the tests read lives in the repository (tests/data, each folder with its
# provenance); SNRMON_TEST_DATA points at another copy of the same folders.
TEST_DATA = Path(os.environ.get("SNRMON_TEST_DATA", REPO / "tests" / "data"))


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``tests/data``: real data with provenance (never edited; a test that damages a file
    works on its own copy)."""
    if not TEST_DATA.is_dir():
        pytest.fail(f"test data not found at {TEST_DATA}")
    return TEST_DATA


HIL_SEEDS = (0, 1)


def _hil_record(path: Path, seed: int) -> Path:
    from snrmon.cli import main

    argv = ["hil", "--out", str(path), "--stops", "37,126", "--hover-s", "4", "--speed", "4"]
    argv += ["--camera", "lwir", "--seed", str(seed), "--json"]
    assert main(argv) == 0, f"snrmon hil --out {path} failed"
    return path


@pytest.fixture(scope="session")
def hil_sessions(tmp_path_factory) -> list[Path]:
    """Two small sessions recorded live by ``snrmon hil --out`` (short flights: two stops, 4 s
    hovers at four times real time, LWIR only: ~9 s each), built once for the campaign, GPS
    import and API tests."""
    folder = tmp_path_factory.mktemp("hil-sessions")
    return [_hil_record(folder / f"flight-{seed}.h5", seed) for seed in HIL_SEEDS]


@pytest.fixture(scope="session")
def xvfb_display():
    """A real X display (Xvfb, 1600x1000, 24 bit) for tests that open real windows; skipped,
    saying why, where Xvfb is not installed (.ci/run installs it)."""
    import select
    import shutil
    import subprocess

    if shutil.which("Xvfb") is None:
        pytest.skip("Xvfb not installed (apt-get install xvfb; .ci/run does)")
    read_fd, write_fd = os.pipe()
    proc = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write_fd), "-screen", "0", "1600x1000x24", "-nolisten", "tcp"],
        pass_fds=(write_fd,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(write_fd)
    try:
        # Xvfb writes the display number it chose once it accepts connections.
        ready, _, _ = select.select([read_fd], [], [], 30)
        number = os.read(read_fd, 64).decode().strip() if ready else ""
        if not number:
            pytest.fail("Xvfb did not report a display within 30 s")
        yield f":{number}"
    finally:
        os.close(read_fd)
        proc.terminate()
        proc.wait(10)

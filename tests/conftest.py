"""Shared fixtures. GUI tests run offscreen; every random generator is seeded by the test."""

from __future__ import annotations

import gc
import os
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

REPO = Path(__file__).resolve().parent.parent
# The real data the tests read lives in the repository (tests/data, each folder with its
# provenance); SNRMON_TEST_DATA points at another copy of the same folders.
TEST_DATA = Path(os.environ.get("SNRMON_TEST_DATA", REPO / "tests" / "data"))


def pytest_collection_modifyitems(config, items) -> None:
    """The files with the most slow tests first, each file whole and in its own order.

    ``make test`` hands whole files to two workers (pytest-xdist ``--dist loadfile``), taking
    them in the order collected (``--no-loadscope-reorder``); by default xdist orders files by
    their number of tests, which put the few-test, minute-long flights (``tests/test_hil*.py``,
    ``test_characterize_twin.py``) last, one worker finishing them while the other stood idle.
    Longest first is the classic remedy for that tail; the count of ``slow`` tests (each
    "more than a few seconds") is the estimate of a file's length."""
    slow: dict[Path, int] = {}
    for item in items:
        slow[item.path] = slow.get(item.path, 0) + bool(item.get_closest_marker("slow"))
    items.sort(key=lambda item: -slow[item.path])  # a stable sort: files stay whole


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``tests/data``: real data with provenance (never edited; a test that damages a file
    works on its own copy)."""
    if not TEST_DATA.is_dir():
        pytest.fail(f"test data not found at {TEST_DATA}")
    return TEST_DATA


@pytest.fixture(autouse=True)
def _collect_cycles_on_the_main_thread():
    """After each test, collect its reference cycles here, on the main thread. A Qt widget a
    test left in a cycle was otherwise destroyed by a later collection on whatever thread ran it:
    once a measurement thread of a later test's live session, whose PySide destructor then waited
    for the GIL while holding the thread (the test run hung; py-spy: QObject::~QObject on
    measure-mwir)."""
    yield
    gc.collect()


@pytest.fixture(scope="module")
def module_tmp(tmp_path_factory, request) -> Iterator[Callable[[str], Path]]:
    """``module_tmp(name)``: a new folder for files a module's tests share (a recording made
    once), removed when the module's last test is done unless one of them failed. pytest's own
    ``tmp_path_factory.mktemp`` folders stay until the whole run ends, so a run held every
    module's recordings at once (7.8 GB at its peak)."""
    made: list[Path] = []
    failed_before = request.session.testsfailed

    def mktemp(name: str) -> Path:
        made.append(tmp_path_factory.mktemp(name))
        return made[-1]

    yield mktemp
    if request.session.testsfailed == failed_before:
        for folder in made:
            shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="session")
def flir_files(shared_data, tmp_path_factory) -> Path:
    """A folder with the real FLIR files of ``tests/data/field-formats/flir`` as the camera
    wrote them: the ``.gz`` ones (kept gzipped in git, over 2 MB raw) decompressed under their
    own names, the others linked."""
    import gzip

    folder = tmp_path_factory.mktemp("flir")
    for path in (shared_data / "field-formats" / "flir").iterdir():
        if path.suffix == ".gz":
            (folder / path.stem).write_bytes(gzip.decompress(path.read_bytes()))
        else:
            (folder / path.name).symlink_to(path.resolve())
    return folder


HIL_SEEDS = (0, 1)


def _hil_record(path: Path, seed: int) -> Path:
    from snrmon.cli import main

    argv = ["hil", "--out", str(path), "--stops", "37,126", "--hover-s", "4", "--speed", "4"]
    # a 256x192 sub-array around the line of sight holds the drone at both stops: a ninth of
    # the full frame's bytes
    argv += ["--cameras", "lwir", "--seed", str(seed), "--size", "256x192", "--json"]
    assert main(argv) == 0, f"snrmon hil --out {path} failed"
    return path


@pytest.fixture(scope="session")
def hil_sessions(tmp_path_factory) -> list[Path]:
    """Two small sessions recorded live by ``snrmon hil --out`` (short flights: two stops, 4 s
    hovers at four times real time, LWIR only, a 256x192 sub-array: ~9 s each), built once for
    the campaign, GPS import and API tests."""
    folder = tmp_path_factory.mktemp("hil-sessions")
    return [_hil_record(folder / f"flight-{seed}.h5", seed) for seed in HIL_SEEDS]


class XvfbScreens:
    """Real X displays (Xvfb, 24 bit), one per screen size asked for, started on first use
    (:func:`snrmon.benchmarks.xvfb.start_xvfb`, as the real-window benchmark starts them) and
    stopped at the end of the test session."""

    def __init__(self) -> None:
        self._servers: list = []
        self._displays: dict[str, str] = {}

    def __call__(self, size: str = "1600x1000") -> str:
        """The display (":N") of an Xvfb screen ``size`` ("WxH") pixels large."""
        import shutil

        from snrmon.benchmarks.xvfb import XvfbError, start_xvfb

        if size in self._displays:
            return self._displays[size]
        if shutil.which("Xvfb") is None:
            pytest.skip("Xvfb not installed (apt-get install xvfb; .ci/run does)")
        try:
            server = start_xvfb(size)
        except XvfbError as exc:
            pytest.fail(str(exc))
        self._servers.append(server)
        self._displays[size] = server.display
        return server.display

    def close(self) -> None:
        for server in self._servers:
            server.stop()


@pytest.fixture(scope="session")
def xvfb_screens():
    """``xvfb_screens("1366x768") -> ":N"``: real X displays for tests that open real windows,
    one per size; skipped, saying why, where Xvfb is not installed (.ci/run installs it)."""
    screens = XvfbScreens()
    try:
        yield screens
    finally:
        screens.close()


@pytest.fixture(scope="session")
def xvfb_display(xvfb_screens):
    """A real X display (Xvfb, 1600x1000, 24 bit) for tests that open real windows."""
    return xvfb_screens("1600x1000")


ARTIFACTS = Path(os.environ.get("SNRMON_ARTIFACTS", REPO / "artifacts"))


@pytest.fixture(scope="session")
def artifacts() -> Path:
    """Where tests keep what a person should look at (screenshots): ``artifacts/`` in the
    checkout (git ignores it), or $SNRMON_ARTIFACTS."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    return ARTIFACTS

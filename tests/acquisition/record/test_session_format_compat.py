"""A session file opens in readers built on HDF5 1.10 (MATLAB's, Debian's h5dump), not only in the
h5py that wrote it: the writer bounds the file format at v110.

The independent reader is the distribution's ``h5dump``/``h5ls`` (hdf5-tools; Debian 12 ships
HDF5 1.10.8), installed by ``.ci/run``. A file written with ``libver="latest"`` by this h5py
(HDF5 2.x) is refused by that h5dump, which the first test shows, so the check can fail.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import h5py
import numpy as np
import pytest

from snrmon.acquisition.measure.peak_snr import PeakSnr
from snrmon.acquisition.record.recorder import SessionRecorder
from snrmon.acquisition.record.writer import LIBVER
from snrmon.drivers.camera.frame import Frame

H5DUMP = shutil.which("h5dump")
H5LS = shutil.which("h5ls")
needs_tools = pytest.mark.skipif(
    H5DUMP is None or H5LS is None,
    reason="h5dump/h5ls not installed (apt-get install hdf5-tools; .ci/run does)",
)
SHAPE = (6, 8)


def _h5dump_version() -> tuple[int, int]:
    out = subprocess.run([H5DUMP, "--version"], capture_output=True, text=True).stdout
    m = re.search(r"Version (\d+)\.(\d+)", out)
    assert m, out
    return int(m.group(1)), int(m.group(2))


@needs_tools
def test_the_independent_reader_is_hdf5_1_10_and_refuses_the_newest_format(tmp_path):
    if _h5dump_version() >= (1, 12):
        pytest.skip("this h5dump is newer than 1.10: it cannot tell the formats apart")
    path = tmp_path / "latest.h5"
    with h5py.File(path, "w", libver="latest") as f:
        d = f.create_dataset("x", (0, 4), np.uint16, chunks=(1, 4), maxshape=(None, 4))
        f.create_dataset("m", (0,), [("a", "<i8")], chunks=(64,), maxshape=(None,))
        f.swmr_mode = True
        d.resize((3, 4))
        d[:] = 7
    assert subprocess.run([H5DUMP, "-H", str(path)], capture_output=True).returncode != 0
    assert LIBVER == ("v110", "v110")


@needs_tools
def test_a_session_file_reads_in_hdf5_1_10(tmp_path):
    path = tmp_path / "s.h5"
    rng = np.random.default_rng(10)
    frames = rng.integers(900, 1100, (5, *SHAPE)).astype(np.uint16)
    rec = SessionRecorder(
        path, config={"session": {"target": "uav1"}}, cameras={"cam": SHAPE}, fsync=False
    )
    for i, px in enumerate(frames):
        rec.add_frame("cam", Frame(px, "cam", i, 10**9 + i * 16_666_667))
        t = 10**9 + i * 16_666_667
        result = PeakSnr(3, 2, 1200.0, 1000.0, 10.0, 20.0, frozenset())
        rec.add_measurement("cam", i, result, counter=i, t_host_ns=t)
    rec.add_state("cam", 0, 10**9, {"version": 1, "note": "state"})
    rec.add_reference("cam", np.zeros(SHAPE, np.float32), {"n_frames": 2}, t_host_ns=10**9)
    rec.add_event("note", payload={"text": "bird"})
    summary = rec.stop()
    assert summary.state == "stopped"

    listing = subprocess.run([H5LS, "-r", str(path)], capture_output=True, text=True)
    assert listing.returncode == 0, listing.stderr
    for name in (
        "/cameras/cam/frames",
        "/cameras/cam/measurements",
        "/cameras/cam/states",
        "/cameras/cam/references",
        "/events",
        "/gps",
        "/rangefinder",
    ):
        assert name in listing.stdout, name
    header = subprocess.run([H5DUMP, "-H", str(path)], capture_output=True, text=True)
    assert header.returncode == 0, header.stderr
    assert '"format_version"' in header.stdout
    # The pixels themselves, as HDF5 1.10 reads them, are the ones written.
    dump = subprocess.run(
        [H5DUMP, "-d", "/cameras/cam/frames[3,0,0;;1,1,8]", "-y", "-w", "0", str(path)],
        capture_output=True,
        text=True,
    )
    assert dump.returncode == 0, dump.stderr
    data = dump.stdout.split("DATA {", 1)[1].split("}", 1)[0]
    values = [int(v) for v in re.findall(r"\d+", data)]
    assert values == frames[3, 0].tolist()
    meas = subprocess.run(
        [H5DUMP, "-d", "/cameras/cam/measurements/snr", str(path)], capture_output=True, text=True
    )
    assert meas.returncode == 0, meas.stderr
    snr = meas.stdout.split("DATA {", 1)[1].split("}", 1)[0]
    assert re.findall(r"\): (.*)", snr) == ["20, 20, 20, 20, 20"]  # every frame's SNR, a column


@needs_tools
def test_compressed_frames_read_in_h5dump_with_the_plugin_path(tmp_path):
    """The default filter (bitshuffle-lz4) through HDF5 1.10's own h5dump: with
    ``HDF5_PLUGIN_PATH`` at hdf5plugin's plugins the pixels are the ones written; without it
    h5dump cannot read them (so the check can fail), as docs/session-format.md says."""
    import os

    import hdf5plugin

    path = tmp_path / "c.h5"
    frames = np.random.default_rng(11).integers(900, 1100, (4, *SHAPE)).astype(np.uint16)
    rec = SessionRecorder(
        path, config={}, cameras={"cam": SHAPE}, fsync=False, compression="bitshuffle-lz4"
    )
    for i, px in enumerate(frames):
        rec.add_frame("cam", Frame(px, "cam", i, 10**9 + i * 16_666_667))
    assert rec.stop().state == "stopped"
    argv = [H5DUMP, "-d", "/cameras/cam/frames[2,0,0;;1,1,8]", "-y", "-w", "0", str(path)]
    env = {k: v for k, v in os.environ.items() if k != "HDF5_PLUGIN_PATH"}
    dump = subprocess.run(
        argv,
        capture_output=True,
        text=True,
        env={**env, "HDF5_PLUGIN_PATH": hdf5plugin.PLUGIN_PATH},
    )
    assert dump.returncode == 0, dump.stderr
    data = dump.stdout.split("DATA {", 1)[1].split("}", 1)[0]
    assert [int(v) for v in re.findall(r"\d+", data)] == frames[2, 0].tolist()
    plain = subprocess.run(
        argv, capture_output=True, text=True, env={**env, "HDF5_PLUGIN_PATH": str(tmp_path)}
    )
    unread = plain.stdout.split("DATA {", 1)[-1].split("}", 1)[0]
    assert plain.returncode != 0 or not re.findall(r"\d+", unread)  # no pixels without it

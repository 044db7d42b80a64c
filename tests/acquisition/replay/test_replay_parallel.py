"""A fast replay of several cameras plays each in a process of its own (acquisition/replay/
forked.py) and gives what one process gives: every frame's measurement, the stop table, the
tallies. A child's failure reaches the caller as the child's own exception."""

from __future__ import annotations

import os
import signal

import h5py
import numpy as np
import pytest

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.engine.session_engine import SessionEngine
from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.record.recorder import SessionRecorder
from snrmon.acquisition.replay import batch
from snrmon.acquisition.replay.batch import replay_session
from snrmon.acquisition.replay.forked import Forked, can_fork
from snrmon.acquisition.runtime.camera_pipeline import CameraPipeline
from snrmon.acquisition.streams.ring import RingFrame
from tests.acquisition.replay.test_replay_gaps import DT, T0, H, W, _frame, _NoDevice
from tests.acquisition.session_factory import write_session
from tests.helpers import replay_frames_text, replay_rows_text

pytestmark = pytest.mark.skipif(not can_fork(), reason="needs fork and two cores")


def test_each_camera_in_its_own_process_gives_what_one_process_gives(tmp_path, monkeypatch):
    made = write_session(tmp_path / "s.h5", hover_s=3.0)
    children = []

    class Counted(Forked):
        def __init__(self, fn) -> None:
            super().__init__(fn)
            children.append(self.pid)

    monkeypatch.setattr(batch, "Forked", Counted)
    monkeypatch.setattr(batch, "idle_core", lambda: True)  # however busy the machine is now
    together = replay_session(made.path, fast=True, parallel=False)
    assert children == []
    apart = replay_session(made.path, fast=True)
    assert len(children) == 1 and children[0] != os.getpid()  # the second camera's child
    names = list(together.cameras)
    assert sorted(names) == ["lwir", "mwir"] and list(apart.cameras) == names
    for name in made.cameras:
        a, t = apart.cameras[name].tally, together.cameras[name].tally
        assert t.measured == a.measured == len(made.frame_t_ns)
        assert replay_frames_text(apart, name) == replay_frames_text(together, name), name
    # Two stops detected from the recorded readings in each process, one row per camera each,
    # in the table's order (stop, then camera).
    assert [(r.stop, r.camera) for r in apart.stops] == [(s, c) for s in (0, 1) for c in names]
    assert replay_rows_text(apart) == replay_rows_text(together)
    # Paced replays and a model (shared by the cameras) stay in one process.
    replay_session(made.path, fast=True, cameras=["mwir"])
    replay_session(made.path, fast=True, speed=1000.0)
    assert len(children) == 1


def _two_cameras_with_references(path) -> list:
    """A live run of two cameras (the same engine, one recorder) that click at frame 5 and
    capture a background reference at frame 10 each: the recording holds their reference
    images and the engine states (format 2). Returns every live measurement."""
    names = ("a", "b")
    config = session_config_from_dict(
        {
            "cameras": {
                n: {"source": "shm", "address": "none", "width_px": W, "height_px": H}
                for n in names
            }
        }
    )
    engine = SessionEngine(config, dict.fromkeys(names, (H, W)))
    pipes = {n: CameraPipeline(n, _NoDevice(), engine) for n in names}
    rec = SessionRecorder(
        path,
        config={"session": config.raw, "track": True},
        cameras=dict.fromkeys(names, (H, W)),
        fsync=False,
    )
    for pipe in pipes.values():
        pipe.attach_recorder(rec)
    live: list = []
    engine.add_listener(lambda m, pixels: live.append(m))
    for k, (name, pipe) in enumerate(pipes.items()):
        rng = np.random.default_rng(40 + k)
        fpn = np.random.default_rng(50 + k).normal(0.0, 8.0, (H, W))
        for i in range(60):
            if i == 5:
                pipe.set_roi(40, 30)
            if i == 10:
                pipe.capture_reference(6)
            pipe._process(RingFrame(_frame(i, rng, fpn), i, i, T0 + i * DT, None, name))
    rec.stop()
    return live


def _refuse(*args, **kwargs):
    raise AssertionError("the forked child read through HDF5")


def test_the_child_reads_nothing_through_hdf5(tmp_path, monkeypatch):
    """The child plays a camera whose background reference is an image in the file: it was
    read before the fork, and its frames come from the memory map."""
    path = tmp_path / "two.h5"
    live = _two_cameras_with_references(path)
    with open_session(path) as f:
        assert all(f.cameras[n].references.shape[0] == 1 for n in ("a", "b"))

    class NoHdf5InTheChild(Forked):
        def __init__(self, fn) -> None:
            def guarded():
                for name in ("__getitem__", "__len__"):
                    setattr(h5py.Dataset, name, _refuse)
                for name in ("shape", "dtype", "chunks"):
                    setattr(h5py.Dataset, name, property(_refuse))
                return fn()

            super().__init__(guarded)

    monkeypatch.setattr(batch, "Forked", NoHdf5InTheChild)
    monkeypatch.setattr(batch, "idle_core", lambda: True)
    apart = replay_session(path, fast=True)
    together = replay_session(path, fast=True, parallel=False)
    assert apart.processes == 2 and together.processes == 1
    for name in ("a", "b"):
        t = apart.cameras[name].tally
        assert t.compared == sum(m.camera == name for m in live) > 0
        assert t.identical == t.compared, (name, t.first_difference)
        assert replay_frames_text(apart, name) == replay_frames_text(together, name), name


def test_the_childs_exception_is_raised_in_the_parent():
    def fails() -> int:
        raise ValueError("mwir.h5: frame 3 unreadable")

    child = Forked(fails)
    with pytest.raises(ValueError, match="frame 3 unreadable") as err:
        child.result()
    assert any("Traceback" in note for note in err.value.__notes__)
    assert Forked(lambda: {"frames": [1, 2]}).result() == {"frames": [1, 2]}


def test_a_child_that_dies_is_a_runtime_error_naming_how():
    child = Forked(lambda: os.kill(os.getpid(), signal.SIGKILL))
    with pytest.raises(RuntimeError, match=f"killed by signal {int(signal.SIGKILL)}"):
        child.result()

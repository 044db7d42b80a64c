"""The console's replay shows what the live console showed: the same per-frame analysis.

A recording written with the real recorder holds a sky with fixed-pattern noise, a background
reference captured over its first 32 frames, the operator's click, a drone from frame 40 on and
GPS fixes from a pointed camera. Played through :class:`ReplayPlayer`, its status must equal
what :class:`CameraEngine` (the live pipeline's engine) gives on the same frames and commands:
the corrected and raw running SNR, the fixed-pattern figure, the section 6 noise; the GPS fix
and its projection into the camera must be the recorded fix's.
"""

from __future__ import annotations

import math

import numpy as np
import pymap3d
import pytest

from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.engine.inputs import FrameOutput, SetRoi, StartReference
from snrmon.acquisition.geo.projection import CameraIntrinsics, Pointing, Site, project_to_pixel
from snrmon.acquisition.measure.peak_snr import PeakSnrConfig
from snrmon.acquisition.record.recorder import SessionRecorder
from snrmon.acquisition.replay.feeder import Feeder
from snrmon.acquisition.replay.player import ReplayPlayer
from snrmon.acquisition.streams.ring import RingFrame
from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.gps.fix import GpsFix
from snrmon.model.presets import load_sensor

SHAPE = (48, 64)
N, REF_FRAMES, DRONE_FROM = 100, 32, 40
SPOT = (30, 22)
T0_NS, DT_NS = 10**12, 16_666_667
SITE = {"lat_deg": 32.38, "lon_deg": -106.48, "alt_m": 1200.0}
POINTING = (2.0, 1.0, 0.0)  # az, el, roll (deg): the drone due north, a little off the axis
FPN_DN, NOISE_DN = 12.0, 5.0


def _frames(seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    fpn = rng.normal(0.0, FPN_DN, SHAPE)
    yy, xx = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]]
    spot = 90.0 * np.exp(-((xx - SPOT[0]) ** 2 + (yy - SPOT[1]) ** 2) / (2 * 0.8**2))
    stack = 1000.0 + fpn + rng.normal(0.0, NOISE_DN, (N, *SHAPE))
    stack[DRONE_FROM:] += spot
    return np.rint(stack).astype(np.uint16)


def _fix(k: int) -> GpsFix:
    lat, lon, alt = pymap3d.enu2geodetic(0.0, 150.0 + 0.5 * k, 3.0, *SITE.values())
    return GpsFix(
        T0_NS + k * 100_000_000 + 5,
        None,
        float(lat),
        float(lon),
        float(alt),
        None,
        1,
        11,
        0.7,
        f"$GPGGA,{k}",
    )


@pytest.fixture(scope="module")
def recording(module_tmp):
    path = module_tmp("replay_player") / "session.h5"
    frames = _frames()
    config = {
        "session": {
            "site": SITE,
            "cameras": {
                "mwir": {"source": "shm", "sensor": "mwir", "pointing_deg": list(POINTING)}
            },
        },
        "track": True,
    }
    rec = SessionRecorder(path, config=config, cameras={"mwir": SHAPE}, fsync=False)
    t = [T0_NS + i * DT_NS for i in range(N)]
    # What the live pipeline records: the reference when its last frame arrives, the click at
    # the frame it took effect on.
    rec.add_event(
        "background_reference",
        camera="mwir",
        t_host_ns=t[REF_FRAMES - 1],
        payload={"n_frames": REF_FRAMES, "first_counter": 0, "last_counter": REF_FRAMES - 1},
    )
    rec.add_event(
        "roi_set",
        camera="mwir",
        t_host_ns=t[DRONE_FROM],
        payload={"x": SPOT[0] + 1, "y": SPOT[1], "counter": DRONE_FROM},
    )
    for i in range(N):
        rec.add_frame("mwir", Frame(frames[i], "mwir", i, t[i]))
    for k in range(17):
        rec.add_gps(_fix(k))
    rec.stop()
    return path, frames, t


def _live(frames: np.ndarray, t: list[int]) -> tuple[CameraEngine, FrameOutput]:
    """The live pipeline's engine on the same frames with the same commands."""
    a = CameraEngine("mwir", SHAPE, PeakSnrConfig())
    a.post(StartReference(REF_FRAMES))
    for i in range(N):
        if i == DRONE_FROM:
            a.post(SetRoi(SPOT[0] + 1, SPOT[1]))
        out = a.process(RingFrame(frames[i], i, i, t[i], None, a.name))
    return a, out


def test_replay_status_is_the_live_analysis(recording):
    path, frames, t = recording
    live, last = _live(frames, t)
    with ReplayPlayer(path) as player:
        player.step(player.position().length)
        assert player.wait_idle(30.0)
        st = player.status()
    cs = st.cameras["mwir"]
    m = last.measurement
    assert cs.last.snr_n == m.snr_n == N - DRONE_FROM
    assert cs.last.result == m.result
    assert (cs.last.snr_mean, cs.last.snr_std) == (m.snr_mean, m.snr_std)
    assert cs.last.raw is not None and m.raw is not None
    assert (cs.last.raw.mean, cs.last.raw.std) == (m.raw.mean, m.raw.std)
    # The reference removes the fixed pattern: the raw track reads lower, as live.
    assert cs.last.raw.mean < 0.7 * cs.last.snr_mean
    fig = live.figures()
    assert cs.figures.reference_frames == REF_FRAMES
    assert cs.figures.fixed_pattern_dn == fig.fixed_pattern_dn == pytest.approx(FPN_DN, rel=0.1)
    assert (
        cs.figures.noise_total_dn,
        cs.figures.noise_temporal_dn,
        cs.figures.noise_spatial_dn,
    ) == (
        fig.noise_total_dn,
        fig.noise_temporal_dn,
        fig.noise_spatial_dn,
    )
    assert cs.figures.noise_temporal_dn == pytest.approx(NOISE_DN, rel=0.15)
    assert cs.figures.noise_spatial_dn == pytest.approx(FPN_DN, rel=0.2)


def test_replay_shows_the_recorded_gps_fix_and_its_projection(recording):
    path = recording[0]
    with ReplayPlayer(path) as player:
        player.seek(60)  # frame 60 at 1.0 s: the fix of k = 10 is the newest
        assert player.wait_idle(30.0)
        st = player.status()
    fix = st.gps_fix
    assert fix == _fix(10)
    want = project_to_pixel(
        Site(**SITE),
        Pointing(*POINTING),
        CameraIntrinsics.from_sensor(load_sensor("mwir")),
        fix.lat_deg,
        fix.lon_deg,
        fix.alt_msl_m,
    )
    assert want.in_view
    assert st.cameras["mwir"].gps_xy == (want.x, want.y)
    assert st.gps_range_m == pytest.approx(math.hypot(155.0, 3.0), abs=0.05)


def test_the_replay_builds_the_model_its_config_names_and_the_one_asked_for(recording):
    """The player builds the recorded config's model (its sensors and target), and the model an
    analyst asks for (ModelRequest): the stop table's predictor and the reference at the
    request's own background, which a seek (a new engine) keeps."""
    from snrmon.acquisition.prediction import ModelRequest

    path = recording[0]
    with ReplayPlayer(path, model_from_config=True) as player:
        first = player.predictor
        assert first is not None and first.target.name == "uav1"  # the recorded default target
        assert player.reference_predictor is None  # nobody asked for one
        player.set_model(ModelRequest("uav2", background_temp_k=280.0))
        sky, reference = player.predictor, player.reference_predictor
        assert sky is not first and reference is not None and reference is not sky
        assert player.stop_table.predictor is sky
        assert sky.target.name == reference.target.name == "uav2"
        assert sky.background_temp_k["mwir"] == reference.background_temp_k["mwir"] == 280.0
        with pytest.raises(ValueError, match="uav9"):
            player.set_model(ModelRequest("uav9"))  # refused: the model stays
        assert (player.predictor, player.reference_predictor) == (sky, reference)
        player.seek(60)
        assert player.wait_idle(30.0)
        assert player.stop_table.predictor is sky and player.reference_predictor is reference


def test_a_seek_prepares_its_fresh_engine_before_the_console_reads_it(recording, monkeypatch):
    """While a seek applies the recorded readings up to its frame (the replay worker's thread),
    a status read on another thread is the one before the seek, never a half-prepared one."""
    path = recording[0]
    seen: list[float | None] = []
    original = Feeder.skip_to
    with ReplayPlayer(path) as player:
        player.seek(60)
        assert player.wait_idle(30.0)
        before = player.status().gps_range_m
        assert before is not None

        def skip_to(feeder, k):
            seen.append(player.status().gps_range_m)  # as the console's timer would read it
            original(feeder, k)

        monkeypatch.setattr(Feeder, "skip_to", skip_to)
        player.seek(30)
        assert player.wait_idle(30.0)
        after = player.status().gps_range_m
    assert seen == [before]
    assert after is not None

"""Target characterization (paper section 3) on a simulated resolved drone at 37 m, directly
and through ``snrmon characterize`` on a recorded session.

The drone is a cross of two bars (0.30 m x 0.10 m) at 36.7 C with thin 2 cm "blades" at the
bar ends, against a 260 K sky (tests/acquisition/calibration_scene.py: built from sim's pieces
because sim's resolved drone is ONE pixel-aligned square of set contrast electrons, for which
sqrt(area) == sqrt(box area), so small and large could not be told apart). Truth: small =
sqrt(area) = 0.2236 m, large = sqrt(box) = 0.30 m. The cross is aligned with the pixel axes, so
the upright bounding box is the true box; a rotated drone needs ``box="rotated"``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib

import numpy as np
import pytest

from snrmon.acquisition.calibrate.calibration import (
    BlackbodyCapture,
    calibrate_sensor,
    radiance_of,
    temperature_of,
)
from snrmon.acquisition.calibrate.calibration_file import save_calibration
from snrmon.acquisition.calibrate.characterize import (
    AirPath,
    CharacterizeConfig,
    at_rest_frames,
    characterize_frame,
    characterize_frames,
    summarise_frames,
    target_toml,
    unmeasurable,
)
from snrmon.acquisition.record.recorder import SessionRecorder
from snrmon.cli import main
from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.rangefinder.reading import RangeReading
from snrmon.model.presets import load_target
from snrmon.model.psf import AiryGaussianPsf
from tests.acquisition.calibration_scene import camera, cross_drone, rect_electrons
from tests.helpers import strict_json

SKY_K, DRONE_K, RANGE_M = 260.0, 309.85, 37.0
SPAN_M, ARM_M = 0.30, 0.10
XC, YC = 64, 48


@pytest.fixture(scope="module")
def cam():
    return camera("mwir", shape=(96, 128), seed=21)


@pytest.fixture(scope="module")
def cal(cam):
    caps = [BlackbodyCapture(t, cam.blackbody(t, 24, seed=i)) for i, t in enumerate((283.0, 318.0))]
    return calibrate_sensor(caps, cam.sensor)


def drone_scene(cam, range_m=RANGE_M, dx=0.3, dy=0.6, blades=True):
    e, area, box = cross_drone(
        cam,
        range_m=range_m,
        xc=XC + dx,
        yc=YC + dy,
        span_m=SPAN_M,
        arm_m=ARM_M,
        temp_k=DRONE_K,
        sky_temp_k=SKY_K,
    )
    if blades:  # 2 cm x 12 cm blades beyond each end of the horizontal bar, as warm as the body
        px = range_m * cam.sensor.ifov_rad
        de = cam.electrons(DRONE_K) - cam.electrons(SKY_K)
        half = SPAN_M / 2 / px
        rects = [
            (XC + dx + s * (half + 0.07 / px), YC + dy, 0.12 / px, 0.02 / px, de) for s in (-1, 1)
        ]
        e = e + rect_electrons(cam.shape, rects, cam.config.psf_sigma_px, cam.sensor.fill_factor)
    return e, math.sqrt(area), math.sqrt(box)


def test_recovers_dimensions_within_10pct_and_temperature_within_half_a_kelvin(cam, cal):
    e, small, large = drone_scene(cam)
    frames = cam.frames(e, 30, seed=5)
    res = characterize_frames(
        ((f, (XC, YC)) for f in frames),
        camera="mwir",
        range_m=RANGE_M,
        ifov_rad=cam.sensor.ifov_rad,
        calibration=cal,
    )
    assert res.n_frames == 30
    assert res.size.small_m == pytest.approx(small, rel=0.10)
    assert res.size.large_m == pytest.approx(large, rel=0.10)
    assert res.temperature.mean_temp_c == pytest.approx(DRONE_K - 273.15, abs=0.5)
    assert res.temperature.background_temp_c == pytest.approx(SKY_K - 273.15, abs=0.1)
    assert res.temperature.rss_delta_t_k == pytest.approx(DRONE_K - SKY_K, abs=0.5)
    assert 0 < res.size.small_m_std < 0.02 * res.size.small_m


def test_thin_arms_read_on_the_core_where_the_outline_mean_reads_low(cam, cal):
    # The twin's drone at 37 m: arms 6 cm (3.2 px) thick. Every pixel of the eroded outline
    # mixes sky in through the pixel and the PSF, so its mean reads low; the core (the pixels
    # farthest from the outline's edge, at the crossing) reads the drone. The PSF: the
    # paper's MWIR fit, a Gaussian of 0.8 px.
    blurred = dataclasses.replace(cam, config=dataclasses.replace(cam.config, psf_sigma_px=0.8))
    e, _, _ = cross_drone(
        blurred,
        range_m=RANGE_M,
        xc=XC + 0.3,
        yc=YC + 0.6,
        span_m=0.24,
        arm_m=0.06,
        temp_k=DRONE_K,
        sky_temp_k=SKY_K,
    )
    res = characterize_frames(
        ((f, (XC, YC)) for f in cam.frames(e, 20, seed=8)),
        camera="mwir",
        range_m=RANGE_M,
        ifov_rad=cam.sensor.ifov_rad,
        calibration=cal,
    )
    assert res.temperature.mean_temp_c == pytest.approx(DRONE_K - 273.15, abs=0.5)
    assert res.core.outline_temp_c < DRONE_K - 273.15 - 1.5  # the mean a thick drone would read
    assert 1 <= res.core.core_pixels < 10


def test_the_cameras_psf_restores_the_cores_contrast(cam, cal):
    """The twin's UAV1 at 37 m through the twin's own optics (Airy x 0.57 px): its bars are 3.2
    px thick, so even the core (the crossing) loses light to the Airy's wings and reads over a
    kelvin low; given the camera's PSF (the Airy blurred as the flight's fit finds it) the core's
    contrast is divided by the share the outline keeps there, and reads the drone."""
    from snrmon.sim.optics import TwinSpread, twin_optics
    from snrmon.sim.silhouette import silhouette_for

    uav1 = load_target("uav1")
    sensor = cam.sensor
    spread = TwinSpread(twin_optics(sensor, DRONE_K, SKY_K, 0.57), silhouette_for(uav1), 0.157)
    size_px = uav1.small_m / (RANGE_M * sensor.ifov_rad)
    pattern = spread.fractions(0.3, -0.2, size_px)
    h = pattern.shape[0] // 2
    pixel_filling = cam.electrons(DRONE_K) - cam.electrons(SKY_K)
    e = np.full(cam.shape, cam.electrons(SKY_K))
    e[YC - h : YC + h + 1, XC - h : XC + h + 1] += pixel_filling * size_px**2 / 0.8 * pattern
    frames = cam.frames(e, 12, seed=9)
    kw = {"range_m": RANGE_M, "ifov_rad": sensor.ifov_rad, "calibration": cal}
    psf = AiryGaussianPsf(sensor.diffraction_psf(), 0.59)
    rows = [
        characterize_frame(f, (XC, YC), psf=psf, fill_factor=sensor.fill_factor, **kw)
        for f in frames
    ]
    res = summarise_frames(rows, camera="mwir", range_m=RANGE_M, method="otsu")
    t_c = DRONE_K - 273.15
    assert res.core.core_seen_temp_c < t_c - 1.0
    assert 0.9 < res.core.core_psf_share < 0.96
    assert res.temperature.mean_temp_c == pytest.approx(t_c, abs=0.5)
    # characterize --json: one flat object, the same keys in the same order as ever
    out = res.as_dict()
    assert list(out) == [
        "camera",
        "range_m",
        "n_frames",
        "small_m",
        "small_m_std",
        "large_m",
        "large_m_std",
        "mean_temp_c",
        "mean_temp_c_std",
        "background_temp_c",
        "background_temp_c_std",
        "rss_delta_t_k",
        "rss_delta_t_k_std",
        "method",
        "outline_temp_c",
        "core_pixels",
        "core_seen_temp_c",
        "core_psf_share",
        "apparent_temp_c",
        "temperature_convention",
    ]
    assert out["core_psf_share"] == res.core.core_psf_share
    assert out["small_m_std"] == res.size.small_m_std


def test_blades_are_removed_by_the_opening_and_kept_without_it(cam, cal):
    e, _, large = drone_scene(cam)
    frame = cam.frames(e, 1, seed=9)[0]
    kw = dict(range_m=RANGE_M, ifov_rad=cam.sensor.ifov_rad, calibration=cal)
    opened = characterize_frame(frame, (XC, YC), **kw)
    raw = characterize_frame(frame, (XC, YC), config=CharacterizeConfig(open_px=1), **kw)
    assert opened.large_m == pytest.approx(large, rel=0.05)
    assert raw.large_m > 1.3 * large  # the blades widen the box when not opened away


def test_rss_delta_t_includes_the_target_spread(cam, cal):
    # a hot hub (20 K above the body) in the middle of the cross: sigma_target > 0
    e, _, _ = drone_scene(cam, blades=False)
    px = RANGE_M * cam.sensor.ifov_rad
    de = cam.electrons(DRONE_K + 20.0) - cam.electrons(DRONE_K)
    e = e + rect_electrons(
        cam.shape,
        [(XC + 0.3, YC + 0.6, 0.08 / px, 0.08 / px, de)],
        cam.config.psf_sigma_px,
        cam.sensor.fill_factor,
    )
    r = characterize_frame(
        cam.frames(e, 1, seed=3)[0],
        (XC, YC),
        range_m=RANGE_M,
        ifov_rad=cam.sensor.ifov_rad,
        calibration=cal,
    )
    assert r.sigma_target_k > 5.0
    assert r.rss_delta_t_k == pytest.approx(math.hypot(r.temp_k - r.background_k, r.sigma_target_k))
    assert r.rss_delta_t_k > r.temp_k - r.background_k + 0.3


def _cross(camera, range_m: float, temp_k: float) -> np.ndarray:
    """The cross without blades at ``temp_k`` against the sky, off the pixel grid (electrons)."""
    e, _, _ = cross_drone(
        camera,
        range_m=range_m,
        xc=XC + 0.3,
        yc=YC + 0.6,
        span_m=SPAN_M,
        arm_m=ARM_M,
        temp_k=temp_k,
        sky_temp_k=SKY_K,
    )
    return e


def test_what_it_cannot_measure_it_refuses_with_the_numbers(cam, cal):
    """At least 25 frames and 7 px per dimension (twice the 3-px opening, plus one). The cross
    at 37 m (12 x 16 px) holds; 10 frames of it do not; at 80 m the opening has eaten its
    2.5-px arms (large 6.3 px, 16 % low) and in the LWIR at 37 m (2.7-px arms) too."""

    def summary(camera, range_m, n):
        e = _cross(camera, range_m, DRONE_K)
        res = characterize_frames(
            ((f, (XC, YC)) for f in camera.frames(e, n, seed=5)),
            camera=camera.sensor.name,
            range_m=range_m,
            ifov_rad=camera.sensor.ifov_rad,
        )
        return res, range_m * camera.sensor.ifov_rad

    res, px = summary(cam, RANGE_M, 30)
    assert unmeasurable(res, pixel_m=px) is None
    res, px = summary(cam, RANGE_M, 10)
    assert unmeasurable(res, pixel_m=px).endswith(
        "cannot be characterised: 10 frames at rest (need >= 25)"
    )
    res, px = summary(cam, 80.0, 30)
    why = unmeasurable(res, pixel_m=px)
    assert why is not None and "(need >= 7 px each" in why and "frames" not in why
    assert res.size.large_m / px < 7
    lwir = camera("lwir", shape=(96, 128), seed=21)
    res, px = summary(lwir, RANGE_M, 30)
    why = unmeasurable(res, pixel_m=px)
    assert why is not None and why.startswith("lwir at 37.0 m cannot be characterised: small ")
    assert unmeasurable(res, pixel_m=px, min_size_px=5.0) is None  # a looser limit given


def test_through_the_air_the_drone_is_corrected_and_the_sky_read_as_seen(cam, cal):
    """A drone at 36.7 C rendered as the camera sees it through air of transmission 0.83 at
    15 C (the MWIR at 37 m): with the path its temperature, spread and RSS delta-T are its
    own, against the sky as seen; without it every one is apparent, some 3 K lower."""
    band = cal.band_um
    path = AirPath(0.83, 288.15)
    seen_k = float(
        temperature_of(band, path.apparent_radiance(radiance_of(band, DRONE_K), band), ())
    )
    assert DRONE_K - seen_k > 2.5
    frames = cam.frames(_cross(cam, RANGE_M, seen_k), 8, seed=9)
    kw = dict(range_m=RANGE_M, ifov_rad=cam.sensor.ifov_rad, calibration=cal)
    own = summarise_frames(
        [characterize_frame(f, (XC, YC), path=path, **kw) for f in frames],
        camera="mwir",
        range_m=RANGE_M,
        method="otsu",
        convention="path_corrected",
    )
    app = summarise_frames(
        [characterize_frame(f, (XC, YC), **kw) for f in frames],
        camera="mwir",
        range_m=RANGE_M,
        method="otsu",
    )
    assert (
        own.temperature_convention == "path_corrected" and app.temperature_convention == "apparent"
    )
    assert own.temperature.mean_temp_c == pytest.approx(DRONE_K - 273.15, abs=0.5)
    assert own.core.apparent_temp_c == pytest.approx(app.temperature.mean_temp_c, abs=1e-3)
    assert own.temperature.background_temp_c == pytest.approx(
        app.temperature.background_temp_c, abs=1e-6
    )  # as seen
    assert own.temperature.background_temp_c == pytest.approx(SKY_K - 273.15, abs=0.1)
    assert own.temperature.rss_delta_t_k == pytest.approx(DRONE_K - SKY_K, rel=0.02)
    assert app.temperature.rss_delta_t_k == pytest.approx(seen_k - SKY_K, rel=0.02)
    with pytest.raises(ValueError, match="convention"):
        summarise_frames([], camera="mwir", range_m=1.0, method="otsu", convention="own")


def test_target_toml_is_read_by_the_model(cam, cal, tmp_path):
    e, _, _ = drone_scene(cam)
    res = characterize_frames(
        ((f, (XC, YC)) for f in cam.frames(e, 5, seed=1)),
        camera="mwir",
        range_m=RANGE_M,
        ifov_rad=cam.sensor.ifov_rad,
        calibration=cal,
    )
    path = tmp_path / "uav_today.toml"
    path.write_text(target_toml(res, "uav_today"))
    t = load_target(str(path))
    assert t.small_m == pytest.approx(res.size.small_m, abs=1e-4)
    assert t.temp_k("mwir") == pytest.approx(res.temperature.mean_temp_c + 273.15, abs=1e-3)
    with pytest.raises(ValueError, match="no temperature for band 'lwir'"):
        t.temp_k("lwir")


@pytest.fixture
def three_frames(cam, cal):
    """The drone characterized from three calibrated frames."""
    e, _, _ = drone_scene(cam)
    return characterize_frames(
        ((f, (XC, YC)) for f in cam.frames(e, 3, seed=1)),
        camera="mwir",
        range_m=RANGE_M,
        ifov_rad=cam.sensor.ifov_rad,
        calibration=cal,
    )


@pytest.mark.parametrize("name", ["Bob's quad", 'the "big" one', "back\\slash\ttab", "Ωmega"])
def test_target_toml_quotes_any_name(three_frames, tmp_path, name):
    """The file is TOML whatever the name holds (it was written with json-ish quoting)."""
    path = tmp_path / "t.toml"
    text = target_toml(three_frames, name, description=f"{name} at 10 m")
    path.write_text(text, encoding="utf-8")
    assert tomllib.loads(path.read_text(encoding="utf-8"))["target"]["name"] == name
    assert load_target(str(path)).name == name


def test_target_toml_refuses_values_toml_cannot_hold(three_frames):
    nan = dataclasses.replace(three_frames.temperature, rss_delta_t_k=float("nan"))
    bad = dataclasses.replace(three_frames, temperature=nan)
    with pytest.raises(ValueError, match="not measured: rss_delta_t_k"):
        target_toml(bad, "x")


def test_bad_inputs_are_one_clear_error(cam, cal):
    frame = cam.frames(cam.electrons(SKY_K), 1, seed=2)[0]
    with pytest.raises(ValueError, match=r"ROI of \+-32 px around \(5, 5\) leaves the 128x96"):
        characterize_frame(frame, (5, 5), range_m=RANGE_M, ifov_rad=1e-3)
    with pytest.raises(ValueError, match="no target segmented in any frame of 'mwir'"):
        characterize_frames([(frame, (XC, YC))], camera="mwir", range_m=37.0, ifov_rad=5e-4)
    with pytest.raises(ValueError, match="calibration is for camera 'mwir', not 'lwir'"):
        characterize_frames([], camera="lwir", range_m=37.0, ifov_rad=5e-4, calibration=cal)
    with pytest.raises(ValueError, match="segmentation method must be one of"):
        CharacterizeConfig(method="watershed")


def _record(cam, path, fps=20.0):
    plan = [(0.0, 6.0, RANGE_M), (9.0, 12.0, 60.0)]
    t_end = 12.0
    rec = SessionRecorder(
        path,
        config={"session": {"cameras": {"mwir": {"source": "shm", "sensor": "mwir"}}}},
        cameras={"mwir": cam.shape},
        flush_interval_s=0.2,
        fsync=False,
    )
    t0 = 10**12
    knots_t = [p for a, b, _ in plan for p in (a, b)]
    knots_r = [r for _, _, r in plan for r in (r, r)]
    # The click is 44 px off the drone (the HIL clicks its GPS position): the track finds it.
    rec.add_event("roi_set", camera="mwir", payload={"x": XC - 44, "y": YC}, t_host_ns=t0)
    rng = np.random.default_rng(4)
    for i in range(int(t_end * fps)):
        t = i / fps
        r = float(np.interp(t, knots_t, knots_r))
        e, _, _ = drone_scene(cam, range_m=r, dx=0.3 + 0.2 * math.sin(t), dy=0.6)
        frame = cam.frames(e, 1, seed=1000 + i)[0]
        rec.add_frame("mwir", Frame(frame, "mwir", i, t0 + int(t * 1e9)))
    for t in np.arange(0.0, t_end, 0.5):
        r = float(np.interp(t, knots_t, knots_r)) + rng.normal(0, 0.1)
        rec.add_range(RangeReading(t0 + int(t * 1e9), r, raw=f"{r:.1f}"))
    rec.stop()


def test_snrmon_characterize_on_a_recorded_close_stop(cam, cal, tmp_path, capsys):
    session = tmp_path / "s.h5"
    _record(cam, session)
    cal_path = save_calibration(cal, tmp_path / "mwir.npz")
    target = tmp_path / "t.toml"
    # this scene's drone has no air in front of it: its apparent temperature is its own
    argv = [
        "characterize",
        str(session),
        "--camera",
        "mwir",
        "--calibration",
        str(cal_path),
        "--json",
        "--target-out",
        str(target),
        "--apparent",
    ]
    rc = main([*argv, "--stop", "99"])
    assert rc != 0
    assert "no stop 99 for mwir" in capsys.readouterr().err
    stop = strict_json(_stops_json(session))[0]
    # a target file needs the drone's temperature: without a calibration, one message
    no_cal = [a for a in argv if a not in ("--calibration", str(cal_path))]
    assert main([*no_cal, "--stop", str(stop)]) == 2
    err = capsys.readouterr().err
    assert f"stop {stop} of mwir: the session has no calibration" in err
    raw = session.read_bytes()
    mtime_ns = session.stat().st_mtime_ns
    assert main([*argv, "--stop", str(stop)]) == 0
    out = strict_json(capsys.readouterr().out)
    # The recording is raw data: its bytes and its time are as recorded.
    assert session.read_bytes() == raw and session.stat().st_mtime_ns == mtime_ns
    for key in ("small_m", "large_m", "mean_temp_c", "rss_delta_t_k", "n_frames", "small_m_std"):
        assert key in out
    _, small, large = drone_scene(cam)
    assert out["range_m"] == pytest.approx(RANGE_M, abs=0.5)
    assert out["n_frames"] >= 50
    assert out["small_m"] == pytest.approx(small, rel=0.10)
    assert out["large_m"] == pytest.approx(large, rel=0.10)
    assert out["mean_temp_c"] == pytest.approx(DRONE_K - 273.15, abs=0.5)
    assert load_target(str(target)).large_m == pytest.approx(out["large_m"], abs=1e-4)
    # The result is kept beside the session it was measured from; in it only with --write.
    from snrmon.acquisition.record.analysis_file import read_results, sidecar_path
    from snrmon.acquisition.record.reader import open_session

    (entry,) = read_results(session)
    assert sidecar_path(session).name == "s.analysis.json"
    assert entry["kind"] == "target_characterized" and entry["camera"] == "mwir"
    assert entry["payload"]["small_m"] == pytest.approx(out["small_m"])
    with open_session(session) as f:
        assert not [e for e in f.event_list() if e["kind"] == "target_characterized"]
    assert main([*argv, "--stop", str(stop), "--write"]) == 0
    capsys.readouterr()
    with open_session(session) as f:
        (event,) = [e for e in f.event_list() if e["kind"] == "target_characterized"]
    assert event["camera"] == "mwir"
    assert event["payload"]["small_m"] == pytest.approx(out["small_m"])
    assert len(read_results(session)) == 1  # --write: into the file instead of beside it
    # Without --apparent the drone's own temperature is found through the air: at 37 m the
    # MWIR transmission is 0.829 (LOWTRAN7 US Standard, contrast-weighted) and the path radiance
    # at 15 C is taken back out.
    assert main([*argv[:-1], "--stop", str(stop), "--no-record"]) == 0
    own = json.loads(capsys.readouterr().out)
    assert own["apparent_temp_c"] == pytest.approx(out["mean_temp_c"])
    assert own["transmission"] == pytest.approx(0.829, abs=0.002)
    from snrmon.acquisition.calibrate.calibration import radiance_of

    band = (3.45, 5.25)
    tau = own["transmission"]
    seen = tau * radiance_of(band, own["mean_temp_c"] + 273.15) + (1 - tau) * radiance_of(
        band, 288.15
    )
    assert seen == pytest.approx(radiance_of(band, own["apparent_temp_c"] + 273.15), rel=2e-3)


def _stops_json(session) -> str:
    from snrmon.acquisition.replay.batch import replay_session

    rows = replay_session(session).stops
    return json.dumps([r.stop for r in rows if r.camera == "mwir" and r.place.lrf_range_m < 45])


def test_at_rest_frames_are_where_range_and_size_are_steady():
    """A close stop whose frames show the drone arriving (larger, shrinking), at rest (its
    size noisy by a pixel) and leaving (shrinking, its range drifting away): the frames used
    are the at-rest ones, wherever they lie; a frame without a segmentation breaks a run."""
    rng = np.random.default_rng(5)
    arriving = np.linspace(26.0, 19.5, 60)
    rest = 19.0 + rng.normal(0.0, 0.4, 150)
    leaving = np.linspace(18.5, 11.0, 210)
    sizes = [*arriving, *rest, *leaving]
    ranges = [37.0] * 60 + [37.0] * 150 + list(np.linspace(37.0, 39.0, 210))
    picked = at_rest_frames(sizes, ranges, 100, stop_range_m=37.0, range_tolerance_m=1.0)
    assert len(picked) == 100 and picked == list(range(picked[0], picked[0] + 100))
    assert picked[0] >= 60 and picked[-1] < 210
    # the last 100 frames (what characterize took before) are the leaving drone's
    assert np.mean(sizes[-100:]) < 0.8 * np.mean([sizes[i] for i in picked])
    # a gap in the segmentation splits the at-rest frames: a run never spans it
    sizes[120] = None
    picked = at_rest_frames(sizes, ranges, 100, stop_range_m=37.0, range_tolerance_m=1.0)
    assert picked[0] > 120 and picked[-1] < 230
    # fewer than n steady frames: the longest run of them (range within 1 m: to frame 314)
    assert at_rest_frames(sizes, ranges, 1000, stop_range_m=37.0) == list(range(121, 315))


def test_the_target_file_keeps_the_segmented_outline_for_the_outline_footprint(cam, cal, tmp_path):
    """The outline a target file keeps is one frame's segmentation at the stop's pixel: the
    cross of the scene (a 30 cm span, 10 cm arms), its area the small dimension's square, and
    the model's outline footprint reads it."""
    from snrmon.acquisition.calibrate.characterize import characterize_frame, median_outline

    e, small, _ = drone_scene(cam, blades=False)
    px_m = RANGE_M * cam.sensor.ifov_rad
    rows = [
        characterize_frame(
            f, (XC, YC), range_m=RANGE_M, ifov_rad=cam.sensor.ifov_rad, calibration=cal
        )
        for f in cam.frames(e, 5, seed=3)
    ]
    outline = median_outline(rows, px_m)
    assert outline.pixel_m == px_m
    assert math.sqrt(outline.area_m2) == pytest.approx(small, rel=0.10)
    mask = outline.mask
    span_px = SPAN_M / px_m
    assert mask.shape[1] == pytest.approx(span_px, abs=2)  # the bar across
    assert mask[0].sum() < 0.5 * mask.shape[1]  # a cross, not a box: its top row is the arm
    res = summarise_frames(rows, camera="mwir", range_m=RANGE_M, method="otsu")
    path = tmp_path / "uav_outline.toml"
    path.write_text(target_toml(res, "uav_outline", outline=outline))
    t = load_target(str(path))
    assert t.outline == outline

"""Which checks a session needs, run in order: environment, config, ports, devices, disk."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from snrmon.doctor import FAIL, PASS, Check
from snrmon.doctor.backends import check_aravis, check_libusb, check_v4l2
from snrmon.doctor.compiled import check_compiled_analysis
from snrmon.doctor.devices import check_devices
from snrmon.doctor.disk import cameras_rate, check_disk_speed, check_free_space, frames_ratio
from snrmon.doctor.ports import check_port
from snrmon.doctor.qt import check_qt_display


@dataclass(frozen=True)
class DoctorOptions:
    """What ``snrmon doctor`` was asked (see its ``--help``)."""

    record_dir: Path = Path(".")
    duration_s: float = 3600.0
    wait_s: float = 5.0
    window_s: float = 2.0
    disk_test_bytes: int = 256 * 10**6
    headless: bool = False


def check_model(config) -> list[Check]:
    """The sensor model of each camera and the target load (the console draws the model beside
    every measurement), and each camera's calibration file fits its sensor."""
    from snrmon.acquisition.calibrate.calibration_file import load_calibration
    from snrmon.model.presets import load_sensor, load_target

    checks = []
    try:
        target = load_target(config.target)
        checks.append(Check("model:target", PASS, f"target {config.target!r}: {target.name}"))
    except (ValueError, OSError) as exc:
        checks.append(
            Check(
                "model:target",
                FAIL,
                f"target {config.target!r}: {exc}",
                'set target to "uav1", "uav2" or a target TOML file',
            )
        )
    for cam in config.cameras:
        name = f"model:{cam.name}"
        try:
            sensor = load_sensor(cam.sensor)
        except (ValueError, OSError) as exc:
            checks.append(
                Check(
                    name,
                    FAIL,
                    f"[cameras.{cam.name}] sensor {cam.sensor!r}: {exc}",
                    f'set [cameras.{cam.name}] sensor to "mwir", "lwir" or a sensor '
                    "TOML file describing this camera",
                )
            )
            continue
        detail = f"sensor {cam.sensor!r}: {sensor.width_px}x{sensor.height_px} @ {sensor.fps:g} fps"
        if cam.calibration is not None:
            try:
                load_calibration(cam.calibration, sensor)
            except (ValueError, OSError) as exc:
                checks.append(
                    Check(
                        name,
                        FAIL,
                        f"{detail}; calibration: {exc}",
                        "calibrate again (snrmon calibrate) or fix [cameras."
                        f"{cam.name}] calibration",
                    )
                )
                continue
            detail += f", calibration {cam.calibration}"
        checks.append(Check(name, PASS, detail))
    return checks


def run_doctor(config, opts: DoctorOptions) -> list[Check]:
    """Every check, in the order an operator fixes things. ``config`` may be None: then only
    this machine is checked (the camera backends are reported but not needed)."""
    cams = config.cameras if config is not None else ()
    sources = {c.source for c in cams}
    checks = [
        check_qt_display(needed=not opts.headless),
        check_libusb(needed=bool(sources & {"v4l2", "aravis"})),
        check_v4l2([str(c.address) for c in cams if c.source == "v4l2"], needed="v4l2" in sources),
        check_aravis(needed="aravis" in sources),
        check_compiled_analysis(),
    ]
    formats: dict = {}
    samples: dict = {}
    if config is not None:
        checks += check_model(config)
        for kind in ("gps", "lrf"):
            settings = getattr(config, kind)
            if settings is not None:
                checks.append(check_port(kind, settings))
        device_checks, formats = check_devices(
            config, wait_s=opts.wait_s, window_s=opts.window_s, samples=samples
        )
        checks += device_checks
    rate = cameras_rate(config, formats)
    checks.append(check_disk_speed(opts.record_dir, rate, opts.disk_test_bytes))
    ratio = frames_ratio(config, samples)
    checks.append(check_free_space(opts.record_dir, rate, opts.duration_s, compression=ratio))
    return checks

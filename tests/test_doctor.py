"""``snrmon doctor`` on simulated devices (an NMEA GPS and an LDM rangefinder on ptys, a camera
process writing a shared-memory ring): it passes when everything works, and each check fails
with its fix when its condition is broken."""

from __future__ import annotations

import os
import pty
import shutil
import time
from collections import namedtuple
from datetime import UTC, datetime
from pathlib import Path

import pytest

from snrmon.acquisition.config import session_config_from_dict
from snrmon.cli import main
from snrmon.doctor import FAIL, PASS
from snrmon.doctor.devices import check_devices
from snrmon.doctor.disk import BLOCK_BYTES, check_disk_speed, check_free_space
from snrmon.doctor.ports import check_port
from snrmon.doctor.qt import check_qt_display
from snrmon.drivers.config import DeviceSettings
from snrmon.sim.devices.nmea_sim import NmeaReplaySimulator, NmeaSimulator, gga_rmc
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.helpers import (
    H,
    SpotOnNoise,
    W,
    field_config,
    field_devices,
    sensor_toml,
    strict_json,
)

FPS = 60.0


def write_config(path: Path, ring: str, sensor: Path, gps_port: str, lrf_port: str) -> Path:
    return field_config(path, ring, gps_port, lrf_port, f'sensor = "{sensor}"')


@pytest.fixture
def rig(tmp_path):
    """Simulated camera, rangefinder and GPS (whose clock is the host's), and their config."""
    ring = f"snrmon-doc-{os.getpid()}-{time.monotonic_ns() % 10**9}"
    with field_devices(ring, gps_utc=datetime.now(UTC), fps=FPS) as (_, lrf, gps):
        sensor = sensor_toml(tmp_path / "cam-sensor.toml")
        config = write_config(tmp_path / "session.toml", ring, sensor, gps.path, lrf.path)
        yield {"config": config, "ring": ring, "sensor": sensor, "gps": gps, "lrf": lrf}


def doctor(capsys, *args: str) -> tuple[int, dict]:
    code = main(["doctor", "--json", "--headless", "--disk-test-mb", "16", *args])
    out = capsys.readouterr().out
    return code, strict_json(out)


def by_name(report: dict) -> dict[str, dict]:
    return {c["name"]: c for c in report["checks"]}


def test_doctor_passes_on_the_simulated_devices(rig, tmp_path, capsys):
    code, report = doctor(
        capsys, "--config", str(rig["config"]), "--record-dir", str(tmp_path), "--duration", "60"
    )
    checks = by_name(report)
    failed = {n: c["detail"] for n, c in checks.items() if c["status"] == FAIL and c["needed"]}
    assert code == 0 and report["ok"] and not failed, failed
    for name in (
        "model:target",
        "model:cam",
        "port:gps",
        "port:lrf",
        "camera:cam",
        "lrf",
        "gps-fix",
        "gps-clock",
        "disk-speed",
        "disk-space",
        "compiled-analysis",
    ):
        assert checks[name]["status"] == PASS and checks[name]["needed"], checks[name]
    cam = checks["camera:cam"]["data"]
    assert cam["fps"] == pytest.approx(FPS, rel=0.05) and cam["expected_fps"] == FPS
    assert abs(checks["gps-clock"]["data"]["offset_s"]) < 1.0
    assert checks["gps-fix"]["data"]["sats"] == 12 and checks["gps-fix"]["data"]["age_s"] < 2
    # 128 x 96 x 2 bytes at 60 fps, twice over for the recorder's overhead
    assert checks["disk-speed"]["data"]["needed_mb_s"] == pytest.approx(W * H * 2 * FPS * 2 / 1e6)
    assert checks["qt-display"]["needed"] is False  # --headless
    assert checks["compiled-analysis"]["data"]["seconds"] > 0
    # the space the cameras' own frames take with the default filter, measured on them
    space = checks["disk-space"]["data"]
    assert space["compression"] == "bitshuffle-lz4" and space["compression_ratio"] > 1.0
    raw_gb = W * H * 2 * FPS * 60 * 1.05 / 1e9
    assert space["needed_gb"] == pytest.approx(raw_gb / space["compression_ratio"])


def test_missing_port_fails_with_its_fix(rig, tmp_path, capsys):
    config = write_config(
        tmp_path / "s.toml", rig["ring"], rig["sensor"], "/dev/ttyUSB-gone", rig["lrf"].path
    )
    code, report = doctor(
        capsys,
        "--config",
        str(config),
        "--wait",
        "1",
        "--record-dir",
        str(tmp_path),
        "--duration",
        "60",
    )
    checks = by_name(report)
    assert code == 1 and not report["ok"]
    port = checks["port:gps"]
    assert port["status"] == FAIL and "/dev/ttyUSB-gone does not exist" in port["detail"]
    assert "snrmon devices" in port["fix"]
    assert checks["gps-fix"]["status"] == FAIL and "no sentence" in checks["gps-fix"]["detail"]
    assert checks["camera:cam"]["status"] == PASS and checks["lrf"]["status"] == PASS


def test_text_output_gives_each_failure_its_fix(rig, tmp_path, capsys):
    config = write_config(
        tmp_path / "s.toml", rig["ring"], rig["sensor"], "/dev/ttyUSB-gone", rig["lrf"].path
    )
    code = main(
        [
            "doctor",
            "--config",
            str(config),
            "--wait",
            "1",
            "--headless",
            "--disk-test-mb",
            "8",
            "--record-dir",
            str(tmp_path),
        ]
    )
    lines = capsys.readouterr().out.splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("FAIL  port:gps"))
    assert code == 1 and lines[at + 1].strip().startswith("fix: plug in the gps")
    assert lines[-1].startswith("snrmon doctor: ") and "NOT ready: port:gps, gps-fix" in lines[-1]


def test_unreadable_port_names_the_group_to_join(tmp_path):
    master, slave = pty.openpty()
    try:
        path = os.ttyname(slave)
        os.chmod(path, 0o660)
        table = DeviceSettings("nmea", path)
        gid = os.stat(path).st_gid
        # Another user, outside the port's group (as root, this process may open anything).
        c = check_port("gps", table, uid=54321, gids={54321})
        assert c.status == FAIL and "not readable and writable" in c.detail
        assert c.fix.startswith("sudo usermod -aG ") and "log out and back in" in c.fix
        assert c.data["mode"] == "crw-rw----"
        assert check_port("gps", table, uid=54321, gids={gid}).status == PASS  # in the group
        assert check_port("gps", table).status == PASS  # this process
    finally:
        os.close(master)
        os.close(slave)
    (tmp_path / "plain").write_text("")
    c = check_port("gps", DeviceSettings("nmea", str(tmp_path / "plain")))
    assert c.status == FAIL and "not a character device" in c.detail
    assert check_port("gps", DeviceSettings("gpsd", "localhost:2947")).status == "skip"


@pytest.mark.slow
def test_devices_that_do_not_answer_or_disagree(rig, tmp_path):
    """No camera writer; a camera at the wrong rate; a GPS without a fix; a GPS whose clock is
    years off; a receiver that sends week-rollover dates (positions kept, time unknown)."""
    slow_ring = f"{rig['ring']}-30"
    slow = ShmProducer(slow_ring, W, H, SpotOnNoise(4), fps=30.0, slots=16)
    nofix = NmeaSimulator(lambda t: None, rate_hz=10.0)
    old_clock = NmeaSimulator(lambda t: (32.0, -106.0, 1200.0), rate_hz=10.0)  # 2019 UTC
    gga, rmc = gga_rmc(datetime(2019, 5, 14, 15, tzinfo=UTC), 32.0, -106.0, 1200.0)
    body = rmc.decode().strip()[1:].split("*")[0].replace(",140519,", ",2208-1,")
    log = tmp_path / "rollover.log"
    log.write_text(gga.decode() + f"${body}*{_checksum(body):02X}\r\n")
    rollover = NmeaReplaySimulator(log, lines_per_s=20, loop=True)
    sims = [slow, nofix, old_clock, rollover]
    for s in sims:
        s.start()
    try:

        def cfg(gps):
            return session_config_from_dict(
                {
                    "cameras": {
                        "gone": {
                            "source": "shm",
                            "address": "snrmon-doc-no-such-ring",
                            "sensor": str(rig["sensor"]),
                        },
                        "slow": {
                            "source": "shm",
                            "address": slow_ring,
                            "sensor": str(rig["sensor"]),
                        },
                    },
                    "gps": {"protocol": "nmea", "port": gps.path, "baud": 38400},
                }
            )

        checks, _ = check_devices(cfg(nofix), wait_s=2, window_s=1)
        c = {k.name: k for k in checks}
        assert c["camera:gone"].status == FAIL and "no frames" in c["camera:gone"].detail
        assert "writer" in c["camera:gone"].fix
        assert (
            c["camera:slow"].status == FAIL
            and "runs at 30 fps but sensor" in c["camera:slow"].detail
        )
        assert c["gps-fix"].status == FAIL and "no fix" in c["gps-fix"].detail
        assert "open sky" in c["gps-fix"].fix
        checks, _ = check_devices(cfg(old_clock), wait_s=2, window_s=1)
        clock = {k.name: k for k in checks}["gps-clock"]
        assert clock.status == FAIL and clock.data["offset_s"] < -1e8  # 2019 against now
        assert "set the host clock" in clock.fix
        checks, _ = check_devices(cfg(rollover), wait_s=2, window_s=1)
        c = {k.name: k for k in checks}
        assert c["gps-fix"].status == PASS  # the positions are kept ...
        assert c["gps-clock"].status == FAIL and "no valid date/time" in c["gps-clock"].detail
    finally:
        for s in sims:
            s.stop()


def _checksum(body: str) -> int:
    from snrmon.drivers.checksum import xor_checksum

    return xor_checksum(body)


def test_slow_disk_fails_with_its_fix(tmp_path):
    def slow_write(fd: int, data: bytes) -> int:  # a disk of ~20 MB/s
        time.sleep(len(data) / 20e6)
        return os.write(fd, data)

    c = check_disk_speed(tmp_path, 60e6, 2 * BLOCK_BYTES, write=slow_write)
    assert c.status == FAIL and c.data["write_mb_s"] < 25 and c.data["needed_mb_s"] == 120
    assert "faster disk" in c.fix
    assert check_disk_speed(tmp_path, 1e6, BLOCK_BYTES).status == PASS
    assert not list(tmp_path.iterdir())  # the test file is gone


def test_full_disk_fails_with_its_fix(tmp_path, rig, capsys):
    usage = namedtuple("usage", "total used free")
    c = check_free_space(tmp_path, 100e6, 3600, usage=lambda _: usage(500e9, 490e9, 10e9))
    assert c.status == FAIL and "room for only 0.03 h" in c.detail and c.data["needed_gb"] > 360
    assert "--record-dir" in c.fix
    # frames measured to compress 4x take a quarter of the room: 90 GB of 10 free
    c = check_free_space(
        tmp_path,
        100e6,
        3600,
        compression=("zstd", 4.0),
        usage=lambda _: usage(500e9, 490e9, 10e9),
    )
    assert c.data["needed_gb"] == pytest.approx(100e6 * 3600 * 1.05 / 4 / 1e9)
    assert "zstd 4.00x" in c.detail and "room for only 0.11 h" in c.detail
    # Through the command: a planned duration the real free space cannot hold.
    free_s = shutil.disk_usage(tmp_path).free / (W * H * 2 * FPS)
    code, report = doctor(
        capsys,
        "--config",
        str(rig["config"]),
        "--record-dir",
        str(tmp_path),
        "--duration",
        f"{free_s * 40:.0f}",  # frames compress less than 20x
        "--wait",
        "3",
    )
    space = by_name(report)["disk-space"]
    assert code == 1 and space["status"] == FAIL and space["needed"]


def test_missing_qt_library_named_with_its_package(tmp_path):
    """An environment that hides libxcb-cursor (an unloadable stub first on the library path):
    the check names the library and the package, with or without a display to open."""
    (tmp_path / "libxcb-cursor.so.0").write_bytes(b"")
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    env["LD_LIBRARY_PATH"] = str(tmp_path)
    c = check_qt_display(env)
    assert c.status == FAIL and not c.needed and "libxcb-cursor.so.0" in c.detail
    assert c.fix.startswith("sudo apt-get install libxcb-cursor0")


@pytest.mark.desktop
def test_qt_display_on_a_real_x_server(xvfb_display, tmp_path):
    env = {**os.environ, "DISPLAY": xvfb_display}
    ok = check_qt_display(env)
    assert ok.status == PASS and ok.data["width"] == 1600, ok.detail
    (tmp_path / "libxcb-cursor.so.0").write_bytes(b"")
    broken = check_qt_display({**env, "LD_LIBRARY_PATH": str(tmp_path)})
    assert broken.status == FAIL and broken.needed and "libxcb-cursor.so.0" in broken.detail
    assert "libxcb-cursor0" in broken.fix
    gone = check_qt_display({**env, "DISPLAY": ":9999"})
    assert gone.status == FAIL and "cannot connect to X display :9999" in gone.detail


def test_an_analysis_that_does_not_compile_fails_with_its_fix(monkeypatch):
    import snrmon.acquisition.engine.warm_up as wu
    from snrmon.doctor.compiled import check_compiled_analysis

    def broken(engine):
        raise ImportError("numba needs NumPy <= 2.3")

    monkeypatch.setattr(wu, "warm_up", broken)
    c = check_compiled_analysis((96, 128))
    assert c.status == FAIL and c.needed
    assert "numba needs NumPy <= 2.3" in c.detail and "constraints.txt" in c.fix

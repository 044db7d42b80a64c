"""A simulated serial device as a process of its own, for a test that kills it as a device dies
(SIGKILL: no goodbye, its pty closed by the kernel): ``python -m tests.gui.device_process
ldm|nmea LINK`` serves the rangefinder (LDM, a steady :data:`RANGE_M` at 20 Hz) or the GPS
(NMEA at 10 Hz, the fixed point :data:`FIX`) on a pty whose stable path is LINK, says ``ready``
on its standard output, and runs until its standard input closes or it is killed.
"""

from __future__ import annotations

import sys

RANGE_M = 150.0
FIX = (32.3810, -106.4790, 1250.0)  # near the test site (32.38, -106.48, 1200 m)


def main(kind: str, link: str) -> None:
    from snrmon.sim.devices.ldm_sim import LdmSimulator
    from snrmon.sim.devices.nmea_sim import NmeaSimulator

    if kind == "ldm":
        sim = LdmSimulator(lambda t: RANGE_M, rate_hz=20.0, tracking=True, link_path=link)
    elif kind == "nmea":
        sim = NmeaSimulator(lambda t: FIX, rate_hz=10.0, link_path=link)
    else:
        raise SystemExit(f"unknown device kind {kind!r} (ldm, nmea)")
    sim.start()
    print("ready", flush=True)
    sys.stdin.read()  # until the test closes it (or kills this process)
    sim.stop()


if __name__ == "__main__":
    main(*sys.argv[1:3])

"""Sensor model speed: the four-curve SNR-versus-range prediction for 500 ranges (paper Figs.
7-10) with the expected Eq. (4) readings of both background rules and the Monte-Carlo band, as
the console asks for it, in milliseconds:

* ``<camera>_first_call_ms``: the first call in a fresh process, imports excluded (it builds
  the PSF's frequency grids, PVF tables and the expected reading's patterns); the median of
  fresh processes, each one in ``<camera>_first_call_ms_runs``;
* ``<camera>_four_curves_500_ranges_ms``: a repeated call (the same inputs), median;
* ``<camera>_new_sky_500_ranges_ms``: a call with a new sky temperature each time (what a
  measured sky asks of the console's model), median;
* ``<camera>_console_600_ranges_new_sky_ms``: the same on the console's 600-range grid
  (``acquisition.prediction.ModelPredictor``), median;

against ``goal_first_call_ms`` and ``goal_warm_ms``; ``load_1min`` is the machine's load
average when it ran (the machine may be shared). Also the cost of one 7x7
pixel-energy-fraction window (what the scene simulator calls per drone)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np

from snrmon.model.presets import load_sensor
from snrmon.model.pvf import pixel_energy_fractions

KEY = "model"
GOAL_FIRST_CALL_MS = 100.0
GOAL_WARM_MS = 20.0
CAMERAS = ("mwir", "lwir")

# One fresh process: its imports, then the calls, timed. scipy.ndimage is imported by the
# expected reading on its first use: an import, not the call's work.
_FRESH = """
import json, sys, time
import numpy as np
import scipy.ndimage  # noqa: F401
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.snr import predict

camera, repeats = sys.argv[1], int(sys.argv[2])
sensor, target = load_sensor(camera), load_target("uav1")
bench = np.linspace(20.0, 3000.0, 500)
console = np.geomspace(10.0, 5000.0, 600)


def ms(**kw):
    t0 = time.perf_counter()
    predict(sensor, target, kw.pop("ranges", bench), **kw)
    return 1e3 * (time.perf_counter() - t0)


out = {"first": ms()}
out["warm"] = [ms() for _ in range(repeats)]
out["new_sky"] = [ms(background_temp_k=255.0 + 3.0 * i) for i in range(repeats)]
ms(ranges=console)
out["console"] = [ms(ranges=console, background_temp_k=256.0 + 3.0 * i) for i in range(repeats)]
print(json.dumps(out))
"""


def _fresh_process(camera: str, repeats: int) -> dict:
    done = subprocess.run(
        [sys.executable, "-c", _FRESH, camera, str(repeats)],
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def _repeat_ms(fn, budget_s: float) -> float:
    n, start = 0, time.perf_counter()
    while True:
        fn()
        n += 1
        elapsed = time.perf_counter() - start
        if elapsed >= budget_s and n >= 5:
            return 1e3 * elapsed / n


def run(duration_s: float) -> dict:
    budget = min(max(duration_s / 4.0, 0.2), 2.0)
    processes = 3 if duration_s >= 1.0 else 1
    repeats = 7 if duration_s >= 1.0 else 3
    figures: dict = {
        "goal_first_call_ms": GOAL_FIRST_CALL_MS,
        "goal_warm_ms": GOAL_WARM_MS,
        "load_1min": round(os.getloadavg()[0], 2),
    }
    for name in CAMERAS:
        runs = [_fresh_process(name, repeats) for _ in range(processes)]
        first = [r["first"] for r in runs]
        figures[f"{name}_first_call_ms"] = round(float(np.median(first)), 1)
        figures[f"{name}_first_call_ms_runs"] = [round(v, 1) for v in first]
        for key, label in (
            ("warm", "four_curves_500_ranges"),
            ("new_sky", "new_sky_500_ranges"),
            ("console", "console_600_ranges_new_sky"),
        ):
            values = [v for r in runs for v in r[key]]
            figures[f"{name}_{label}_ms"] = round(float(np.median(values)), 2)
    for name in CAMERAS:
        sensor = load_sensor(name)
        psf = sensor.corrected_psf() if name == "mwir" else sensor.diffraction_psf()
        ff = sensor.fill_factor
        pixel_energy_fractions(psf, 0.1, 0.2, fill_factor=ff, target_sigma_px=0.2)
        rng = np.random.default_rng(0)
        d = rng.uniform(-0.5, 0.5, size=(64, 2))
        it = iter(range(10**9))

        def one(d=d, it=it, psf=psf, ff=ff):
            k = next(it) % 64
            pixel_energy_fractions(psf, d[k, 0], d[k, 1], fill_factor=ff, target_sigma_px=0.2)

        figures[f"{name}_pixel_fractions_7x7_us"] = round(1e3 * _repeat_ms(one, budget / 2), 1)
    airy = load_sensor("mwir").diffraction_psf()
    pixel_energy_fractions(airy, 0.0, 0.0, fill_factor=0.8)
    figures["mwir_airy_pixel_fractions_7x7_us"] = round(
        1e3 * _repeat_ms(lambda: pixel_energy_fractions(airy, 0.3, -0.2, fill_factor=0.8), 0.2), 1
    )
    return figures


if __name__ == "__main__":
    print(run(2.0))

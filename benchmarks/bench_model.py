"""Sensor model speed: the four-curve SNR-versus-range prediction for 500 ranges (paper Figs.
7-10), first call (builds PSF/PVF caches) and repeated calls, in milliseconds; and the cost of
one 7x7 pixel-energy-fraction window (what the scene simulator calls per drone)."""

from __future__ import annotations

import time

import numpy as np

from snrmon.model.presets import load_sensor, load_target
from snrmon.model.pvf import pixel_energy_fractions
from snrmon.model.snr import predict

KEY = "model"


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
    ranges = np.linspace(20.0, 3000.0, 500)
    figures: dict = {}
    for name in ("mwir", "lwir"):
        sensor, target = load_sensor(name), load_target("uav1")
        t0 = time.perf_counter()
        predict(sensor, target, ranges)
        figures[f"{name}_first_call_ms"] = round(1e3 * (time.perf_counter() - t0), 2)
        ms = _repeat_ms(lambda s=sensor, t=target: predict(s, t, ranges), budget)
        figures[f"{name}_four_curves_500_ranges_ms"] = round(ms, 3)
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

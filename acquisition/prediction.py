"""The model's prediction at a measured range, for the stop table and the live charts.

The four curves of paper Figs. 7-10 (small/large characteristic dimension, uncorrected
diffraction-limited point target / corrected real PSF and finite size) are computed once per
camera on a dense logarithmic range grid by :func:`model.snr.predict` and interpolated in
log-range, so a lookup per frame costs microseconds and every number still comes from
:mod:`model`.
"""

from __future__ import annotations

import numpy as np

CURVES = ("small", "large", "small_corrected", "large_corrected")


class ModelPredictor:
    """``predictor(camera, range_m) -> {"small", "large", "small_corrected",
    "large_corrected", "resolved_small"}`` for each camera's sensor preset and one target."""

    def __init__(
        self,
        sensors: dict[str, str],
        target: str,
        *,
        ranges_m: np.ndarray | None = None,
        **predict_options,
    ) -> None:
        from model.presets import load_sensor, load_target
        from model.snr import predict

        self.target = load_target(target)
        self._predict = predict
        self._options = dict(predict_options)
        self.sensors = {}
        self.background_temp_k: dict[str, float | None] = {}
        self.ranges_m = (
            np.geomspace(10.0, 5000.0, 600) if ranges_m is None else np.asarray(ranges_m, float)
        )
        self._log_r = np.log(self.ranges_m)
        self.curves: dict[str, dict[str, np.ndarray]] = {}
        for camera, sensor_name in sensors.items():
            self.sensors[camera] = load_sensor(sensor_name)
            self._compute(camera, predict_options.get("background_temp_k"))

    def set_background(self, camera: str, temp_k: float | None) -> None:
        """Recompute ``camera``'s curves for a measured background (sky) temperature: the
        paper's path-radiance correction (sections 8-9); None returns to the model's own."""
        if camera in self.sensors:
            self._compute(camera, temp_k)

    def _compute(self, camera: str, background_temp_k: float | None) -> None:
        options = {**self._options, "background_temp_k": background_temp_k}
        p = self._predict(self.sensors[camera], self.target, self.ranges_m, **options)
        self.background_temp_k[camera] = background_temp_k
        curves = {
            "small": np.asarray(p.snr_small, float),
            "large": np.asarray(p.snr_large, float),
            "small_corrected": np.asarray(p.snr_small_corrected, float),
            "large_corrected": np.asarray(p.snr_large_corrected, float),
            "resolved_small": np.asarray(p.resolved_small, float),
        }
        for name in ("small_corrected", "large_corrected"):  # the Fig. 12 band
            if name in p.lower and name in p.upper:
                curves[f"{name}_lower"] = np.asarray(p.lower[name], float)
                curves[f"{name}_upper"] = np.asarray(p.upper[name], float)
        self.curves = {**self.curves, camera: curves}  # swapped whole: readers never see half

    def __call__(self, camera: str, range_m: float) -> dict[str, float]:
        curves = self.curves.get(camera)
        if curves is None or range_m is None or not range_m > 0:
            return {}
        x = np.log(range_m)
        out = {name: float(np.interp(x, self._log_r, curves[name])) for name in CURVES}
        # The resolved/unresolved switch is a step, not something to interpolate.
        i = int(np.clip(np.searchsorted(self._log_r, x), 0, len(self._log_r) - 1))
        out["resolved_small"] = float(curves["resolved_small"][i])
        return out

    def curve(self, camera: str) -> dict[str, tuple]:
        """The four curves of ``camera`` as (ranges_m, snr) pairs, for plotting, and the
        uncertainty band of each corrected curve as (ranges_m, lower, upper)."""
        c = self.curves.get(camera, {})
        out: dict[str, tuple] = {name: (self.ranges_m, c[name]) for name in CURVES if name in c}
        for name in ("small_corrected", "large_corrected"):
            if f"{name}_lower" in c:
                out[f"{name} band"] = (self.ranges_m, c[f"{name}_lower"], c[f"{name}_upper"])
        return out

"""The noise panel: per camera, the section 6 split (total, temporal and spatial noise) and, beside
it, the 3D noise (D'Agostino and Webb's seven components, bias-corrected) of the background clear
of the target over the last complete block of 100 frames, all in DN.

Every value is a field of :class:`snrmon.acquisition.engine.status.CameraStatus` computed on the
processing side (acquisition/measure/track_noise.py, acquisition/measure/noise3d.py); the panel
only formats it. "--" until the pipeline has a background to measure (a track, or a clear-sky
rectangle in the measurement config) and, for the 3D noise, until 100 frames of it are in.
"""

from __future__ import annotations

import math

from PySide6.QtWidgets import QGridLayout, QLabel, QVBoxLayout, QWidget

from snrmon.acquisition.engine.status import CameraStatus, SessionStatus

COLUMNS = (
    ("noise_total_dn", "total", "Total noise (DN): std of the background pixels of one frame"),
    (
        "noise_temporal_dn",
        "temporal",
        "Temporal noise (DN): std of the difference with the previous frame over the same pixels, "
        "divided by sqrt(2) (a difference of two frames carries sqrt(2) times the single-frame "
        "temporal noise)",
    ),
    (
        "noise_spatial_dn",
        "spatial",
        "Spatial (fixed-pattern) noise (DN): sqrt(total^2 - temporal^2)",
    ),
)
NOISE_3D = ("t", "v", "h", "tv", "th", "vh", "tvh", "total")
NOISE_3D_TIPS = {
    "t": "frame-to-frame flicker of the whole frame",
    "v": "fixed row noise",
    "h": "fixed column noise",
    "tv": "row noise that changes every frame",
    "th": "column noise that changes every frame",
    "vh": "fixed-pattern non-uniformity, pixel to pixel",
    "tvh": "random spatio-temporal noise (NETD = sigma_tvh / SiTF)",
    "total": "all seven together: the noise of one pixel sample",
}
NOISE_3D_TIP = (
    "3D noise (D'Agostino and Webb), bias-corrected for the finite cube (Haefner and Burks), DN: "
    "raw pixels of the largest region clear of the tracked peak by 20 px (or the clear-sky "
    "rectangle), at most 128 x 128 px nearest the target, over the last complete block of 100 "
    "frames (docs/measurement.md)"
)
REGION_TIP = (
    "Background: the clear-sky rectangle of the measurement config if there is one, else a "
    "41 x 41 px square around the tracked peak without the 7 x 7 box; raw camera pixels, "
    "re-estimated 4 times per second."
)


class NoisePanel(QWidget):
    """Two grids: one row per camera, total / temporal / spatial noise (DN); and the 3D noise's
    seven components and total (DN)."""

    def __init__(self, cameras: list[str], parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.labels: dict[tuple[str, str], QLabel] = {}
        grid = QGridLayout()
        for col, (_, title, tip) in enumerate(COLUMNS, start=1):
            head = QLabel(f"{title} (DN)")
            head.setToolTip(tip)
            grid.addWidget(head, 0, col)
        for row, cam in enumerate(cameras, start=1):
            name = QLabel(cam.upper())
            name.setToolTip(f"{cam}: {REGION_TIP}")
            grid.addWidget(name, row, 0)
            for col, (field, _title, tip) in enumerate(COLUMNS, start=1):
                value = QLabel("--")
                value.setToolTip(f"{cam} {tip}")
                grid.addWidget(value, row, col)
                self.labels[(cam, field)] = value
        cube = QGridLayout()
        title = QLabel("3D noise (DN, bias-corrected, last 100 frames)")
        title.setToolTip(NOISE_3D_TIP)
        cube.addWidget(title, 0, 0, 1, len(NOISE_3D) + 1)
        for col, comp in enumerate(NOISE_3D, start=1):
            head = QLabel(comp)
            head.setToolTip(f"sigma_{comp}: {NOISE_3D_TIPS[comp]}")
            cube.addWidget(head, 1, col)
        self.region_labels: dict[str, QLabel] = {}
        for row, cam in enumerate(cameras, start=2):
            name = QLabel(cam.upper())
            name.setToolTip(f"{cam}: {NOISE_3D_TIP}")
            cube.addWidget(name, row, 0)
            self.region_labels[cam] = name
            for col, comp in enumerate(NOISE_3D, start=1):
                value = QLabel("--")
                value.setToolTip(f"{cam} sigma_{comp}: {NOISE_3D_TIPS[comp]}")
                cube.addWidget(value, row, col)
                self.labels[(cam, f"noise_3d_{comp}")] = value
        lay = QVBoxLayout(self)
        lay.setContentsMargins(4, 4, 4, 4)
        lay.addLayout(grid)
        lay.addSpacing(6)
        lay.addLayout(cube)
        lay.addStretch(1)
        self.setToolTip(REGION_TIP)

    def show_status(self, st: SessionStatus) -> None:
        for (cam, field), label in self.labels.items():
            cs = st.cameras.get(cam)
            if field.startswith("noise_3d_"):
                self._show_3d(cam, field.removeprefix("noise_3d_"), label, cs)
                continue
            value = getattr(cs.figures, field) if cs is not None else math.nan
            text = f"{value:.2f}" if math.isfinite(value) else "--"
            if label.text() != text:
                label.setText(text)

    def _show_3d(self, cam: str, comp: str, label: QLabel, cs: CameraStatus | None) -> None:
        figure = cs.figures.noise_3d if cs is not None else None
        if figure is None:
            text, tip = "--", f"{cam} sigma_{comp}: {NOISE_3D_TIPS[comp]}"
        else:
            n = figure.noise
            lo, hi = n.ci95[comp]
            x0, y0, x1, y1 = figure.region
            text = f"{n.sigma_corrected[comp]:.2f}"
            tip = (
                f"{cam} sigma_{comp} ({NOISE_3D_TIPS[comp]}): {text} DN bias-corrected, 95 % "
                f"interval {lo:.3f}-{hi:.3f} DN; directional estimate {n.sigma[comp]:.3f} DN. "
                f"Region x {x0}-{x1}, y {y0}-{y1} ({n.cols} x {n.rows} px), {n.frames} frames, "
                f"mean {n.mean:.1f} DN"
            )
        if label.text() != text:
            label.setText(text)
        if label.toolTip() != tip:
            label.setToolTip(tip)

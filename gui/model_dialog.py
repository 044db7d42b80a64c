"""The model options dialog: target preset, which curves are shown, background temperature,
the day's met readings (air temperature, relative humidity, pressure, visibility, aerosol model,
season) that drive the model's LOWTRAN7 atmosphere, and the noise: the model's own or the
cameras' measured 3D noise; a live session records the readings and the noise. Readings left
empty are the season's standard atmosphere at sea level; neither is remembered for the next
start (another day, other weather: the session's [weather] table gives them; other cameras'
noise).

It only collects choices into a :class:`snrmon.gui.model_curves.ModelOptions` and hands them to the
window's ``apply(options) -> error message | None``; the window rebuilds the predictors. A bad
entry is refused with its message shown in the dialog, which stays open.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDialog,
    QDialogButtonBox,
    QFormLayout,
    QLabel,
    QLineEdit,
    QVBoxLayout,
    QWidget,
)

from snrmon.acquisition.measure.track_noise import FRAMES_3D
from snrmon.acquisition.prediction import (
    AEROSOLS,
    DEFAULT_VISIBILITY_KM,
    NOISE_SOURCES,
    SEASONS,
)
from snrmon.gui.model_curves import (
    ALL_CURVES,
    CURVE_LABELS,
    MET_FIELDS,
    ModelOptions,
    parse_background_temp,
    parse_met_readings,
)

TARGET_CHOICES = ("uav1", "uav2")  # the model's target presets; a target TOML path also works


class ModelOptionsDialog(QDialog):
    """Non-modal: Apply keeps it open, OK applies and closes, Cancel closes."""

    def __init__(
        self,
        options: ModelOptions,
        apply: Callable[[ModelOptions], str | None],
        parent: QWidget | None = None,
    ) -> None:
        super().__init__(parent)
        self.setWindowTitle("Model options")
        self._apply = apply
        form = QFormLayout()
        self._add_target_and_curves(form, options)
        self._add_background(form, options)
        self._add_weather(form, options)
        self._add_noise(form, options)
        self.error = QLabel("")
        self.error.setStyleSheet("color: #ff6060;")
        self.error.setWordWrap(True)
        buttons = QDialogButtonBox(
            QDialogButtonBox.StandardButton.Ok
            | QDialogButtonBox.StandardButton.Apply
            | QDialogButtonBox.StandardButton.Cancel
        )
        self.apply_button = buttons.button(QDialogButtonBox.StandardButton.Apply)
        self.apply_button.clicked.connect(self.apply)
        buttons.accepted.connect(self._ok)
        buttons.rejected.connect(self.reject)
        lay = QVBoxLayout(self)
        lay.addLayout(form)
        lay.addWidget(self.error)
        lay.addWidget(buttons)

    def _add_target_and_curves(self, form: QFormLayout, options: ModelOptions) -> None:
        """The target's row and one check box per curve (the first row captioned "curves")."""
        self.target = QComboBox()
        self.target.setEditable(True)
        self.target.addItems(list(TARGET_CHOICES))
        self.target.setCurrentText(options.target)
        self.target.setToolTip(
            "Target preset of the model (uav1: DJI Phantom 4 Pro, uav2: DJI Inspire 1), "
            "or the path of a target TOML file"
        )
        self.shown: dict[str, QCheckBox] = {}
        form.addRow("target", self.target)
        for name in ALL_CURVES:
            box = QCheckBox(CURVE_LABELS[name])
            box.setChecked(name in options.shown)
            box.setToolTip(
                "Uncorrected: diffraction-limited PSF, point target; corrected: real PSF and "
                "finite target size (paper Figs. 7-10); corrected curves carry their "
                "uncertainty band"
            )
            self.shown[name] = box
            form.addRow("" if len(self.shown) > 1 else "curves", box)

    def _add_background(self, form: QFormLayout, options: ModelOptions) -> None:
        self.background = QLineEdit(
            "" if options.background_temp_k is None else f"{options.background_temp_k:g}"
        )
        self.background.setPlaceholderText("the model's own")
        self.background.setToolTip(
            "Background (sky) temperature of the model in K; empty: the model's own. With a "
            "calibration the curves at the measured sky are drawn as well."
        )
        form.addRow("background (K)", self.background)

    def _add_weather(self, form: QFormLayout, options: ModelOptions) -> None:
        """The day's met readings, the aerosol model and the season."""
        weather = options.weather
        self.met: dict[str, QLineEdit] = {}
        for key, what, unit in MET_FIELDS:
            value = None if weather is None else getattr(weather, key)
            edit = QLineEdit("" if value is None else f"{value:g}")
            vis = key == "visibility_km"
            edit.setPlaceholderText(f"{DEFAULT_VISIBILITY_KM:g} km" if vis else "the season's")
            edit.setToolTip(
                f"Today's {what} in {unit}, as read at the site; empty: "
                + (
                    f"{DEFAULT_VISIBILITY_KM:g} km (aerosol none: no aerosol)"
                    if vis
                    else "the season's standard atmosphere at sea level"
                )
            )
            self.met[key] = edit
            form.addRow(f"{what} ({unit})", edit)
        self.aerosol = QComboBox()
        self.aerosol.addItems(list(AEROSOLS))
        self.aerosol.setCurrentText(weather.aerosol if weather else "rural")
        self.aerosol.setToolTip("LOWTRAN7 aerosol model at the visibility (none: no aerosol)")
        form.addRow("aerosol", self.aerosol)
        self.season = QComboBox()
        self.season.addItems(list(SEASONS))
        self.season.setCurrentText(weather.season if weather else "us_std_1976")
        self.season.setToolTip(
            "Standard atmosphere whose sea-level air stands in for readings not given"
        )
        form.addRow("season", self.season)

    def _add_noise(self, form: QFormLayout, options: ModelOptions) -> None:
        self.noise = QComboBox()
        self.noise.addItems(list(NOISE_SOURCES))
        self.noise.setCurrentText(options.noise)
        self.noise.setToolTip(
            "The noise in the model's SNR (Eq. 3's denominator). model: the model's own "
            "(Eq. 1 temporal noise, no spatial noise). measured: each camera's bias-corrected "
            "sigma_tvh and sigma_vh of the 3D noise of the background around the target over "
            f"the last {FRAMES_3D} frames (the noise panel; docs/measurement.md), taken when "
            "you apply: the peak-pixel SNR's noise after non-uniformity correction is about "
            "sqrt(sigma_tvh^2 + sigma_vh^2). A camera without a 3D noise yet keeps the "
            "model's."
        )
        form.addRow("noise", self.noise)

    def options(self) -> ModelOptions:
        """The choices as entered (ValueError for a bad background temperature or reading)."""
        shown = tuple(name for name, box in self.shown.items() if box.isChecked())
        return ModelOptions(
            target=self.target.currentText().strip(),
            shown=shown,
            background_temp_k=parse_background_temp(self.background.text()),
            weather=parse_met_readings(
                {k: e.text() for k, e in self.met.items()},
                self.aerosol.currentText(),
                self.season.currentText(),
            ),
            noise=self.noise.currentText(),
        )

    def apply(self) -> bool:
        """Hand the choices to the window; show why when they are refused."""
        try:
            message = self._apply(self.options())
        except ValueError as exc:
            message = str(exc)
        self.error.setText(message or "")
        return message is None

    def _ok(self) -> None:
        if self.apply():
            self.accept()

"""snrmon: the peak-pixel SNR of unresolved drones in infrared video, beside the sensor model.

The public API (:mod:`snrmon.api`, docs/api.md) is at the top: :func:`predict` (the model's
curves as an xarray Dataset), :func:`open_session` (a recording, a :class:`RecordedSession`:
frames, measurements, the stop table), :func:`load_stack`, :func:`measure_stack`,
:func:`track_stack` (paper Eq. 4 on a stack). They are imported when first used, so
``import snrmon`` stays cheap for the command line.

One installed namespace. Its subpackages each own one job (docs/architecture.md):
:mod:`snrmon.model` (the physics), :mod:`snrmon.drivers` (devices), :mod:`snrmon.acquisition`
(the pipeline, recording, replay), :mod:`snrmon.sim` (simulated devices and scenes),
:mod:`snrmon.gui` (the console, with the ``gui`` extra) and the command line
(:mod:`snrmon.cli`).
"""

from __future__ import annotations

__version__ = "0.1.0"
__all__ = [
    "RecordedSession",
    "load_stack",
    "measure_stack",
    "open_session",
    "predict",
    "track_stack",
]
DEPRECATED = ("Session",)  # the old name of RecordedSession: still there, with a warning


def __getattr__(name: str):
    if name in __all__ or name in DEPRECATED:
        from snrmon import api

        return getattr(api, name)
    raise AttributeError(f"module 'snrmon' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])

"""snrmon: the peak-pixel SNR of unresolved drones in infrared video, beside the sensor model.

One installed namespace. Its subpackages each own one job (docs/architecture.md):
:mod:`snrmon.model` (the physics), :mod:`snrmon.drivers` (devices), :mod:`snrmon.acquisition`
(the pipeline, recording, replay), :mod:`snrmon.sim` (simulated devices and scenes),
:mod:`snrmon.gui` (the console, with the ``gui`` extra) and the command line
(:mod:`snrmon.cli`).
"""

from __future__ import annotations

from pathlib import Path

__version__ = "0.1.0"

# Run from a source checkout (the repository's top folder on sys.path, as pytest and
# ``python -m snrmon`` there put it), this folder is found before the installed package, and
# the folders that install as snrmon.model, snrmon.acquisition, ... are its siblings, not its
# children: let Python look for subpackages beside it too. An installed package (wheel or
# editable link tree) has them inside and is left alone.
if not (Path(__file__).parent / "model").is_dir():  # pragma: no cover - depends on the layout
    __path__.append(str(Path(__file__).resolve().parent.parent))

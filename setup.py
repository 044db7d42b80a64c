"""The one namespace: the folders at the top of the repository install under ``snrmon``.

``acquisition/``, ``drivers/``, ``gui/``, ``sim/``, ``model/`` and ``benchmarks/`` stay where the
product was specified to have them, and install as ``snrmon.acquisition``, ``snrmon.drivers``, ...
(setuptools' package-dir mapping), so nothing generic lands in site-packages. Everything else
about the distribution is declared in ``pyproject.toml``.
"""

from setuptools import find_packages, setup

FOLDERS = {
    "snrmon": "snrmon",
    "snrmon.acquisition": "acquisition",
    "snrmon.benchmarks": "benchmarks",
    "snrmon.drivers": "drivers",
    "snrmon.gui": "gui",
    "snrmon.model": "model",
    "snrmon.sim": "sim",
}

packages = []
for package, folder in FOLDERS.items():
    packages.append(package)
    packages += [f"{package}.{sub}" for sub in find_packages(folder)]
# A folder of data files (the presets' TOML, the atmosphere table) is a package to setuptools
# too: name it.
packages += ["snrmon.model.presets", "snrmon.model.tables"]

setup(package_dir=FOLDERS, packages=packages)

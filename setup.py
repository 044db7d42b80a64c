"""The one namespace: the folders at the top of the repository install under ``snrmon``.

``acquisition/``, ``drivers/``, ``gui/``, ``sim/``, ``model/`` and ``benchmarks/`` stay where the
product was specified to have them, and install as ``snrmon.acquisition``, ``snrmon.drivers``, ...
(setuptools' package-dir mapping), so nothing generic lands in site-packages. In the checkout,
``snrmon/`` holds a symbolic link to each of those folders, so that the checkout's ``snrmon`` is
the whole namespace too (``python -m snrmon``, pytest and import-linter run from the top folder
see what is installed); the links are not packaged: each folder is packaged once, by its
mapping. Everything else about the distribution is declared in ``pyproject.toml``.
"""

from pathlib import Path

from setuptools import find_packages, setup

TABLE = Path(__file__).parent / "model" / "tables" / "lowtran7_horizontal.npz"
if not TABLE.is_file():  # data in the repository and in the sdist: a checkout without it is cut
    raise SystemExit(
        f"{TABLE.relative_to(Path(__file__).parent)} is missing from this checkout: it is data "
        "kept in git (`git checkout -- model/tables`), not built at install."
    )

FOLDERS = {
    "snrmon": "snrmon",
    "snrmon.acquisition": "acquisition",
    "snrmon.benchmarks": "benchmarks",
    "snrmon.drivers": "drivers",
    "snrmon.gui": "gui",
    "snrmon.model": "model",
    "snrmon.sim": "sim",
}

LINKED = [name.removeprefix("snrmon.") for name in FOLDERS if name != "snrmon"]
packages = []
for package, folder in FOLDERS.items():
    packages.append(package)
    # snrmon/'s links to the other folders are theirs, found by their own mapping
    skip = [*LINKED, *(f"{name}.*" for name in LINKED)] if package == "snrmon" else []
    packages += [f"{package}.{sub}" for sub in find_packages(folder, exclude=skip)]
# A folder of data files (the presets' TOML, the atmosphere table) is a package to setuptools
# too: name it.
packages += ["snrmon.model.presets", "snrmon.model.tables"]

setup(package_dir=FOLDERS, packages=packages)

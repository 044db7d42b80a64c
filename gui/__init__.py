"""The PySide6 + pyqtgraph operator console. It displays and commands; every number it shows
comes from :mod:`snrmon.acquisition` or :mod:`snrmon.model`. Only the CLI entry point imports it."""

"""The PySide6 + pyqtgraph operator console. It displays and commands; every number it shows
comes from :mod:`acquisition` or :mod:`model`. Only the CLI entry point imports it."""

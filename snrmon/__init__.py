"""snrmon: the command-line entry point only.

It parses arguments and wires the packages together (``model``, ``drivers``,
``acquisition``, ``sim``, ``gui``); it computes nothing itself. Each subcommand
lives in its own module under :mod:`snrmon.commands`.
"""

__version__ = "0.1.0"

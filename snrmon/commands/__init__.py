"""One module per ``snrmon`` subcommand; each defines ``register(subparsers)``."""

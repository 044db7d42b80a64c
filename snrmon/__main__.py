"""``python -m snrmon`` is the same as the ``snrmon`` console script."""

from snrmon.cli import main

raise SystemExit(main())

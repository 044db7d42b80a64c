"""Speed and memory measurements reported by ``snrmon bench`` (never timed assertions in tests).

Every module here named ``bench_*.py`` defines ``run(duration_s: float) -> dict``; the dict is
merged into ``snrmon bench --json`` under the module's ``KEY`` (or, with ``TOP_LEVEL = True``,
each of its keys is a top-level section).
"""

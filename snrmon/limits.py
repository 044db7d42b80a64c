"""The ranges where the work is possible and the choices the command line states, shared by the
command line's checks (:mod:`snrmon.inputs`) and the session config's
(:mod:`snrmon.acquisition.config`): a value beyond one would hang a command or ask for
terabytes. Imports nothing, so that every ``--help`` states them without loading numpy."""

MAX_FRAME_PX = 8192
"""The largest frame side (and window, box or sub-array) in pixels any command takes."""
MAX_WINDOW_FRAMES = 100_000
"""The longest running window in frames (17 minutes at 100 fps; its values are kept)."""
MAX_SEED = 2**31 - 1
"""The largest seed: each simulated device adds its index, within numpy's 2**32 - 1."""
MAX_DURATION_S = 31 * 86400.0
"""The longest duration any command runs for (a month: finite, unlike ``inf``)."""
MAX_STOP_RANGE_M = 5000.0
"""The farthest hover stop of a simulated flight, metres (the paper's is 508 m)."""
MIN_FRAMES_AT_REST = 25
"""The fewest frames of a drone at rest that ``snrmon characterize`` measures from: the
standard deviation over the frames is then known to 14 %."""
COMPRESSION_CHOICES = ("none", "lz4", "bitshuffle-lz4", "zstd", "gzip")
"""What ``--compression`` and the session config's ``compression`` take (``none``: no filter)."""
DEFAULT_COMPRESSION = "bitshuffle-lz4"
"""The frames' filter when none is asked for: of the filters that keep a day within 45 % of its
raw size, the one with the least writer CPU, and it keeps up with both cameras on a quarter of
one core (``snrmon bench --only compression``: its ``chosen``; docs/session-format.md)."""
PSF_CHOICES = ("fitted", "preset")
"""What the session config's ``model_psf`` takes: the model's corrected PSF fitted from the
flight's unresolved stops as each is final ("fitted", the default), or the sensor preset's
throughout ("preset") (:mod:`snrmon.acquisition.calibrate.flight_psf`)."""
FOOTPRINT_CHOICES = ("square", "outline")
"""What ``--footprint`` and the session config's ``footprint`` take: the model's target
as the paper's square of its small dimension ("square", the default), or the outline the close
stop measured, scaled by range ("outline") (:mod:`snrmon.model.footprint`)."""

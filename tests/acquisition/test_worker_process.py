"""The worker process at the console's exit (acquisition/worker_process.py): a job asked for
while the pool closes is dropped quietly, as the jobs the closing pool drops, and whoever asked
is told by a cancelled future, not by an exception from a pool that takes no more work."""

import subprocess
import sys
import textwrap

import pytest

# A job still queued when the script ends; its callback asks for a recomputation during the
# interpreter's exit, as a PSF fit that finishes then does (its adoption recomputes the curves).
EXIT_DURING_A_JOB = textwrap.dedent(
    """
    from snrmon.acquisition import worker_process
    from snrmon.acquisition.prediction import ModelPredictor

    p = ModelPredictor({"mwir": "mwir"}, "uav1", ranges_m=[100.0, 500.0], asynchronous=True)

    def adopt(job):
        p.set_background("mwir", 260.0)
        print(job.result(), p.pending("mwir"), p.background_temp_k["mwir"], flush=True)

    worker_process.submit(abs, -7).add_done_callback(adopt)
    """
)


@pytest.mark.slow
def test_a_recomputation_asked_for_during_the_exit_is_dropped_without_a_traceback():
    done = subprocess.run(
        [sys.executable, "-c", EXIT_DURING_A_JOB], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""
    # the job's callback ran during the exit; its recomputation was not begun (nothing left
    # "recomputing" for ever) and the asked-for input is kept as the camera's
    assert done.stdout.split() == ["7", "False", "260.0"]

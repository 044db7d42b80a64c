"""The pipeline: everything between a device's readings and the numbers the console shows. No Qt.

One subpackage per job (each says what it owns in its own docstring):

- :mod:`snrmon.acquisition.measure`: Eq. (4), the peak-pixel SNR, and its statistics (paper sections
  5-6);
- :mod:`snrmon.acquisition.track`: following the drone from the operator's click;
- :mod:`snrmon.acquisition.engine`: the ONE per-frame engine that live acquisition, the console's
  replay and batch replay all run;
- :mod:`snrmon.acquisition.runtime`: the live session: device threads, frame rings, time base;
- :mod:`snrmon.acquisition.stops`: range stops and the SNR-versus-range table;
- :mod:`snrmon.acquisition.record`: the HDF5 session file (schema, writer, recorder, reader);
- :mod:`snrmon.acquisition.replay`: recordings and frame stacks played back through the engine;
- :mod:`snrmon.acquisition.calibrate`: radiometric calibration, sky temperature, target
  characterization;
- :mod:`snrmon.acquisition.geo`: GPS geometry, pointing, GPS cues;
- :mod:`snrmon.acquisition.report`: the paper's figures and the stop table of a session.

At the top level: :mod:`snrmon.acquisition.config` (the session configuration, its one factory) and
:mod:`snrmon.acquisition.prediction` (the seam to :mod:`snrmon.model`: the model's SNR at a stop's
range), :mod:`snrmon.acquisition.stage_clock` (where a live frame's time goes, stage by stage) and
:mod:`snrmon.acquisition.worker_process` (the one process that runs the heavy work, the model's
recomputation and the PSF fit, away from the measurement threads).
"""

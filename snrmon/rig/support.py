"""Small pieces of the HIL rig (:mod:`snrmon.rig.rig`): the flight and the stop detector's rules
at a speed, and a closed recording's accounting for the run's JSON."""

from __future__ import annotations

from dataclasses import replace

from snrmon.acquisition.stops.detector import StopConfig


def flight_config_of(opts):
    """The simulated flight (:class:`snrmon.sim.flight.FlightConfig`) of the options."""
    from snrmon.sim.flight import FlightConfig

    return FlightConfig(
        stops_m=tuple(opts.stops_m),
        hover_s=opts.hover_s,
        speed_mps=opts.transit_mps,
        start_range_m=opts.start_range_m,
        seed=opts.seed,
    )


def stop_config_at(speed: float) -> StopConfig:
    """The stop detector's rules on a flight run at ``speed`` x real time: "steady for 3 s"
    means 3 s of the flight, so 3 / speed s of the host clock the detector runs on."""
    default = StopConfig()
    return replace(default, steady_s=default.steady_s / speed)


def recording_summary(summary) -> dict:
    """What a closed recording holds and lost (:class:`snrmon.acquisition.record.recorder.
    RecorderSummary`), for the run's JSON: frames written and dropped per camera, with reasons."""
    return {
        "path": summary.path,
        "state": summary.state,
        "frames_received": dict(summary.frames_received),
        "frames_written": dict(summary.frames_written),
        "dropped": {cam: dict(reasons) for cam, reasons in summary.dropped.items()},
        "error": summary.error,
        # per camera: received = written + sum(dropped) + before_recording (+ after, queued)
        "accounting": summary.extra.get("accounting"),
    }

"""One frame accounting, by the same names and with the same meaning, in every JSON that holds
one: ``snrmon hil --json`` (the day's, its recording's), the recording's ``summary_json`` and
``snrmon replay --json`` of the same recording; and in each the identity ``received = written +
sum(dropped) + before_recording + after_recording + queued + wrong_shape``."""

from __future__ import annotations

import json

from snrmon.acquisition.engine.status import ACCOUNTING_FIELDS, FrameAccounting
from snrmon.acquisition.record.reader import open_session
from snrmon.cli import main


def test_every_json_of_one_recording_holds_the_same_accounting(tmp_path, capsys):
    path = tmp_path / "s.h5"
    argv = ["hil", "--seed", "4", "--cameras", "lwir", "--stops", "37", "--hover-s", "2"]
    argv += ["--no-calibration", "--speed", "max", "--size", "256x192", "--out", str(path)]
    assert main([*argv, "--json", "--quiet"]) == 0
    hil = json.loads(capsys.readouterr().out)
    assert main(["replay", str(path), "--fast", "--json"]) == 0
    replay = json.loads(capsys.readouterr().out)["frames"]["lwir"]
    with open_session(path) as f:
        kept = f.summary["extra"]["accounting"]["lwir"]
        in_file = f.cameras["lwir"].n_frames
    every = {
        "hil --json frames": hil["frames"]["lwir"],
        "hil --json recording": hil["recording"]["accounting"]["lwir"],
        "summary_json": kept,
        "replay --json": {k: replay[k] for k in ACCOUNTING_FIELDS},
    }
    for where, acc in every.items():
        assert sorted(acc) == sorted(ACCOUNTING_FIELDS), where  # these names, no other
        assert FrameAccounting.from_record(acc).unaccounted == 0, (where, acc)
        assert acc == kept, where
    assert kept["written"] == in_file == replay["in_file"] > 0
    # The replay's own counts go by other names: no second before_recording of another meaning.
    assert set(replay) - set(ACCOUNTING_FIELDS) == {
        "in_file",
        "measured",
        "from_recorded_rows",
        "rows_before_recording",
        "compared",
        "identical",
        "first_difference_counter",
        "states_restored",
    }


def test_a_file_without_the_accounting_says_what_it_did_not_count():
    old = FrameAccounting.not_kept(5, {"recorder_backlog": 2})
    assert tuple(old) == ACCOUNTING_FIELDS
    assert old["written"] == 5 and old["dropped"] == {"recorder_backlog": 2}
    assert all(old[k] is None for k in ACCOUNTING_FIELDS if k not in ("written", "dropped"))

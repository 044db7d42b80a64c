"""Campaign re-analysis: every session of a field campaign through the same engine
as ``snrmon replay``, one task per (session, camera) on Dask distributed, into one Parquet stop
table, optional per-frame tables and one report.

- :mod:`snrmon.campaign.settings`: ``analysis.toml`` (Eq. 4 box, search, background,
  calibration per camera, model options), recorded in every output;
- :mod:`snrmon.campaign.tasks`: the per-(session, camera) task a worker runs (opens the file by
  path; returns only rows);
- :mod:`snrmon.campaign.run`: planning, submitting to a LocalCluster or an existing scheduler,
  collecting results and failures;
- :mod:`snrmon.campaign.tables`: the Parquet tables and their schema;
- :mod:`snrmon.campaign.report`: the campaign report (PDF or PNG).

See docs/campaign.md.
"""

"""A run of package jobs and its report, the same for build and test: the jobs on the
scheduler under the run's timings (`package_run.py`), `log/<run>/timings.json`,
`report.json` written at the end, and the self-contained `report.html` drawn from the run's
log directory alone (timeline, critical path, CPU use, per-package table, failures first)."""

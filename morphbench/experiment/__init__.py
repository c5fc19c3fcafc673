"""Experiments: the run loop, its records and landscape scans.

The names below are imported on first use (``morphbench.lazy``): ``records`` and ``events`` need no simulator, and
importing them (as the metrics and the report do) must not start one.
"""

from morphbench.lazy import export_lazily

export_lazily(__name__, {
    "Event": "events", "parse_event": "events", "parse_events": "events",
    "RunRecords": "records",
    "load_run_config": "config", "run_config_from_table": "config",
    "RunConfig": "run", "make_sensor": "run", "measure": "run", "run": "driver", "run_batch": "driver",
    "Motion": "scan", "motion_at": "scan", "scan": "scan", "scan_phases": "scan", "velocity_at": "scan",
})

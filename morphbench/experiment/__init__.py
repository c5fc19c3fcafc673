"""Experiments: the run loop, its records and landscape scans."""

from morphbench.experiment.config import load_run_config, run_config_from_table
from morphbench.experiment.events import Event, parse_events
from morphbench.experiment.records import RunRecords
from morphbench.experiment.run import RunConfig, make_sensor, measure, run
from morphbench.experiment.scan import Motion, motion_at, scan, scan_phases, velocity_at

__all__ = ["Event", "RunConfig", "RunRecords", "load_run_config", "parse_events", "run_config_from_table", "make_sensor", "measure", "Motion", "motion_at", "run", "scan", "scan_phases", "velocity_at"]

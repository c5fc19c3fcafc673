"""Experiments: the run loop, its records and landscape scans."""

from morphbench.experiment.records import RunRecords
from morphbench.experiment.run import RunConfig, make_sensor, measure, run
from morphbench.experiment.scan import scan, scan_phases, velocity_at

__all__ = ["RunConfig", "RunRecords", "make_sensor", "measure", "run", "scan", "scan_phases", "velocity_at"]

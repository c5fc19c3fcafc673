"""Sensing: each unit's measurement of its own motion, from its own pose only (no simulator here)."""

from morphbench.sensing.base import Sensor, forward_axes
from morphbench.sensing.ideal import IdealSensor

__all__ = ["IdealSensor", "Sensor", "forward_axes"]

"""Sensing: each unit's measurement of its own motion, from its own pose only (no simulator here)."""

from morphbench.sensing.base import Sensor, forward_axes
from morphbench.sensing.ground import GroundTexture
from morphbench.sensing.ideal import IdealSensor
from morphbench.sensing.optical import OpticalSensor

__all__ = ["GroundTexture", "IdealSensor", "OpticalSensor", "Sensor", "forward_axes"]

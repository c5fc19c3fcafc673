"""morphbench: a PyBullet testbed for robotic matter.

Data flow: shape file -> assembly in a world -> sensors -> learners -> records -> metrics and plots.
"""

__version__ = "0.1.0"

"""The colours a shape is shown in: in the simulator's view, exported scenes, drawings and videos (RGBA, 0..1)."""

UNIT_RGBA = (0.20, 0.45, 0.80, 1.0)
"""Active units."""
DUMMY_RGBA = (0.55, 0.55, 0.55, 1.0)
"""Dummies."""
BELLOWS_RGBA = (0.95, 0.50, 0.10, 1.0)
"""Actuated links: a unit's bellows."""
PASSIVE_RGBA = (0.15, 0.60, 0.30, 1.0)
"""Passive links."""

"""The colours a shape is shown in: in the simulator's view, exported scenes, drawings and videos (RGBA, 0..1), and
the colour maps of units by pressure and by phase (videos, phase maps)."""

import numpy as np

UNIT_RGBA = (0.20, 0.45, 0.80, 1.0)
"""Active units."""
DUMMY_RGBA = (0.55, 0.55, 0.55, 1.0)
"""Dummies."""
BELLOWS_RGBA = (0.95, 0.50, 0.10, 1.0)
"""Actuated links: a unit's bellows."""
PASSIVE_RGBA = (0.15, 0.60, 0.30, 1.0)
"""Passive links."""
FULL_PRESSURE_RGB = (0.90, 0.15, 0.10)
"""A unit whose bellows is at full pressure, in videos; an empty one is UNIT_RGBA, pressures between mixed
linearly."""
DAMAGED_RGBA = (0.05, 0.05, 0.05, 1.0)
"""Damaged units, in videos."""
_PHASE_SHIFTS = (0.0, 1.0 / 3.0, 2.0 / 3.0)
"""cycles, where each of red, green and blue peaks on the phase circle."""


def pressure_rgb(pressure):
    """RGB (0..1, shape (..., 3)) of units whose bellows are at ``pressure`` (0..1, clipped): blue when empty, red
    when full."""
    p = np.clip(np.asarray(pressure, dtype=float), 0.0, 1.0)[..., None]
    return (1 - p) * np.asarray(UNIT_RGBA[:3]) + p * np.asarray(FULL_PRESSURE_RGB)


def phase_rgb(phase):
    """RGB (0..1, shape (..., 3)) of phases (cycles): a colour wheel, each channel a cosine of the phase, so the map
    is cyclic (phase 0 and 1 are one colour, nearby phases nearby colours) and a travelling wave shows as bands of
    hue. Channels stay within 0.15..0.95: no phase is lost in black or white, or in the grey of the ground."""
    turns = np.mod(np.asarray(phase, dtype=float), 1.0)[..., None] - np.asarray(_PHASE_SHIFTS)
    return 0.55 + 0.40 * np.cos(2 * np.pi * turns)

"""Every random stream of morphbench: its ``numpy.random.SeedSequence`` is ``[seed, STREAM, ...]``.

Distinct ids keep the streams independent, so adding draws to one never changes another. The values are part of the
results: changing one changes every run that draws from it. One draw has no id of its own: a procedural ground
texture is ``default_rng(ground seed)`` (morphbench.sensing.ground), kept so that textures stay the same.
"""

LEARNER_STREAM = 0
"""``[run seed, 0, unit]``: unit's learner (0-based; morphbench.learning.plugins.unit_rng)."""

NOISE_STREAM = 1
"""``[run seed, 1, unit]``: unit's measurement noise (the run loop, morphbench.experiment.run)."""

SCAN_STREAM = 2
"""``[scan seed, 2]``: the random phase samples of a scan beyond 3 units (morphbench.experiment.scan)."""

FRICTION_STREAM = 3
"""``[field seed, 3]``: the wave vectors and phases of a friction field (morphbench.physics.friction)."""

SHUFFLE_STREAM = 4
"""``[shuffle seed, 4]``: the permutation of a shuffle, as a transform and as a run's event
(morphbench.shapes.transforms)."""

OPTICAL_STREAM = 5
"""``[run seed, 5]``: the optical sensors' image noise (morphbench.experiment.run.make_sensor)."""

CONTROLLER_STREAM = 6
"""``[run seed, 6]``: a centralized controller's draws (morphbench.learning.controllers.controller_rng)."""

CLOCK_STREAM = 7
"""``[run seed, 7]``: every unit's clock, its rate error then its offset, one double each per unit
(morphbench.experiment.clocks)."""

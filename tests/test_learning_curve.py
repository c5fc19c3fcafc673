"""A run's learning curve shows its events: a dashed line at the step in every panel, the event named above."""

import matplotlib.pyplot as plt
import numpy as np

from morphbench.experiment import RunConfig, run
from morphbench.experiment.events import DamageEvent
from morphbench.plots import learning_curve_figure
from morphbench.shapes import load_shape


def event_lines(ax) -> list[float]:
    return [line.get_xdata()[0] for line in ax.get_lines() if line.get_linestyle() == "--"]


def test_events_are_marked_at_their_step():
    config = RunConfig(shape=load_shape("shapes/chain-2.toml"), steps=4, seed=0,
                       events=(DamageEvent(step=3, unit=1, mode="open"),))
    records = run(config)
    fig = learning_curve_figure(records.steps(), records.units(), "chain-2")
    try:
        assert all(event_lines(ax) == [3] for ax in fig.axes)
        assert [t.get_text() for t in fig.axes[0].texts] == ["damage unit=1 mode=open"]
    finally:
        plt.close(fig)
    calm = run(RunConfig(shape=config.shape, steps=4, seed=0))
    fig = learning_curve_figure(calm.steps(), calm.units())
    try:
        assert not any(event_lines(ax) for ax in fig.axes) and not fig.axes[0].texts
        assert np.allclose(fig.axes[0].get_lines()[0].get_ydata(), calm.steps().ubar)
    finally:
        plt.close(fig)


def test_a_large_assembly_s_phases_are_one_artist():
    """Beyond LEGEND_UNITS units the kept phases are one scatter (a 10,000-unit sheet drew one line per unit)."""
    import pandas as pd

    from morphbench.plots import LEGEND_UNITS

    n, steps = 50, 4
    units = pd.DataFrame({"unit": np.repeat(np.arange(1, n + 1), steps), "step": np.tile(np.arange(steps), n),
                          "phase_kept": np.linspace(0, 1, n * steps, endpoint=False)})
    table = pd.DataFrame({"step": np.arange(steps), "ubar": 1.0, "ubar_true": 1.0, "acceptance": 0.5, "event": ""})
    fig = learning_curve_figure(table, units)
    try:
        phases = fig.axes[2]
        assert n > LEGEND_UNITS and len(phases.collections) == 1 and not phases.get_lines()
        assert len(phases.collections[0].get_offsets()) == n * steps and phases.get_legend() is None
    finally:
        plt.close(fig)

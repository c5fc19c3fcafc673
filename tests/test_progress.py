"""A suite's progress bar counts its jobs' estimated work and says so, and its time left is the mean rate since the
start: batches of seeds end together, in bursts, and a moving average of the last bursts made it jump."""

import io
from types import SimpleNamespace

from morphbench.bench.model import Job
from morphbench.bench.runner import _progress_bar


class Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def test_the_estimate_is_the_mean_rate_since_the_start(capsys):
    jobs = [Job(f"j{k}", "run", None, 10.0) for k in range(10)] + [Job("s0", "scan", None, 10.0)]
    bar = _progress_bar(SimpleNamespace(name="suite"), jobs, SimpleNamespace(describe=lambda: "pool of 2"), True)
    assert "10 runs and 1 scan parts" in capsys.readouterr().err and "of the work" in bar.bar_format
    clock = Clock()
    bar.fp, bar._time, bar.start_t, bar.last_print_t = io.StringIO(), clock, 0.0, 0.0
    shown = []
    for t, work in [(1, 10), (2, 10), (3, 10), (10, 0), (10.5, 40)]:  # a quiet spell, then a batch ends at once
        clock.now = t
        bar.update(work)
        shown.append(bar.format_meter(**bar.format_dict))
    # the mean rate: 70 of 110 done in 10.5 s, 40 left at 6.67 a second (the last bursts alone would say 1 s)
    assert "[00:10<00:06" in shown[-1] and "[00:10<00:26" in shown[-2]
    bar.close()

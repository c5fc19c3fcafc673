"""Accuracy and cost of the optical sensor (docs/sensing.md).

    python benchmarks/optical.py              # about 3 minutes on one core

Accuracy: mean |sensed - true| per-step velocity (mm/cycle) over chain-3 learning runs, at the defaults and with one
setting changed at a time (image noise, contrast, grain, frame rate). Motion the sensor cannot follow (speed, tilt,
lift-off) is measured on scripted poses: a sensor carried at a known speed, tilt or height. Cost: wall time of the
time spent inside the optical sensor during a chain-3 run, against the rest of that run's wall time.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from morphbench.experiment import RunConfig, run
from morphbench.params import EnvironmentParams, GroundParams, OpticalParams, SensorParams
from morphbench.sensing import GroundTexture, OpticalSensor
from morphbench.shapes import load_shape

CHAIN_3 = load_shape("shapes/chain-3.toml")


def run_error(steps: int, seeds: range, optical: OpticalParams = OpticalParams(),
              ground: GroundParams = GroundParams()) -> float:
    errors = []
    for seed in seeds:
        units = run(RunConfig(shape=CHAIN_3, steps=steps, seed=seed, sensor=SensorParams(optical=optical),
                              environment=EnvironmentParams(ground=ground))).units()
        errors.append((units.u_measured - units.u_true).abs().mean())
    return float(np.mean(errors))


def scripted_error(speed: float = 0.02, tilt_deg: float = 0.0, lift: float = 0.0, frames: int = 40) -> float:
    """mm per mm: |sensed - true| / true for a sensor carried forward at ``speed`` (m/s), tilted about its forward
    axis by ``tilt_deg`` and lifted by ``lift`` (m)."""
    params = OpticalParams()
    sensor = OpticalSensor(1, params, GroundTexture(GroundParams()), np.random.default_rng(0))
    half = np.radians(tilt_deg) / 2
    quaternion = np.array([[np.sin(half), 0.0, 0.0, np.cos(half)]])  # roll about the forward (x) axis
    z = params.mount_depth + lift

    def at(x):
        return np.array([[x, 0.0, z]]), quaternion

    sensor.reset(*at(0.0))
    step = speed / params.frame_rate
    for k in range(1, frames + 1):
        sensor.sample(*at(k * step))
    true = frames * step
    return float(abs(sensor.displacement()[0] - true) / true)


def main() -> None:
    print(f"# {time.strftime('%Y-%m-%d')}")
    steps, seeds = 40, range(3)
    print("\n| setting | mean abs error (mm/cycle) |\n|---|---|")
    print(f"| defaults | {run_error(steps, seeds):.3f} |")
    defaults_o, defaults_g = OpticalParams(), GroundParams()
    for label, optical, ground in (
        ("image noise 0.05", dataclasses.replace(defaults_o, noise=0.05), defaults_g),
        ("image noise 0.10", dataclasses.replace(defaults_o, noise=0.10), defaults_g),
        ("contrast 0.1", defaults_o, dataclasses.replace(defaults_g, contrast=0.1)),
        ("contrast 0.03", defaults_o, dataclasses.replace(defaults_g, contrast=0.03)),
        ("coarse grain 10 mm", defaults_o, dataclasses.replace(defaults_g, grain=0.010)),
        ("blur 1.5 px", dataclasses.replace(defaults_o, blur=1.5), defaults_g),
        ("4 frames/s", dataclasses.replace(defaults_o, frame_rate=4.0), defaults_g),
    ):
        print(f"| {label} | {run_error(steps, seeds, optical, ground):.3f} |", flush=True)
    print("\n| scripted motion | relative error of the sensed distance |\n|---|---|")
    for label, kwargs in (("20 mm/s", {}), ("40 mm/s", {"speed": 0.04}), ("60 mm/s", {"speed": 0.06}),
                          ("80 mm/s", {"speed": 0.08}), ("tilt 10 deg", {"tilt_deg": 10}),
                          ("tilt 30 deg", {"tilt_deg": 30}), ("lift 1 mm", {"lift": 0.001}),
                          ("lift 2 mm (above lift-off)", {"lift": 0.002})):
        print(f"| {label} | {scripted_error(**kwargs):.3f} |")
    print("\n| run | wall s | of which optical sensing s | added to the rest of the run |\n|---|---|---|---|")
    for steps in (100, 100):
        spent = timed_sensor()
        records = run(RunConfig(shape=CHAIN_3, steps=steps, seed=0))
        sensing = spent[0]
        print(f"| chain-3, {steps} steps | {records.wall_time:.2f} | {sensing:.2f} | "
              f"{sensing / (records.wall_time - sensing):.1%} |", flush=True)


def timed_sensor() -> list[float]:
    """Make every OpticalSensor method add its wall time to the returned counter (the machine is shared, so the
    sensor's share is measured inside one run rather than as a difference of two runs)."""
    spent = [0.0]
    for name in ("reset", "sample", "displacement"):
        method = getattr(OpticalSensor, name).__wrapped__ if hasattr(getattr(OpticalSensor, name), "__wrapped__") \
            else getattr(OpticalSensor, name)

        def timed(self, *args, _method=method):
            started = time.perf_counter()
            try:
                return _method(self, *args)
            finally:
                spent[0] += time.perf_counter() - started

        timed.__wrapped__ = method
        setattr(OpticalSensor, name, timed)
    return spent


if __name__ == "__main__":
    main()

"""Faults that must stop a run with one clear line: plug-in learners that misbehave, physics that leaves the model.

Plug-in faults go through ``morphbench run`` in-process (``conftest.run_cli``): exit 2, one line on stderr naming the
plug-in and the method, no traceback, no run directory. Physics faults are made to happen on purpose, by a world whose
poses are broken at a known time (a subclass of the quasi-static world) or by parameters no bellows has.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import sys
import textwrap

import numpy as np
import pytest

from morphbench.bench import LocalExecutor, load_suite, run_suite
from morphbench.bench import jobs as bench_jobs
from morphbench.cli import EXIT_BAD_INPUT
from morphbench.errors import ConfigError, PhysicsError, PluginError
from morphbench.experiment import RunConfig, run
from morphbench.experiment.events import CutEvent, ShuffleEvent
from morphbench.params import (
    DEFAULT_PHYSICS,
    FAST_PHYSICS,
    GRAVITY,
    MIN_FRICTION_INERTIA,
    QUASISTATIC_PHYSICS,
    EnvironmentParams,
    FrictionFieldParams,
    LearnerParams,
    SensorParams,
    friction_inertia,
)
from morphbench.physics import QuasiStaticWorld, World, make_world
from morphbench.physics.protocol import Single
from morphbench.shapes import load_shape
from morphbench.shapes.transforms import shuffle_order

from conftest import SHAPES_DIR, chain, run_cli, write_suite

run_module = importlib.import_module("morphbench.experiment.run")  # the package exports its function run by that name
driver_module = importlib.import_module("morphbench.experiment.driver")


def use_world(monkeypatch, world_class) -> None:
    """Runs build their world as ``world_class(shape, physics, environment)``, a batch of one."""
    monkeypatch.setattr(driver_module, "make_world", lambda shape, physics, environment, scene, copies: Single(
        world_class(shape, physics, environment)))
CHAIN2 = str(SHAPES_DIR / "chain-2.toml")
IDEAL = SensorParams(kind="ideal")

# --- plug-in learners -------------------------------------------------------------------------------------------

PLUGIN = '''
import math
import sys


class Faulty:
    """Behaves like a greedy learner until FAULT, a class attribute the test sets, breaks one method."""

    def __init__(self, params, rng):
        {init}
        self.rng, self.phase, self.calls = rng, float(rng.uniform()), 0

    def propose(self):
        {propose}
        return (self.phase + 0.05) % 1.0

    def update(self, velocity):
        self.calls += 1
        {update}
        return False


def recurse(n):
    return recurse(n + 1) + 1
'''

FAULTS = {
    # kind: (method named in the message, which method breaks, its code, what the message says)
    "init raises": ("__init__(params, rng)", "init", "raise RuntimeError('no hardware')", "RuntimeError: no hardware"),
    "propose raises": ("propose()", "propose", "raise ValueError('bad trial')", "ValueError: bad trial"),
    "update raises": ("update(velocity)", "update", "raise KeyError('memory')", "KeyError: 'memory'"),
    "propose returns a list": ("propose()", "propose", "return [0.1]", "got [0.1]"),
    "propose returns None": ("propose()", "propose", "return None", "got None"),
    "propose returns a string": ("propose()", "propose", "return '0.5'", "got '0.5'"),
    "propose returns a bool": ("propose()", "propose", "return True", "got True"),
    "propose returns NaN": ("propose()", "propose", "return math.nan", "got nan"),
    "propose returns inf": ("propose()", "propose", "return -math.inf", "got -inf"),
    "phase left NaN": ("phase", "update", "self.phase = math.nan", "got nan"),
    "phase left a string": ("phase", "update", "self.phase = 'front'", "got 'front'"),
    "propose recurses": ("propose()", "propose", "recurse(0)", "RecursionError"),
    "update calls sys.exit": ("update(velocity)", "update", "sys.exit(3)", "SystemExit: 3"),
    "propose raises GeneratorExit": ("propose()", "propose", "raise GeneratorExit", "GeneratorExit"),
}


def plugin_source(where: str, code: str) -> str:
    """The Faulty plug-in with ``code`` at the start of method ``where`` (init, propose or update)."""
    slots = {"init": "pass", "propose": "pass", "update": "pass", where: code}
    return textwrap.dedent(PLUGIN).format(**slots)


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    """Writes a plug-in module on sys.path (and on the workers' PYTHONPATH); returns its name. Unloaded afterwards."""
    directory = tmp_path / "plugins"
    directory.mkdir()
    monkeypatch.syspath_prepend(str(directory))
    monkeypatch.setenv("PYTHONPATH", str(directory))
    written = []

    def write(name: str, source: str) -> str:
        (directory / f"{name}.py").write_text(source)
        written.append(name)
        return name

    yield write
    for name in written:
        sys.modules.pop(name, None)


@pytest.mark.parametrize("kind", FAULTS)
def test_a_misbehaving_plugin_stops_the_run_with_one_line(kind, plugin, tmp_path, capsys):
    method, where, code, expected = FAULTS[kind]
    module = plugin(f"mb_faulty_{where}_{abs(hash(kind))}", plugin_source(where, code))
    spec = f"{module}:Faulty"
    out = tmp_path / "run"
    status, _, err = run_cli(capsys, "run", CHAIN2, "--steps", "3", "--out", str(out), "--quiet", "--learner", spec)
    assert status == EXIT_BAD_INPUT, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    line = lines[0]
    assert line.startswith(f"morphbench: error: --learner: {spec}: expected {method} of unit 1"), line
    assert expected in line, line
    assert not out.exists()  # nothing written, not even the directory


def test_the_message_tells_where_in_the_plugin_it_raised(plugin):
    module = plugin("mb_faulty_where", plugin_source("update", "raise KeyError('memory')"))
    config = RunConfig(shape=chain(2), learner=f"{module}:Faulty", steps=3, sensor=IDEAL)
    with pytest.raises(PluginError) as info:
        run(config)
    assert info.value.method == "update(velocity)"
    assert str(info.value).endswith(f"(it raised KeyError: 'memory' (in update, {module}.py:19))")


class Wrapping:
    """Proposes its kept phase + 1.25 and keeps -0.1 + step/100 after every update: finite, outside [0, 1)."""

    def __init__(self, params, rng):
        self.phase, self.steps = 0.5, 0

    def propose(self):
        return self.phase + 1.25

    def update(self, velocity):
        self.steps += 1
        self.phase = np.float32(-0.1 + self.steps / 100) if self.steps % 2 else -0.1 + self.steps / 100
        return True


def test_finite_phases_outside_the_unit_interval_are_wrapped(monkeypatch):
    monkeypatch.setattr(sys.modules[__name__], "Wrapping", Wrapping)
    config = RunConfig(shape=chain(2), learner=f"{__name__}:Wrapping", steps=3, sensor=IDEAL)
    units = run(config).units()
    unit1 = units[units.unit == 1].set_index("step")
    expected_kept = [(-0.1 + k / 100) % 1.0 for k in range(1, 5)]
    np.testing.assert_allclose(unit1.phase_kept, expected_kept, atol=1e-6)  # 0.91, 0.92, ...
    np.testing.assert_allclose(unit1.phase_tried, [0.75] + [(p + 0.25) % 1.0 for p in expected_kept[:-1]], atol=1e-6)


def test_in_a_suite_a_failing_plugin_run_is_recorded_and_the_others_go_on(plugin, tmp_path):
    module = plugin("mb_faulty_suite", plugin_source("propose", "return None"))
    suite = write_suite(tmp_path, f"""
        [[experiment]]
        name = "mixed"
        shapes = ["{CHAIN2}"]
        learners = ["thermal", "{module}:Faulty"]
        seeds = 1
        steps = 3
    """)
    outcome = run_suite(load_suite(suite), tmp_path / "out", LocalExecutor(2), progress=False)
    runs = outcome.tables["runs"].set_index("learner")
    assert (outcome.done, outcome.failed) == (1, 1)
    assert runs.loc["thermal", "status"] == "done"
    failed = runs.loc[f"{module}:Faulty"]
    assert failed.status == "failed"
    assert failed.error == (f"--learner: {module}:Faulty: expected propose() of unit 1 at learning step 0 to return "
                            "a phase as a finite number, got None")


# --- physics outside the model ---------------------------------------------------------------------------------

LP = LearnerParams()
STEP_CYCLES = LP.discard_cycles + LP.cycles_per_step
BREAK_TIME = (LP.warmup_cycles + STEP_CYCLES) * 2.0 + 0.5
"""s: just after learning step 0 (cycles of 2 s), so the fault shows at the end of learning step 1."""


class BrokenWorld(QuasiStaticWorld):
    """A quasi-static chain whose pose of ``body`` (an index, or a slice: several at once) is changed by
    ``fault(position, orientation)`` from BREAK_TIME on."""

    body: int | slice
    fault = staticmethod(lambda position, orientation: None)

    def poses(self, which=None):
        positions, orientations = super().poses()
        if self.time > BREAK_TIME:
            self.fault(positions[self.body], orientations[self.body])
        index = slice(None) if which is None else list(which)
        return positions[index], orientations[index]


def run_broken(monkeypatch, body: int | slice, fault, shape=None, steps: int = 3):
    """A short run of chain-2 (units are bodies 0 and 1, the dummy body 2) in a BrokenWorld."""
    world_class = type("Broken", (BrokenWorld,), {"body": body, "fault": staticmethod(fault)})
    use_world(monkeypatch, world_class)
    return run(RunConfig(shape=shape or chain(2), steps=steps, sensor=IDEAL, physics=QUASISTATIC_PHYSICS))


def tilt(degrees: float):
    def fault(position, orientation):
        orientation[:] = [math.sin(math.radians(degrees) / 2), 0.0, 0.0, math.cos(math.radians(degrees) / 2)]
    return fault


def lift(heights: float):
    def fault(position, orientation):
        position[..., 2] += heights * 0.030  # the unit's height
    return fault


def jump(reaches_per_cycle: float):
    """Moves the body forward once, by ``reaches_per_cycle`` bellows strokes per cycle of the step it happens in."""
    def fault(position, orientation):
        position[..., 0] += reaches_per_cycle * 0.0105 * STEP_CYCLES
    return fault


def not_finite(position, orientation):
    position[..., 1] = math.nan


@pytest.mark.parametrize("body, fault, name, what", [
    (1, not_finite, "unit 2", "has a pose that is not finite (position ["),
    (0, tilt(50), "unit 1", "tipped over (tilted 50 degrees from upright, more than 45)"),
    (2, lift(1.2), "dummy body 2", "was launched (36 mm above its rest height, more than its own height of 30 mm)"),
    (1, jump(1.5 * run_module.MAX_REACH_PER_CYCLE), "unit 2",
     f"mm/cycle over {STEP_CYCLES} cycles, faster than its bellows can push it (at most 3 x 10.5 mm per cycle"),
])
def test_each_detector_stops_the_run_at_the_step_it_fires(monkeypatch, body, fault, name, what):
    with pytest.raises(PhysicsError) as info:
        run_broken(monkeypatch, body, fault)
    message = str(info.value)
    assert message.startswith(f"test: physics left the model's validity at learning step 1: {name} "), message
    assert what in message, message
    assert "\n" not in message


@pytest.mark.parametrize("fault", [tilt(40), lift(0.8), jump(0.5 * run_module.MAX_REACH_PER_CYCLE)])
def test_below_each_bound_the_run_goes_on(monkeypatch, fault):
    """Every body at once, so that the links keep their lengths."""
    assert len(run_broken(monkeypatch, slice(None), fault).steps()) == 4


class SampleBrokenWorld(QuasiStaticWorld):
    """A quasi-static chain whose sampled pose of ``body`` in the middle of each measurement from BREAK_TIME on is
    changed by ``fault``: the poses at the checks, where the measurement ends, stay whole."""

    body: int
    fault = staticmethod(lambda position, orientation: None)

    def advance_sampled(self, n_ticks, every, on_tick=None):
        positions, orientations = super().advance_sampled(n_ticks, every, on_tick)
        if self.time > BREAK_TIME:
            middle = len(positions) // 2
            self.fault(positions[middle, self.body], orientations[middle, self.body])
        return positions, orientations


def shift(metres: float):
    def fault(position, orientation):
        position[..., 0] += metres
    return fault


@pytest.mark.parametrize("fault, name, what", [
    (tilt(60), "unit 1", "tipped over (tilted 60 degrees"),
    (lift(1.5), "unit 1", "was launched (45 mm above its rest height"),
    (shift(0.040), "link 1", "mm apart, more than the full length plus its force cap's give and 0.25 of its reach "
     "(99.79 mm): its bodies were torn apart"),  # 70 mm empty, 10.5 stroke, 5 N / 300 N/m, 2.6 mm
    (shift(-0.030), "link 1", "mm apart, less than the empty length minus its force cap's give and 0.25 of its reach "
     "(50.71 mm): its bodies were pushed into each other"),
])
def test_motion_inside_the_measured_cycles_is_checked(monkeypatch, fault, name, what):
    """Each fault lasts one sample in the middle of the window and is gone where the window ends."""
    world_class = type("Broken", (SampleBrokenWorld,), {"body": 0, "fault": staticmethod(fault)})
    use_world(monkeypatch, world_class)
    config = RunConfig(shape=chain(2), steps=3, sensor=IDEAL, physics=QUASISTATIC_PHYSICS)
    with pytest.raises(PhysicsError) as info:
        run(config)
    message = str(info.value)
    assert message.startswith(f"test: physics left the model's validity at learning step 1: {name} "), message
    assert what in message, message
    if name.startswith("link"):
        assert "(unit 1 to unit 2) held its bodies' centres " in message, message


@pytest.mark.parametrize("cut", [False, True])
def test_a_cut_link_lets_its_bodies_part(monkeypatch, cut):
    """Unit 1 moved 40 mm away from unit 2 (13 mm/cycle over the step, under the speed bound) tears link 1, unless
    that link was cut."""
    world_class = type("Broken", (BrokenWorld,), {"body": 0, "fault": staticmethod(shift(0.040))})
    use_world(monkeypatch, world_class)
    config = RunConfig(shape=chain(3), steps=3, sensor=IDEAL, physics=QUASISTATIC_PHYSICS,
                       events=(CutEvent(step=1, link=1),) if cut else ())
    if cut:
        assert len(run(config).steps()) == 4
    else:
        with pytest.raises(PhysicsError, match="at learning step 1: link 1 .* torn apart"):
            run(config)


def test_the_issues_exploding_chain_is_caught():
    """30 units with 5 cm strokes and bellows of 1e7 N/m: PyBullet's explicit springs chatter at their force cap and
    the chain buckles while its units' net displacement stays under the speed bound (issue 21)."""
    shape = chain(30, actuator={"stiffness": 1e7, "stroke": 0.05})
    issue = LearnerParams(discard_cycles=1)  # the protocol the issue ran: its window shows the buckled links first
    with pytest.raises(PhysicsError, match=r"at learning step 0: link \d+ \(unit \d+ to unit \d+\) held its bodies"):
        run(RunConfig(shape=shape, steps=2, sensor=IDEAL, physics=FAST_PHYSICS, learner_params=issue))


@pytest.mark.parametrize("name", ["chain-2", "chain-3", "chain-20", "grid-2x2"])
@pytest.mark.parametrize("physics", [DEFAULT_PHYSICS, FAST_PHYSICS], ids=["default", "fast"])
def test_healthy_library_shapes_stay_valid(name, physics):
    assert len(run(RunConfig(shape=load_shape(SHAPES_DIR / f"{name}.toml"), steps=3, sensor=IDEAL,
                             physics=physics)).steps()) == 4


def test_a_shuffled_unit_is_named_by_its_own_number(monkeypatch):
    """Seed 1 swaps chain-2's units at step 1, so the front body (0) is then unit 2."""
    shape = chain(2)
    assert list(shuffle_order(2, 1)) == [1, 0]
    config = RunConfig(shape=shape, steps=3, sensor=IDEAL, physics=QUASISTATIC_PHYSICS,
                       events=(ShuffleEvent(step=1, seed=1),))
    world_class = type("Broken", (BrokenWorld,), {"body": 0, "fault": staticmethod(tilt(60))})
    use_world(monkeypatch, world_class)
    with pytest.raises(PhysicsError, match="at learning step 1: unit 2 tipped over"):
        run(config)


def huge(shape, **actuator):
    """``shape`` with actuator values no file would pass (set past the parameters' validation)."""
    return dataclasses.replace(shape, actuator=dataclasses.replace(shape.actuator, **actuator))


RUNAWAY = {"stroke": 1000.0, "tau_inflate": 100.0, "tau_vent": 100.0}
"""A bellows of 1 km that the quasi-static model takes (slow enough to keep friction 56 times its inertial force): it
pushes its bodies metres per cycle."""


def with_unit_mass(shape, mass):
    return dataclasses.replace(shape, bodies=tuple(dataclasses.replace(b, mass=mass) if not b.dummy else b
                                                   for b in shape.bodies))


@pytest.mark.parametrize("shape, physics, what", [
    (huge(chain(2), **RUNAWAY), QUASISTATIC_PHYSICS, "faster than its bellows can push it"),
    (huge(chain(2), stroke=1e300), FAST_PHYSICS, "tipped over"),
    (with_unit_mass(chain(2), 1e-6), FAST_PHYSICS, "tipped over"),
    (huge(chain(2), damping=1e300), FAST_PHYSICS, "faster than its bellows can push it"),
], ids=["stroke-quasistatic", "stroke-pybullet", "mass-pybullet", "damping-pybullet"])
def test_the_issues_blow_ups_are_caught(shape, physics, what):
    with pytest.raises(PhysicsError) as info:
        run(RunConfig(shape=shape, steps=5, sensor=IDEAL, physics=physics))
    assert what in str(info.value)


def test_morphbench_run_exits_2_with_the_line_and_writes_nothing(monkeypatch, tmp_path, capsys):
    world_class = type("Broken", (BrokenWorld,), {"body": 0, "fault": staticmethod(tilt(80))})
    use_world(monkeypatch, world_class)
    out = tmp_path / "run"
    status, _, err = run_cli(capsys, "run", CHAIN2, "--steps", "3", "--out", str(out), "--quiet", "--physics",
                             "quasistatic", "--sensor", "ideal")
    assert status == EXIT_BAD_INPUT
    assert err.strip().splitlines() == [f"morphbench: error: {CHAIN2}: physics left the model's validity at learning "
                                        "step 1: unit 1 tipped over (tilted 80 degrees from upright, more than 45)"]
    assert not out.exists()


def test_in_a_suite_a_blown_up_run_is_recorded_as_failed(tmp_path):
    suite = write_suite(tmp_path, f"""
        [[experiment]]
        name = "one"
        shapes = ["{CHAIN2}"]
        learners = ["thermal"]
        seeds = 1
        steps = 3
    """)
    job = load_suite(suite).jobs()[0]
    config = job.payload
    broken = dataclasses.replace(job, payload=dataclasses.replace(
        config, shape=huge(config.shape, **RUNAWAY), physics=QUASISTATIC_PHYSICS))
    result = bench_jobs.execute(broken)
    assert result["status"] == "failed"
    assert result["error"].startswith(f"{CHAIN2}: physics left the model's validity at learning step 0: unit 1 moved")
    assert "Traceback" in result["traceback"]
    assert bench_jobs.execute(job)["status"] == "done"


def test_an_absurd_stroke_is_refused_on_the_quasi_static_backend_before_simulating():
    with pytest.raises(ConfigError, match=r"friction_scale >= 2e\+301 .* stroke 1e\+300 m"):
        RunConfig(shape=huge(chain(2), stroke=1e300), physics=QUASISTATIC_PHYSICS)


# --- the quasi-static model's range: friction against inertia -----------------------------------------------------

CHAIN3 = str(SHAPES_DIR / "chain-3.toml")
CHAIN3_LOWEST = MIN_FRICTION_INERTIA / friction_inertia(chain(3), EnvironmentParams())[0]
"""the lowest friction scale the quasi-static model takes for chain-3 (0.216)."""


def test_friction_against_inertia_follows_its_formula():
    """mu g tau^2 / stroke with mu the mass-weighted mean friction (chain-2: units 0.5, dummy 0.7, 50 g each)."""
    shape, environment = chain(2), EnvironmentParams()
    ratio, mu, tau, stroke = friction_inertia(shape, environment)
    assert (mu, tau, stroke) == (pytest.approx(1.7 / 3), 0.3, 0.0105)
    assert ratio == pytest.approx(1.7 / 3 * GRAVITY * 0.09 / 0.0105)  # 47.6
    assert friction_inertia(shape, environment, 0.5)[0] == pytest.approx(ratio / 2)
    assert friction_inertia(shape, EnvironmentParams(vibration=0.8))[0] == pytest.approx(0.8 * ratio)
    assert friction_inertia(shape, EnvironmentParams(vibration=1.5))[0] == pytest.approx(ratio)  # never raised
    field = EnvironmentParams(friction_field=FrictionFieldParams(amplitude=0.4))
    assert friction_inertia(shape, field)[0] == pytest.approx(0.6 * ratio)  # the field's troughs
    slow = huge(shape, tau_inflate=0.6)  # the faster time constant counts
    assert friction_inertia(slow, environment)[0] == pytest.approx(ratio)
    assert friction_inertia(huge(shape, tau_vent=0.15), environment)[0] == pytest.approx(ratio / 4)
    assert friction_inertia(huge(shape, stroke=0.021), environment)[0] == pytest.approx(ratio / 2)
    mean = (2 * 0.2 * 0.5 + 0.05 * 0.7) / 0.45  # heavier units weigh more in the mean, not in the ratio
    assert friction_inertia(with_unit_mass(shape, 0.2), environment)[0] == pytest.approx(ratio * mean / (1.7 / 3))
    assert CHAIN3_LOWEST == pytest.approx(0.2162, abs=1e-4)


@pytest.mark.parametrize("scale", [1e-6, 0.2])
def test_a_quasistatic_run_below_the_range_is_refused_before_simulating(scale):
    environment = EnvironmentParams(friction_scale=scale)
    with pytest.raises(ConfigError) as info:
        RunConfig(shape=chain(3), environment=environment, physics=QUASISTATIC_PHYSICS)
    message = str(info.value)
    assert message.startswith("test: environment.friction_scale: expected a friction_scale >= 0.216 on the "
                              "quasi-static physics, which holds only while friction is at least 10 times the bellows' "
                              "inertial force (mu g tau^2 / stroke = "), message
    assert message.endswith(f"use the PyBullet physics (--physics fast or reference), got {scale!r}"), message
    RunConfig(shape=chain(3), environment=environment, physics=FAST_PHYSICS)  # PyBullet takes it
    RunConfig(shape=chain(3), environment=EnvironmentParams(friction_scale=0.22), physics=QUASISTATIC_PHYSICS)


def test_auto_refuses_rather_than_switch_and_keeps_pybullet_for_stacks():
    """A RunConfig on 'auto' is built (the command line may still choose its physics), then its world is refused
    where 'auto' picks the quasi-static model; a stack, which 'auto' puts on PyBullet anyway, is not refused."""
    environment = EnvironmentParams(friction_scale=1e-6)
    config = RunConfig(shape=chain(3), environment=environment, steps=1, sensor=IDEAL)
    with pytest.raises(ConfigError, match="environment.friction_scale: expected a friction_scale >= 0.216"):
        run(config)
    with make_world(load_shape(SHAPES_DIR / "stack-2x2x2.toml"), DEFAULT_PHYSICS, environment) as world:
        assert isinstance(world, World)
    with pytest.raises(ConfigError, match="environment.friction_scale"):
        make_world(chain(3), QUASISTATIC_PHYSICS, environment)  # scans build their worlds here too


def run_file(tmp_path, text: str) -> str:
    path = tmp_path / "low.toml"
    path.write_text(f'shape = "{CHAIN3}"\nsteps = 3\n' + textwrap.dedent(text))
    return str(path)


def test_morphbench_run_below_the_range_exits_2_unless_on_pybullet(tmp_path, capsys):
    path = run_file(tmp_path, "[environment]\nfriction_scale = 1e-6\n")
    for physics in ([], ["--physics", "quasistatic"]):
        status, _, err = run_cli(capsys, "run", path, "--out", str(tmp_path / "qs"), "--quiet", "--sensor", "ideal",
                                 *physics)
        assert status == EXIT_BAD_INPUT
        lines = err.strip().splitlines()
        # auto finds the shape outside the range where it builds the world, so it names the shape file, whose bellows
        # (tau, stroke) are the other half of the rule; an explicit quasi-static backend is refused with the run file
        source = CHAIN3 if not physics else path
        assert len(lines) == 1 and lines[0].startswith(
            f"morphbench: error: {source}: environment.friction_scale: expected a friction_scale >= 0.216 "), err
        assert not (tmp_path / "qs").exists()
    status, out, err = run_cli(capsys, "run", path, "--out", str(tmp_path / "fast"), "--quiet", "--sensor", "ideal",
                               "--physics", "fast")
    assert status == 0, err
    assert (tmp_path / "fast" / "steps.parquet").exists()


def test_a_friction_event_below_the_range_stops_a_quasistatic_run_at_its_step(tmp_path, capsys):
    path = run_file(tmp_path, "[[events]]\nstep = 2\nkind = \"friction\"\nscale = 1e-300\n")
    status, _, err = run_cli(capsys, "run", path, "--out", str(tmp_path / "qs"), "--quiet", "--sensor", "ideal")
    assert status == EXIT_BAD_INPUT
    assert err.strip().splitlines() == [
        f"morphbench: error: {CHAIN3}: physics left the model's validity at learning step 2: a friction event (scale "
        "1e-300) takes friction outside the quasi-static model's range: expected a friction_scale >= 0.216 on the "
        "quasi-static physics, which holds only while friction is at least 10 times the bellows' inertial force (mu g "
        "tau^2 / stroke = 4.62e-299 with mu 5.5e-301, tau 0.3 s, stroke 0.0105 m; docs/fidelity.md): use the PyBullet "
        "physics (--physics fast or reference)"]
    status, _, err = run_cli(capsys, "run", path, "--out", str(tmp_path / "fast"), "--quiet", "--sensor", "ideal",
                             "--physics", "fast")
    assert status == 0, err


def test_in_a_suite_a_friction_event_below_the_range_fails_the_quasistatic_runs_only(tmp_path):
    """Two seeds on the default physics (run as one batch on the quasi-static model) fail at the event; the same
    seeds on PyBullet finish."""
    suite = write_suite(tmp_path, f"""
        [[experiment]]
        name = "slippery"
        shapes = ["{CHAIN3}"]
        physics = ["default", "fast"]
        seeds = 2
        steps = 3
        [[experiment.events]]
        step = 2
        kind = "friction"
        scale = 0.1
    """)
    outcome = run_suite(load_suite(suite), tmp_path / "out", LocalExecutor(2), progress=False)
    assert (outcome.done, outcome.failed) == (2, 2)
    runs = outcome.tables["runs"]
    failed = runs[runs.status == "failed"]
    assert set(failed.physics) == {"default"}
    expected = (f"{CHAIN3}: physics left the model's validity at learning step 2: a friction event (scale 0.1) takes "
                "friction outside the quasi-static model's range")
    assert all(error.startswith(expected) for error in failed.error), list(failed.error)

"""The per-unit learners: Metropolis decisions on scripted draws, memory rules, streams and plug-in loading."""

from __future__ import annotations

import inspect
import math
import sys
import textwrap

import numpy as np
import pytest

from morphbench.errors import ConfigError
from morphbench.learning import (
    LEARNERS,
    FlakyLearner,
    Learner,
    RandomLearner,
    ThermalLearner,
    load_learner_class,
    make_learners,
    unit_rng,
)
from morphbench.learning import plugins
from morphbench.learning.metropolis import MetropolisLearner
from morphbench.params import LearnerParams, check_learner, learner_defaults

from conftest import SHAPES_DIR

# any RuntimeWarning (exp overflow, -inf arithmetic, division by zero) is a bug here
pytestmark = pytest.mark.filterwarnings("error")

BOTH = pytest.mark.parametrize("cls", [ThermalLearner, FlakyLearner])


class ScriptedRng:
    """Stands in for a Generator: ``uniform`` returns the scripted values in order and checks they fit its range."""

    def __init__(self, *values: float):
        self.values = list(values)
        self.calls: list[tuple[float, float]] = []

    def uniform(self, low: float = 0.0, high: float = 1.0) -> float:
        assert self.values, "the learner drew more random numbers than scripted"
        value = self.values.pop(0)
        assert low <= value <= high, f"scripted {value} outside the requested range [{low}, {high}]"
        self.calls.append((low, high))
        return value


def learner(cls, *draws, **params):
    """A learner on scripted draws: the first draw is its initial phase."""
    return cls(LearnerParams(**params), ScriptedRng(*draws))


def step(unit, velocity):
    """One learning step against a fixed measurement: (proposed phase, accepted)."""
    return unit.propose(), unit.update(velocity)


def circular_distance(a, b):
    d = abs(a - b) % 1.0
    return min(d, 1.0 - d)


# --- Metropolis decisions on fixed draws ------------------------------------------------------------------------


@BOTH
def test_better_or_equal_trial_is_accepted_without_a_draw(cls):
    unit = learner(cls, 0.5, 0.5, -0.2)  # phase, eps, eps: no acceptance draw scripted
    assert step(unit, 1.0) == (0.5, True)  # 'measure': the initial phase itself
    trial, accepted = step(unit, 2.0)
    assert trial == pytest.approx(0.55) and accepted
    assert unit.phase == pytest.approx(0.55) and unit.memory == 2.0
    trial, accepted = step(unit, 2.0)  # equal: exp(0) = 1
    assert trial == pytest.approx(0.53) and accepted
    assert unit.phase == pytest.approx(0.53)
    assert unit.rng.calls == [(0.0, 1.0), (-1.0, 1.0), (-1.0, 1.0)]


@pytest.mark.parametrize(
    "cls, draw, accepted, memory",
    [
        (ThermalLearner, 0.60, True, 2.9),  # exp(-0.1 / 0.2) = 0.6065
        (ThermalLearner, 0.61, False, 3.0),  # rejected: keeps the last accepted measurement
        (FlakyLearner, 0.60, True, 2.9),
        (FlakyLearner, 0.61, False, 2.9),  # rejected, but remembers what it measured
    ],
)
def test_worse_trial_is_accepted_iff_draw_below_boltzmann_factor(cls, draw, accepted, memory):
    unit = learner(cls, 0.5, 1.0, draw, temperature=0.2)
    step(unit, 3.0)
    trial, result = step(unit, 2.9)
    assert trial == pytest.approx(0.6) and result is accepted
    assert unit.phase == pytest.approx(0.6 if accepted else 0.5)
    assert unit.memory == memory
    assert unit.rng.calls[-1] == (0.0, 1.0) and not unit.rng.values


@pytest.mark.parametrize(
    "phase, eps, expected",
    [(0.95, 1.0, 0.05), (0.02, -0.5, 0.97), (0.999, 0.01, 0.0), (0.0, -1e-17, 0.0)],  # last: -1e-18 % 1.0 == 1.0
)
def test_trial_phase_wraps_modulo_one(phase, eps, expected):
    unit = learner(ThermalLearner, phase, eps, initial_memory="-inf")
    trial, accepted = step(unit, 0.0)
    assert 0.0 <= trial < 1.0 and accepted
    assert trial == pytest.approx(expected, abs=1e-12)
    assert unit.phase == trial


def test_memory_rule_makes_thermal_and_flaky_decide_differently():
    # a rejected worse trial leaves Thermal remembering 4.0 and Flaky 1.0; the next trial (2.0) lies between them
    script = (0.5, 0.5, 0.99, -0.5, 0.5)  # phase, eps, draw (reject), eps, draw (only Thermal needs it)
    thermal, flaky = learner(ThermalLearner, *script), learner(FlakyLearner, *script)
    for unit in (thermal, flaky):
        step(unit, 4.0)
        assert step(unit, 1.0)[1] is False
        assert unit.phase == 0.5
    assert (thermal.memory, flaky.memory) == (4.0, 1.0)
    assert step(thermal, 2.0) == (pytest.approx(0.45), False)
    assert step(flaky, 2.0) == (pytest.approx(0.45), True)
    assert (thermal.phase, thermal.memory) == (0.5, 4.0)
    assert flaky.phase == pytest.approx(0.45) and flaky.memory == 2.0
    assert thermal.rng.values == [] and flaky.rng.values == [0.5]  # Flaky accepted without drawing


def test_thermal_and_flaky_share_the_metropolis_step():
    for cls in (ThermalLearner, FlakyLearner):
        assert issubclass(cls, MetropolisLearner) and issubclass(cls, Learner)
        assert "propose" not in vars(cls) and "update" not in vars(cls)


# --- temperature edge cases ---------------------------------------------------------------------------------------


@BOTH
def test_zero_temperature_is_greedy(cls):
    unit = learner(cls, 0.5, 0.5, 0.0, 0.5, temperature=0.0)
    step(unit, 1.0)
    assert step(unit, 0.999)[1] is False  # even a draw of 0 is not below probability 0
    assert step(unit, 1.0 if cls is ThermalLearner else 0.999)[1] is True  # equal to memory: no draw, accepted
    assert not unit.rng.values


@BOTH
def test_infinite_temperature_accepts_everything(cls):
    unit = learner(cls, 0.5, 0.5, 0.999, temperature=math.inf)
    step(unit, 1.0)
    assert step(unit, -1e6)[1] is True


@BOTH
def test_huge_drop_at_tiny_temperature_is_rejected_without_warnings(cls):
    unit = learner(cls, 0.5, 0.5, 0.0, temperature=1e-300)
    step(unit, 1e6)
    assert step(unit, -1e6)[1] is False


# --- initial memory -----------------------------------------------------------------------------------------------


@BOTH
def test_initial_memory_measure(cls):
    unit = learner(cls, 0.3, initial_memory="measure")
    assert unit.memory is None and unit.phase == 0.3
    assert unit.propose() == 0.3  # no eps drawn for the first step
    assert unit.update(-7.0) is True
    assert unit.memory == -7.0 and unit.phase == 0.3
    assert unit.rng.calls == [(0.0, 1.0)]


@BOTH
def test_initial_memory_minus_inf_accepts_the_first_trial_without_a_draw(cls):
    unit = learner(cls, 0.3, 0.5, initial_memory="-inf")
    assert unit.memory == -math.inf
    trial, accepted = step(unit, -1e9)
    assert trial == pytest.approx(0.35) and accepted
    assert unit.phase == pytest.approx(0.35) and unit.memory == -1e9


@BOTH
def test_initial_memory_zero(cls):
    unit = learner(cls, 0.3, 0.5, 0.99, initial_memory="zero", temperature=0.2)
    assert unit.memory == 0.0
    trial, accepted = step(unit, -1.0)  # worse than 0: needs a draw, 0.99 > exp(-5)
    assert trial == pytest.approx(0.35) and not accepted
    assert unit.phase == 0.3
    assert unit.memory == (0.0 if cls is ThermalLearner else -1.0)


@pytest.mark.parametrize(
    "field, value",
    [("initial_memory", "first"), ("temperature", -0.1), ("temperature", math.nan), ("step_size", -0.1)],
)
def test_bad_learner_params_raise_config_error(field, value):
    with pytest.raises(ConfigError, match=field):
        ThermalLearner(LearnerParams(**{field: value}), unit_rng(0, 0))


def test_protocol_misuse_is_reported():
    unit = ThermalLearner(LearnerParams(), unit_rng(0, 0))
    with pytest.raises(RuntimeError):
        unit.update(1.0)
    unit.propose()
    with pytest.raises(RuntimeError):
        unit.propose()
    with pytest.raises(ValueError):
        unit.update(math.nan)


# --- random streams: per unit, reproducible, independent ----------------------------------------------------------


def proposals(units, landscapes, steps=30):
    """Run every unit on its own landscape; the proposals of each unit."""
    out = [[] for _ in units]
    for _ in range(steps):
        for i, (unit, landscape) in enumerate(zip(units, landscapes)):
            phase = unit.propose()
            out[i].append(phase)
            unit.update(landscape(phase))
    return out


def hill(phase):
    return 5 * math.cos(2 * math.pi * (phase - 0.3))


def test_unit_rng_is_stream_zero_of_the_run_seed():
    expected = np.random.default_rng(np.random.SeedSequence([7, 0, 2])).random(5)
    assert np.array_equal(unit_rng(7, 2).random(5), expected)
    assert not np.array_equal(unit_rng(7, 2).random(5), unit_rng(7, 3).random(5))


def test_a_unit_cannot_see_another_units_data():
    params = LearnerParams()
    a = make_learners(ThermalLearner, params, seed=7, n_units=3)
    b = make_learners(ThermalLearner, params, seed=7, n_units=3)
    flat = lambda phase: 0.0  # noqa: E731
    pa = proposals(a, [hill, hill, hill])
    pb = proposals(b, [hill, lambda phase: -hill(phase), flat])  # units 1 and 2 see other worlds
    assert pa[0] == pb[0]  # unit 0 is unaffected
    assert pa[1] != pb[1]  # and the measurements fed to unit 1 did matter
    alone = make_learners(ThermalLearner, params, seed=7, n_units=1)
    assert proposals(alone, [hill])[0] == pa[0]  # nor does the number of other units
    assert len({id(unit.rng) for unit in a}) == 3


def test_the_learner_api_gives_no_access_to_other_units():
    assert list(inspect.signature(Learner.__init__).parameters) == ["self", "params", "rng"]
    assert list(inspect.signature(Learner.propose).parameters) == ["self"]
    assert list(inspect.signature(Learner.update).parameters) == ["self", "velocity"]
    units = make_learners(FlakyLearner, LearnerParams(), seed=1, n_units=2)
    proposals(units, [hill, hill], steps=3)
    others = {id(units[1]), id(units[1].rng)}
    assert not any(id(value) in others for value in vars(units[0]).values())


@pytest.mark.parametrize("cls", [ThermalLearner, FlakyLearner])
def test_same_seed_same_proposals_different_seed_different(cls):
    run = lambda seed: proposals(make_learners(cls, LearnerParams(), seed, 2), [hill, hill])  # noqa: E731
    assert run(3) == run(3)
    assert run(3) != run(4)


# --- plug-ins -----------------------------------------------------------------------------------------------------


@pytest.fixture
def plugin_module(tmp_path, monkeypatch):
    """Writes a module into a directory on sys.path; returns its name. Written modules are unloaded afterwards."""
    monkeypatch.syspath_prepend(str(tmp_path))
    written = []

    def write(name, source):
        (tmp_path / f"{name}.py").write_text(textwrap.dedent(source))
        written.append(name)
        return name

    yield write
    for name in written:
        sys.modules.pop(name, None)


def docstring_example():
    """The example plug-in of the plugins module docstring, as source code."""
    lines = plugins.__doc__.splitlines()
    start = next(i for i, line in enumerate(lines) if "# my_learners.py" in line)
    block = []
    for line in lines[start:]:
        if line.strip() and not line.startswith("    "):
            break
        block.append(line)
    return textwrap.dedent("\n".join(block))


@pytest.mark.parametrize("spec, cls", [("thermal", ThermalLearner), ("FLAKY", FlakyLearner),
                                       (" Thermal ", ThermalLearner), ("random", RandomLearner)])
def test_builtin_learners_by_name(spec, cls):
    assert load_learner_class(spec) is cls


def test_documented_plugin_example_loads_and_runs(plugin_module):
    name = plugin_module("mb_doc_example", docstring_example())
    cls = load_learner_class(f"{name}:Greedy")
    assert not issubclass(cls, Learner)
    units = make_learners(cls, LearnerParams(), seed=5, n_units=2)
    proposals(units, [hill, hill], steps=200)
    assert all(circular_distance(unit.phase, 0.3) < 0.05 for unit in units)  # greedy climbs the hill


def test_plugin_subclassing_learner(plugin_module):
    name = plugin_module(
        "mb_fixed",
        """
        from morphbench.learning import Learner

        class Fixed(Learner):
            def propose(self):
                return self.phase

            def update(self, velocity):
                return False
        """,
    )
    cls = load_learner_class(f"{name}:Fixed")
    units = make_learners(cls, LearnerParams(), seed=0, n_units=2)
    assert [unit.phase for unit in units] == [unit_rng(0, i).uniform(0.0, 1.0) for i in range(2)]


BAD_MODULES = {
    "mb_raises": "raise RuntimeError('boom at import')",
    "mb_exits": "import sys\nsys.exit(3)",
    "mb_broken_import": "import mb_no_such_dependency",
    "mb_syntax": "class Broken(:\n    pass",
    "mb_shapes": """
        import math
        NOT_A_CLASS = 3

        def function(params, rng):
            pass

        class NoUpdate:
            def __init__(self, params, rng):
                self.phase = 0.0
            def propose(self):
                return 0.0

        class UpdateNotCallable:
            update = 3
            def __init__(self, params, rng):
                self.phase = 0.0
            def propose(self):
                return 0.0

        class WrongSignature:
            def __init__(self, params):
                self.phase = 0.0
            def propose(self):
                return 0.0
            def update(self, velocity):
                return True
        """,
    "mb_abstract": """
        from morphbench.learning import Learner

        class HalfDone(Learner):
            def propose(self):
                return self.phase
        """,
}


@pytest.mark.parametrize(
    "spec, expected",
    [
        ("metropolis", "'thermal', 'flaky', 'averaged', 'adaptive', 'sparse' or 'random'"),
        ("mb_shapes", "package.module:ClassName"),  # no colon
        ("mb_shapes:", "package.module:ClassName"),
        (":NoUpdate", "package.module:ClassName"),
        ("mb shapes:NoUpdate", "package.module:ClassName"),
        ("mb_shapes:No.Update", "package.module:ClassName"),
        ("mb_missing_module:Cls", "an importable module 'mb_missing_module'"),
        ("mb_shapes.sub:Cls", "an importable module 'mb_shapes.sub'"),
        ("mb_raises:Cls", "to import cleanly (it raised RuntimeError: boom at import)"),
        ("mb_exits:Cls", "to import cleanly (it raised SystemExit"),
        ("mb_broken_import:Cls", "to import cleanly (it raised ModuleNotFoundError"),
        ("mb_syntax:Broken", "to import cleanly (it raised SyntaxError"),
        ("mb_shapes:Missing", "to define a class 'Missing'"),
        ("mb_shapes:NOT_A_CLASS", "'NOT_A_CLASS' to be a class (it is a int)"),
        ("mb_shapes:function", "'function' to be a class"),
        ("mb_shapes:NoUpdate", "(missing: update)"),
        ("mb_shapes:UpdateNotCallable", "(missing: update)"),
        ("mb_shapes:WrongSignature", "constructible as WrongSignature(params, rng)"),
        ("mb_abstract:HalfDone", "a concrete class ('HalfDone' leaves abstract: update)"),
    ],
)
def test_bad_learner_specs_raise_config_error(plugin_module, spec, expected):
    for name, source in BAD_MODULES.items():
        plugin_module(name, source)
    with pytest.raises(ConfigError) as info:
        load_learner_class(spec)
    message = str(info.value)
    assert message.startswith(f"--learner: {spec}: expected")
    assert expected in message


@pytest.mark.parametrize(
    "module, body, expected",
    [
        ("mb_ctor_raises", "raise ValueError('no hardware')", "constructing it raised ValueError: no hardware"),
        ("mb_ctor_no_phase", "pass", "instances to expose 'phase'"),
        ("mb_ctor_phase_one", "self.phase = 1.0", "got 1.0"),
        ("mb_ctor_phase_text", "self.phase = 'front'", "got 'front'"),
    ],
)
def test_plugin_failing_at_construction_raises_config_error(plugin_module, module, body, expected):
    name = plugin_module(
        module,
        f"""
        class Bad:
            def __init__(self, params, rng):
                {body}
            def propose(self):
                return 0.0
            def update(self, velocity):
                return True
        """,
    )
    cls = load_learner_class(f"{name}:Bad")
    with pytest.raises(ConfigError) as info:
        make_learners(cls, LearnerParams(), seed=0, n_units=2)
    message = str(info.value)
    assert message.startswith(f"--learner: {name}:Bad: expected")
    assert expected in message


# --- statistics ---------------------------------------------------------------------------------------------------


def test_thermal_learner_climbs_a_noiseless_hill():
    params = LearnerParams(temperature=0.2)
    final = []
    for seed in range(20):
        unit = ThermalLearner(params, unit_rng(seed, 0))
        for _ in range(200):
            unit.update(hill(unit.propose()))
        final.append(circular_distance(unit.phase, 0.3))
    # at T = 0.2 the stationary spread around the peak is about 0.03, so a few seeds may sit just outside 0.05
    assert sum(d < 0.05 for d in final) >= 14
    assert max(final) < 0.1


def test_the_random_baseline_runs_a_fresh_uniform_phase_every_step_and_keeps_it():
    learner = LEARNERS["random"](LearnerParams(), np.random.default_rng(5))
    tried = []
    for velocity in np.linspace(-5, 5, 2000):
        tried.append(learner.propose())
        assert learner.update(float(velocity)) is True and learner.phase == tried[-1]
    tried = np.array(tried)
    assert tried.min() >= 0 and tried.max() < 1
    assert np.histogram(tried, bins=10, range=(0, 1))[0].min() > 150  # about 200 per tenth
    first, second = (LEARNERS["random"](LearnerParams(), np.random.default_rng(9)) for _ in range(2))
    assert [first.propose() for _ in range(5)] == [second.propose() for _ in range(5)]  # its own stream only


def test_thermal_beats_random_phase_changes_on_a_chain():
    from morphbench.experiment import RunConfig, run
    from morphbench.params import QUASISTATIC_PHYSICS, SensorParams
    from morphbench.shapes import load_shape

    shape = load_shape(SHAPES_DIR / "chain-2.toml")

    def final(learner):
        return np.mean([run(RunConfig(shape=shape, learner=learner, physics=QUASISTATIC_PHYSICS, steps=60, seed=seed,
                                      sensor=SensorParams(kind="ideal"))).summary()["final_ubar_true"]
                        for seed in range(4)])

    thermal, random = final("thermal"), final("random")
    assert thermal > 2.0 and thermal > random + 1.5


@pytest.mark.parametrize("name", ["thermal", "flaky", "averaged", "adaptive", "sparse", "random"])
@pytest.mark.parametrize("initial_memory, temperature", [("measure", 0.5), ("-inf", 0.0), ("zero", math.inf),
                                                         ("measure", 3.0)])
def test_the_arrays_of_a_built_in_learner_step_as_its_objects(name, initial_memory, temperature):
    """make_controller steps every per-unit built-in as arrays over the units (learning/arrays.py): the same
    proposals, acceptances, kept phases and memories as one learner object per unit, step by step, dead units
    included, for every initial memory and temperature; more steps than a block of draws."""
    from morphbench.learning.arrays import BLOCK, UnitArrays
    from morphbench.learning.plugins import Decentralized, make_controller, make_learners

    params = LearnerParams(initial_memory=initial_memory, temperature=temperature, step_size=0.3,
                           trial_probability=0.9, trial_decay_steps=30)  # sparse's own step counts, dead units'
    cls, n = load_learner_class(name), 5
    arrays, objects = make_controller(cls, params, 7, n), Decentralized(make_learners(cls, params, 7, n))
    assert isinstance(arrays, UnitArrays)
    rng = np.random.default_rng(1)
    assert np.array_equal(arrays.initial(), objects.initial())
    for step in range(3 * BLOCK):
        alive = np.arange(n) != (step // 40)  # unit 0, then 1, then 2 dies for a while
        tried = arrays.propose(step, alive)
        assert np.array_equal(tried, objects.propose(step, alive))
        u = np.where(alive, rng.normal(0.0, 1.0, n), np.nan)
        for got, expected in zip(arrays.update(step, u, alive), objects.update(step, u, alive)):
            assert np.array_equal(got, expected)
        assert np.array_equal(arrays.memory(), objects.memory(), equal_nan=True)


@pytest.mark.parametrize("rule", ["thermal", "flaky", "adaptive", "sparse"])
def test_a_run_s_view_of_a_joint_controller_is_that_run_s_own_controller(rule):
    """Three runs' units in one UnitArrays: run 1's view proposes, accepts and remembers what run 1's own
    controller does, step by step, with units dying and stepping alone, while the other runs' units wait."""
    from morphbench.learning import load_learner_class, make_controller
    from morphbench.learning.arrays import RunView
    from morphbench.learning.plugins import make_joint_controller

    params, n, seeds = LearnerParams(adapt_window=3, trial_probability=0.9, trial_decay_steps=4), 4, [11, 12, 13]
    cls = load_learner_class(rule)
    own = make_controller(cls, params, seeds[1], n)
    view = RunView(make_joint_controller(cls, params, seeds, n), 1, n)
    np.testing.assert_array_equal(view.initial(), own.initial())
    rng = np.random.default_rng(0)
    for step in range(30):
        alive = np.array([True, True, step < 20, True])
        units = None if step % 3 else rng.random(n) < 0.7
        np.testing.assert_array_equal(view.propose(step, alive, units), own.propose(step, alive, units))
        velocity = rng.normal(2.0, 1.0, n)
        for got, expected in zip(view.update(step, velocity, alive, units), own.update(step, velocity, alive, units)):
            np.testing.assert_array_equal(got, expected)
        np.testing.assert_array_equal(view.memory(), own.memory())
    with pytest.raises(ConfigError, match="of unit 2 at learning step 30"):  # numbered within its run
        view.propose(30, np.ones(n, bool))
        view.update(30, np.array([1.0, np.nan, 1.0, 1.0]), np.ones(n, bool))


def test_a_sparse_unit_tries_on_a_fraction_of_its_steps_and_refreshes_its_memory_on_the_others():
    """The sparse learner: on a step it does not try, its phase stays, its memory becomes the step's measurement
    and it reports no acceptance; it tries on about trial_probability of its steps (binomial, 1,000 steps)."""
    from morphbench.learning.metropolis import SparseLearner

    learner = SparseLearner(LearnerParams(trial_probability=0.2, temperature=0.0), np.random.default_rng(3))
    assert learner.propose() == learner.phase and learner.update(1.0) and learner.memory == 1.0  # 'measure'
    tries, rng = 0, np.random.default_rng(4)
    for _ in range(1000):
        kept, trial = learner.phase, learner.propose()
        velocity = float(rng.normal(0.0, 1.0))
        before, accepted = learner.memory, learner.update(velocity)
        if learner.trying:
            tries += 1
            assert accepted == (velocity >= before)  # greedy at T = 0: a trial as good as the memory is kept
            assert learner.memory == (velocity if accepted else before)
            assert learner.phase == (trial if accepted else kept)
        else:
            assert trial == kept == learner.phase and not accepted and learner.memory == velocity
    assert abs(tries - 200) < 4 * (1000 * 0.2 * 0.8) ** 0.5


def test_a_sparse_unit_s_trial_probability_falls_with_its_own_steps_to_its_floor():
    """p = max(p_min, p0 / (1 + t / tau)) at the unit's own step t (its first, measuring, step is t = 0): the
    fraction of 2,000 units that try at a step follows it (binomial bounds); no decay keeps p0."""
    from morphbench.learning.arrays import UnitArrays
    from morphbench.learning.metropolis import trial_probability

    params = LearnerParams(trial_probability=0.8, trial_decay_steps=10, trial_probability_min=0.1)
    assert trial_probability(params, 0) == 0.8 and trial_probability(params, 10) == pytest.approx(0.4)
    assert trial_probability(params, 1000) == 0.1 and trial_probability(LearnerParams(), 1000) == 0.25
    n = 2000
    arrays = UnitArrays("sparse", params, [np.random.default_rng([7, u]) for u in range(n)], "sparse")
    alive = np.ones(n, bool)
    for step in range(120):
        arrays.propose(step, alive)
        if step:
            p = max(0.1, 0.8 / (1 + step / 10))
            assert abs(arrays.trying.mean() - p) < 4 * (p * (1 - p) / n) ** 0.5
        arrays.update(step, np.zeros(n), alive)
    with pytest.raises(ConfigError, match="trial_probability_min"):
        check_learner(LearnerParams(trial_probability=0.1, trial_decay_steps=5, trial_probability_min=0.2), "f")


@pytest.mark.parametrize("name", ["thermal", "flaky", "averaged", "adaptive", "sparse", "random"])
def test_a_unit_s_learner_cannot_see_another_unit_s_measurements(name):
    """No communication: whatever the other units measure, a unit's proposals, acceptances, kept phases and memory
    are the same (its own measurements and its own stream alone decide them), in the arrays a run steps."""
    from morphbench.learning.plugins import make_controller

    cls, n, rng = load_learner_class(name), 4, np.random.default_rng(5)
    params = learner_defaults(name)  # each learner's own settings (sparse: its decaying trial probability)
    one, other = make_controller(cls, params, 9, n), make_controller(cls, params, 9, n)
    alive = np.ones(n, bool)
    for step in range(200):
        a, b = one.propose(step, alive), other.propose(step, alive)
        assert a[0] == b[0]
        u = rng.normal(1.0, 2.0, n)
        v = u.copy()
        v[1:] = rng.normal(-3.0, 5.0, n - 1)  # the others' measurements: anything else
        (accepted_a, kept_a), (accepted_b, kept_b) = one.update(step, u, alive), other.update(step, v, alive)
        assert accepted_a[0] == accepted_b[0] and kept_a[0] == kept_b[0]
        assert one.memory()[0] == other.memory()[0]

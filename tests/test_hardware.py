"""The environment preset 'hardware' (params.ENVIRONMENT_PRESETS): named in one word by a run file, a suite and the
command line, the fields beside it on top; a scan of it measures its ground and pumps only; the default
environment's ids are those of before (opt-in); the friction field's offset reads the same track further on; the
hardware suite (benchmarks/paper-hardware.toml) and the hardware target set of benchmarks/calibrate.py."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import math
import sys
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from morphbench import params as P
from morphbench.bench import claims as C
from morphbench.bench.suite import load_suite, suite_from_table
from morphbench.errors import ConfigError
from morphbench.experiment import RunConfig, load_run_config, run_config_from_table
from morphbench.experiment.driver import run_batch
from morphbench.experiment.scan import velocity_at
from morphbench.identity import config_identity, identity, stable_hash
from morphbench.physics.friction import FrictionField, factors
from morphbench.shapes import load_shape

from conftest import BENCHMARKS_DIR, SHAPES_DIR, run_cli

HW = P.HARDWARE_ENVIRONMENT
CHAIN2 = SHAPES_DIR / "chain-2.toml"


def test_the_presets_are_whole_environments_and_hardware_turns_each_effect_on():
    assert P.ENVIRONMENT_PRESETS["default"] == P.EnvironmentParams()
    assert set(P.ENVIRONMENT_PRESET.values) == {"default", "hardware"}
    P.check_params(HW, "HARDWARE_ENVIRONMENT")  # every value within its field's range
    assert HW.vibration < 1 and HW.noise > 0 and HW.friction_field.amplitude > 0
    assert HW.clock_drift > 0 and HW.clock_offset > 0 and HW.friction_field.offset == 0
    source = Path(P.__file__).read_text(encoding="utf-8")
    assert "CALIBRATED" in source.split("HARDWARE_ENVIRONMENT = ", 1)[1].split("ENVIRONMENT_PRESETS", 1)[0]
    ground = P.scan_environment(HW)
    assert (ground.noise, ground.clock_drift, ground.clock_offset) == (0.0, 0.0, 0.0)
    assert ground.vibration == HW.vibration and ground.friction_field == HW.friction_field


def test_the_default_environments_ids_are_those_of_before():
    """Golden values computed before the presets and the field's offset existed: stored results keep their ids."""
    assert P.environment_id(P.EnvironmentParams()) == "655b0ab6a566"
    config = RunConfig(shape=load_shape(CHAIN2))
    assert stable_hash(config_identity(config, "default")) == "39f29d97cf6a"
    assert "offset" not in identity(P.EnvironmentParams())["friction_field"]
    assert next(f for f in dataclasses.fields(P.FrictionFieldParams) if f.name == "offset").metadata.get("later")
    shifted = P.FrictionFieldParams(amplitude=0.3, offset=0.5)
    assert identity(shifted)["offset"] == 0.5


def test_an_offset_reads_the_same_field_further_along_the_track():
    params = P.FrictionFieldParams(amplitude=0.3, correlation_length=0.25, seed=4)
    here, there = FrictionField(params), FrictionField(dataclasses.replace(params, offset=0.7))
    x = np.linspace(0.0, 4.0, 201)
    y = np.zeros_like(x)
    assert np.allclose(there(x, y), here(x + 0.7, y), atol=1e-12)
    compiled = np.empty_like(x)
    factors(x, y, *there.compiled(), compiled)
    assert np.allclose(compiled, there.friction(1.0, x, y), atol=1e-12)
    assert not np.allclose(there(x, y), here(x, y))


def _run(table: dict) -> RunConfig:
    return run_config_from_table({"shape": "chain-2.toml", **table}, "run.toml", SHAPES_DIR)


def test_a_run_file_names_the_preset_in_one_word_or_sets_fields_on_top_of_it():
    assert _run({"environment": "hardware"}).environment == HW
    assert _run({}).environment == P.EnvironmentParams()
    mine = _run({"environment": {"preset": "hardware", "noise": 0.25, "friction_field": {"offset": 0.5}}}).environment
    assert mine == dataclasses.replace(HW, noise=0.25, friction_field=dataclasses.replace(HW.friction_field,
                                                                                          offset=0.5))
    with pytest.raises(ConfigError, match="environment.preset"):
        _run({"environment": {"preset": "lab"}})
    with pytest.raises(ConfigError, match="environment"):
        _run({"environment": "lab"})
    with pytest.raises(ConfigError, match="environment.friction_field.offset"):
        _run({"environment": {"preset": "hardware", "friction_field": {"offset": -1.0}}})


def test_load_run_config_takes_the_preset_of_the_command_line_and_keeps_the_files_fields(tmp_path):
    assert load_run_config(CHAIN2, environment="hardware").environment == HW
    path = tmp_path / "run.toml"
    path.write_text(f'shape = "{CHAIN2}"\n[environment]\nnoise = 0.1\n')
    assert load_run_config(path, environment="hardware").environment == dataclasses.replace(HW, noise=0.1)
    assert load_run_config(path).environment == P.EnvironmentParams(noise=0.1)
    with pytest.raises(ConfigError, match="--environment"):
        load_run_config(path, environment="lab")


def _suite(tmp_path, text: str):
    return suite_from_table(tomllib.loads(text), source="s.toml", base=SHAPES_DIR)


def test_a_suite_names_the_preset_and_labels_its_conditions_by_it(tmp_path):
    suite = _suite(tmp_path, """
        [[experiment]]
        name = "a"
        shape = "chain-2.toml"
        steps = 2
        environment = [{preset = "hardware"}, {preset = "hardware", vibration = 0.7}, {friction_scale = 1.5}]
        [[experiment]]
        name = "d"
        shape = "chain-2.toml"
        steps = 2
        environment = ["default", "hardware"]
        [[experiment]]
        name = "b"
        shape = "chain-2.toml"
        steps = 2
        environment = "hardware"
        noise = 0.25
        [[scan]]
        name = "c"
        shape = "chain-2.toml"
        resolution = 4
        environment = {preset = "hardware", friction_field = {offset = 0.5}}
    """.replace("\n        ", "\n"))
    conditions = {r.condition["environment"]: r for r in suite.runs.values()}
    assert set(conditions) == {"hardware", "hardware, vibration=0.7", "friction_scale=1.5", "default"}
    assert conditions["default"].config.environment == P.EnvironmentParams()
    assert conditions["hardware"].config.environment in (HW, dataclasses.replace(HW, noise=0.25))
    assert conditions["hardware, vibration=0.7"].config.environment == dataclasses.replace(HW, vibration=0.7)
    noisy = [r for r in suite.runs.values() if r.config.environment.noise == 0.25]
    assert noisy and all(r.config.environment == dataclasses.replace(HW, noise=0.25) for r in noisy)  # the alias
    scan = suite.scans[0]
    assert scan.environment == P.scan_environment(dataclasses.replace(
        HW, friction_field=dataclasses.replace(HW.friction_field, offset=0.5)))
    assert scan.columns["environment"] == "hardware, friction_field.offset=0.5"


@pytest.mark.parametrize("environment, key", [('{preset = "hardware", noise = 0.5}', "environment.noise"),
                                              ('{preset = "hardware", clock_drift = 0.01}', "environment.clock_drift"),
                                              ('{noise_ground = 0.5}', "environment.noise_ground"),
                                              ('"lab"', "environment")])
def test_a_scan_of_the_preset_still_refuses_noise_and_clocks_written_beside_it(tmp_path, environment, key):
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
        _suite(tmp_path, f'[[scan]]\nshape = "chain-2.toml"\nresolution = 4\nenvironment = {environment}\n')


def test_the_hardware_suite_runs_the_experiments_at_56_seeds_on_the_preset():
    suite = load_suite(BENCHMARKS_DIR / "paper-hardware.toml")
    assert suite.name == C.HARDWARE_SUITE
    assert {e.name for e in suite.experiments} == {"hw-S1", "hw-S4", "hw-S6", "hw-S8"}
    assert all(r.config.environment == HW for r in suite.runs.values())
    seeds = {}
    for r in suite.runs.values():
        seeds.setdefault(r.condition_id, set()).add(r.seed)
    assert all(s == set(range(56)) for s in seeds.values())
    offsets = {}
    for scan in suite.scans:
        assert scan.environment == P.scan_environment(dataclasses.replace(
            HW, friction_field=dataclasses.replace(HW.friction_field, offset=scan.environment.friction_field.offset)))
        offsets.setdefault(scan.name.split("-at-")[0], []).append(scan.environment.friction_field.offset)
    assert offsets == {name: [0.0, 0.5, 1.0, 1.5] for name in ("hw-S2", "hw-S3", "hw-S6-damaged")}
    for name in offsets:  # every track claim finds its places
        assert C._track_names({"scans": pd.DataFrame({"scan": [s.name for s in suite.scans]})}, name) == \
            [name] + [f"{name}-at-{k}" for k in (1, 2, 3)]


def test_the_command_line_runs_and_scans_on_the_preset(tmp_path, capsys):
    code, _, err = run_cli(capsys, "run", str(CHAIN2), "--environment", "hardware", "--steps", "2", "--out",
                           str(tmp_path / "run"), "--quiet")
    assert code == 0, err
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["config"]["environment"]["vibration"] == HW.vibration
    assert summary["config"]["environment"]["clock_drift"] == HW.clock_drift
    code, _, err = run_cli(capsys, "run", str(CHAIN2), "--environment", "hardware", "--noise", "0", "--steps", "2",
                           "--out", str(tmp_path / "quiet"), "--quiet")
    assert code == 0 and json.loads((tmp_path / "quiet" / "summary.json").read_text())["config"]["environment"][
        "noise"] == 0.0
    code, out, err = run_cli(capsys, "scan", str(CHAIN2), "--environment", "hardware", "--resolution", "4",
                             "--cycles", "1", "--out", str(tmp_path / "scan"), "--quiet")
    assert code == 0, err
    code, _, err = run_cli(capsys, "run", str(CHAIN2), "--environment", "lab", "--out", str(tmp_path / "x"))
    assert code == 2 and "--environment" in err


def _first_step_residuals(environment: dict, seeds=(4,)) -> list[pd.DataFrame]:
    """chain-2's step 0 per unit (measured minus true velocity, and where the unit stands) for each seed, run as one
    batch."""
    configs = [_run({"steps": 2, "seed": seed, "sensor": {"kind": "ideal"}, "environment": environment})
               for seed in seeds]
    frames = []
    for records in run_batch(configs):
        units = records.units()
        first = units[units.step == 0]
        frames.append(first.assign(residual=first.u_measured - first.u_true))
    return frames


@pytest.mark.parametrize("clocks", [{}, {"clock_drift": 0.001, "clock_offset": 0.5}])
def test_a_noise_of_the_ground_scales_each_units_noise_by_the_field_where_it_stands(clocks):
    """EnvironmentParams.noise_ground: a unit's noise is noise (1 + b f(x, y)) at its place, f the friction field's
    shape (here with no amplitude: the physics is the uniform ground's, so the same seed draws the same normals and
    the residuals' ratio is the factor itself), on one clock and with clocks of their own alike."""
    ground = {"noise": 1.0, "friction_field": {"amplitude": 0.0, "correlation_length": 0.1}, **clocks}
    (plain,), (shaded,) = _first_step_residuals(ground), _first_step_residuals({**ground, "noise_ground": 0.9})
    shape = FrictionField(P.FrictionFieldParams(amplitude=0.0, correlation_length=0.1))
    factor = 1 + 0.9 * shape(shaded.x_m.to_numpy(), shaded.y_m.to_numpy())  # where each unit ended its step
    assert np.abs(factor - 1).max() > 0.2  # the units stand where the field is far from 0
    ratio = shaded.residual.to_numpy() / plain.residual.to_numpy()
    assert ratio == pytest.approx(factor, rel=1e-2 if clocks else 1e-9)  # with clocks each unit ends on its own


def test_a_noise_of_the_ground_is_the_same_run_alone_or_in_a_batch_and_off_leaves_runs_as_they_were():
    ground = {"noise": 1.0, "noise_ground": 0.5, "friction_field": {"amplitude": 0.3, "correlation_length": 0.1}}
    together = _first_step_residuals(ground, seeds=(4, 5))
    alone = [_first_step_residuals(ground, seeds=(seed,))[0] for seed in (4, 5)]
    for a, b in zip(together, alone):
        pd.testing.assert_frame_equal(a.reset_index(drop=True), b.reset_index(drop=True))
    off = P.EnvironmentParams(noise=1.0)  # at its default the field is left out of ids: results keep their ids
    assert config_identity(_run({"environment": {"noise": 1.0, "noise_ground": 0.0}}), "default") == \
        config_identity(_run({"environment": {"noise": 1.0}}), "default")
    assert P.environment_id(dataclasses.replace(off, noise_ground=0.5)) == P.environment_id(off)
    assert P.scan_environment(dataclasses.replace(HW, noise_ground=0.5)) == P.scan_environment(HW)


def _curve(physics: str, environment: P.EnvironmentParams) -> np.ndarray:
    """chain-2's velocity (mm/cycle) at the phase differences 0.2, 0.4, 0.6 and 0.8 on a physics preset."""
    shape = load_shape(CHAIN2)
    return np.array([velocity_at(shape, [0.0, d], physics=P.PHYSICS_PRESETS[physics], cycles=4,
                                 environment=environment).mean() for d in (0.2, 0.4, 0.6, 0.8)])


@pytest.mark.parametrize("physics", ["quasistatic", "dynamic", "fast"])
def test_the_presets_pumps_and_track_act_on_every_backend(physics):
    """Part 4 of the preset: on the quasi-static, dynamic and PyBullet models alike, the preset's vibration makes the
    2-unit curve asymmetric (forward at 0.4 faster than backward at 0.6) where without it the curve is the model's
    mirror image, and its track (the field at the robot's start) changes the curve again."""
    bare = _curve(physics, P.EnvironmentParams())
    shaken = _curve(physics, P.EnvironmentParams(vibration=HW.vibration))
    ground = _curve(physics, P.scan_environment(HW))
    assert bare[1] > 4 and abs(bare[1] + bare[2]) < 0.2
    assert shaken[1] + shaken[2] > 0.4
    assert np.abs(ground - shaken).max() > 1.0


@pytest.mark.parametrize("physics", ["dynamic", "fast"])
def test_the_backends_agree_on_the_presets_curve_away_from_the_ratchet(physics):
    """The hardware suite's scans use the quasi-static model; the models with inertia measure the same vibrated curve
    on a uniform ground (2026-12-05: within 0.11 mm/cycle) and on the preset's track the same curve within 1.2 at
    dphi 0.2-0.8; nearer 0, where the track's place makes the quasi-static units ratchet, inertia halves the speed
    (7.0 against 3.1-4.0 at 0: docs/hardware.md)."""
    shaken = P.EnvironmentParams(vibration=HW.vibration)
    assert _curve(physics, shaken) == pytest.approx(_curve("quasistatic", shaken), abs=0.2)
    ground = P.scan_environment(HW)
    assert _curve(physics, ground) == pytest.approx(_curve("quasistatic", ground), abs=1.5)


# --- benchmarks/calibrate.py --targets hardware (the search itself is not run here) ---------------------------------


def _script(name: str):
    spec = importlib.util.spec_from_file_location(f"{name}_script", BENCHMARKS_DIR / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up while it loads
    try:
        spec.loader.exec_module(module)
    finally:
        del sys.modules[spec.name]
    return module


@pytest.fixture(scope="module")
def calibrate():
    return _script("calibrate")


def _claim(rule: str, paper: float, tolerance: float, unit: str = "mm/cycle") -> C.Claim:
    return C.Claim("hw-x", "x (hardware)", "", paper, unit, lambda t: "", tolerance, rule)


def test_a_claims_distance_is_zero_where_it_holds_and_grows_with_the_excess(calibrate):
    d = calibrate.claim_distance
    assert d(_claim("within", 4.5, 1.0), 4.0) == 0 and d(_claim("within", 4.5, 1.0), 2.5) == pytest.approx(1.0)
    assert d(_claim("phase", 0.9, 0.1, "cycles"), 0.05) == pytest.approx(0.5)  # 0.15 on the circle, 0.05 too far
    assert d(_claim("phase", 0.9, 0.1, "cycles"), 0.95) == 0
    assert d(_claim("at most", 0.0, 0.1, "of trials"), 0.3) == pytest.approx(2.0)
    assert d(_claim("at least", 4.5, 1.0), 3.0) == pytest.approx(0.5) and d(_claim("at least", 4.5, 1.0), 9.0) == 0
    assert d(_claim("within", 4.5, 1.0), 100.0) == calibrate.CAP and d(_claim("within", 4.5, 1.0), math.nan) == \
        calibrate.CAP
    for value in np.linspace(-5, 5, 41):  # zero exactly where the claim holds
        for claim in (_claim("within", 1.0, 0.5), _claim("at most", -0.25, 0.0), _claim("phase", 0.4, 0.1, "cycles")):
            assert (calibrate.claim_distance(claim, value) == 0) == claim.holds(value)


def test_the_hardware_score_sums_the_claims_distances_a_claim_not_measured_at_the_cap(calibrate):
    claims = (_claim("within", 4.5, 1.0), _claim("at most", 0.0, 0.1, "of trials"), _claim("within", 1.0, 0.5))
    verdicts = [C.Verdict(claims[0], C.Measured(3.0, ""), False), C.Verdict(claims[1], C.Measured(0.05, ""), True),
                C.Verdict(claims[2], None, None, "not measured")]
    score, rows = calibrate.hardware_score(verdicts)
    assert score == pytest.approx(0.5 + 0 + calibrate.CAP)
    assert [r[2] for r in rows] == pytest.approx([0.5, 0.0, calibrate.CAP]) and math.isnan(rows[2][1])
    assert [r[3] for r in rows] == [True, True, False]
    none_found = calibrate.hardware_score([C.Verdict(claims[2], C.Measured(math.nan, "none found"), False)])[1][0]
    assert none_found[2] == calibrate.CAP and none_found[3] is True


def test_a_hardware_candidate_is_the_hardware_suite_with_its_effects_and_never_the_learners(calibrate):
    assert set(calibrate.HARDWARE_SPACE) == {"vibration", "field_amplitude", "field_length", "noise", "clock_drift"}
    base = calibrate.HARDWARE_BASE
    for key, bound in calibrate.HARDWARE_SPACE.items():
        assert bound.low <= base[key] <= bound.high, key
    unit = calibrate.to_unit(base, calibrate.HARDWARE_SPACE)
    assert calibrate.from_unit(unit, calibrate.HARDWARE_SPACE) == pytest.approx(base)
    candidate = {"vibration": 0.7, "field_amplitude": 0.2, "field_length": 0.5, "noise": 0.8, "clock_drift": 0.002}
    table = calibrate.hardware_suite_table(candidate, 3)
    suite = suite_from_table(table, source="paper-hardware.toml", base=BENCHMARKS_DIR)
    assert suite.name == C.HARDWARE_SUITE
    field = dataclasses.replace(HW.friction_field, amplitude=0.2, correlation_length=0.5)
    wanted = dataclasses.replace(HW, vibration=0.7, noise=0.8, clock_drift=0.002, friction_field=field)
    assert all(r.config.environment == wanted and r.seed < 3 for r in suite.runs.values())
    assert all(r.config.learner_params == P.LearnerParams() for r in suite.runs.values())  # never the learners
    assert sorted({s.environment.friction_field.offset for s in suite.scans}) == [0.0, 0.5, 1.0, 1.5]
    for scan in suite.scans:
        assert scan.environment == P.scan_environment(dataclasses.replace(
            wanted, friction_field=dataclasses.replace(field, offset=scan.environment.friction_field.offset)))
    # the lowest friction the space allows is still within the quasi-static model's range on every chain
    space = calibrate.HARDWARE_SPACE
    low = dataclasses.replace(HW, vibration=space["vibration"].low, friction_field=dataclasses.replace(
        HW.friction_field, amplitude=space["field_amplitude"].high))
    for n in (2, 3, 7):
        assert P.friction_inertia(load_shape(SHAPES_DIR / f"chain-{n}.toml"), low)[0] >= P.MIN_FRICTION_INERTIA


def test_the_ablation_switches_each_effect_off_alone_and_tabulates_the_verdicts(calibrate):
    base = dict(calibrate.HARDWARE_BASE)
    columns = calibrate.ablations(base)
    assert list(columns) == ["preset", "no vibration", "no field", "no noise", "one clock"]
    assert columns["preset"] == base
    for name, candidate in columns.items():
        changed = {k for k in {*candidate, *base} if candidate.get(k, calibrate.HARDWARE_FIXED.get(k)) !=
                   base.get(k, calibrate.HARDWARE_FIXED.get(k))}
        assert changed == set(calibrate.ABLATIONS.get(name, {})), name
    off = calibrate.hardware_environment(columns["one clock"])
    assert off["clock_drift"] == 0 and off["clock_offset"] == 0 and off["noise"] == base["noise"]
    assert calibrate.hardware_environment(columns["no vibration"])["vibration"] == 1.0
    rows = {"preset": [("hw-a", 4.2, 0.0, True), ("hw-b", math.nan, calibrate.CAP, False),
                       ("hw-c", math.nan, calibrate.CAP, True)],
            "no vibration": [("hw-a", 1.5, 2.0, True), ("hw-b", 0.5, 0.0, True), ("hw-c", 1.0, 0.0, True)]}
    assert calibrate.ablation_table(rows) == ["| claim | preset | no vibration |", "|---|---|---|",
                                              "| `hw-a` | holds | no (1.5) |", "| `hw-b` | not measured | holds |",
                                              "| `hw-c` | no (none found) | holds |"]


# --- benchmarks/hardware_curve.py: the 2-unit curve's claims over the vibration and the field ------------------------


def test_the_curve_sweep_measures_the_suites_places_by_its_claims_and_without_effects_the_curve_is_symmetric():
    sweep = _script("hardware_curve")
    assert [p.environment.friction_field.offset for p in sweep.places()] == [0.0, 0.5, 1.0, 1.5]
    bare = sweep.measure("default", 1.0, 0.0, 1)  # no vibration, a uniform ground: the model's symmetric curve
    assert set(bare) == set(sweep.CURVE_CLAIMS)
    assert bare["hw-peak"][0] == pytest.approx(-bare["hw-trough"][0], rel=0.1)
    assert bare["hw-peak-at"][0] + bare["hw-trough-at"][0] == pytest.approx(1.0, abs=0.03)
    assert math.isnan(bare["hw-local-max"][0]) and not bare["hw-local-max"][1]
    shaken = sweep.measure("default", HW.vibration, HW.friction_field.amplitude, 1)  # the preset's: the asymmetry
    assert shaken["hw-trough"][1] and not bare["hw-trough"][1]
    page = sweep.page([{"physics": "default", "vibration": 1.0, "amplitude": 0.0, **bare}], "cmd", 1.0)
    assert "| default | 1 | 0 |" in page and "all six hold: 0 of 1" in page

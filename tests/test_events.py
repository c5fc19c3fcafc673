"""Events as objects: parsed from their tables, written back as the same tables, applied to a world and the run
state."""


import numpy as np
import pytest

from morphbench.errors import ConfigError
from morphbench.experiment import RunConfig, parse_events
from morphbench.experiment.events import EVENT_KINDS, DamageEvent, RunState, ShuffleEvent
from morphbench.shapes import load_shape
from morphbench.shapes.transforms import shuffle_order

TABLES = [
    ({"step": 1, "kind": "friction", "scale": 0.5}, "friction scale=0.5"),
    ({"step": 1, "kind": "friction", "scale": 0.5, "bodies": "passive"}, "friction scale=0.5 bodies=passive"),
    ({"step": 2, "kind": "damage", "unit": 2, "mode": "no-inflate"}, "damage unit=2 mode=no-inflate"),
    ({"step": 3, "kind": "shuffle", "seed": 7}, "shuffle seed=7"),
    ({"step": 4, "kind": "cut", "link": 1}, "cut link=1"),
    ({"step": 5, "kind": "noise", "sigma": 1.0}, "noise sigma=1.0"),
]


def test_each_kind_parses_to_its_class_and_back_to_its_table():
    events = parse_events([table for table, _ in TABLES], "x.toml", 3, 3)
    for event, (table, text) in zip(events, TABLES):
        assert type(event) is EVENT_KINDS[table["kind"]] and event.kind == table["kind"]
        # settings() is what summary.json and suite run ids keep of an event: the table's keys in its order (an
        # optional field left at its default is left out, so events written before it keep their ids)
        assert list(event.settings().items()) == list(table.items())
        assert event.describe() == text


def test_a_config_written_and_read_back_has_the_same_events():
    shape = load_shape("shapes/chain-3.toml")
    config = RunConfig(shape=shape, events=parse_events([table for table, _ in TABLES], "x.toml", 3, 3))
    assert RunConfig.from_dict(config.to_dict()).events == config.events


def test_a_bad_event_in_a_summary_names_the_summary():
    data = RunConfig(shape=load_shape("shapes/chain-3.toml")).to_dict()
    data["events"] = [{"step": 1, "kind": "noise", "sigma": -1.0}]
    with pytest.raises(ConfigError, match=r"run/summary.json.*events\[0\]\.sigma"):
        RunConfig.from_dict(data, source="run/summary.json")


@pytest.mark.parametrize("bodies", ["dummy", 1, ["passive"]])
def test_a_friction_event_names_its_bodies_from_a_fixed_list(bodies):
    with pytest.raises(ConfigError, match=r"x.toml.*events\[0\]\.bodies.*all.*active.*passive"):
        parse_events([{"step": 1, "kind": "friction", "scale": 0.5, "bodies": bodies}], "x.toml", 3, 3)


class FakeWorld:
    def __init__(self):
        self.damage = {}

    def set_damage(self, position, mode):
        self.damage[position] = mode


def test_damage_travels_with_its_unit_through_a_shuffle():
    world, state = FakeWorld(), RunState.initial(4, noise=0.0)
    DamageEvent(step=1, unit=2, mode="stuck").apply(world, state)
    assert world.damage == {0: "", 1: "stuck", 2: "", 3: ""}
    ShuffleEvent(step=2, seed=3).apply(world, state)
    assert np.array_equal(state.order, shuffle_order(4, 3))
    assert world.damage[int(state.position()[1])] == "stuck" and list(world.damage.values()).count("stuck") == 1

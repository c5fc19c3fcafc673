"""Random streams: one table of ids (morphbench/streams.py), used by every module that seeds a generator."""

import re
from pathlib import Path

from morphbench import streams

PACKAGE = Path(streams.__file__).parent


def test_stream_ids_are_distinct():
    ids = {name: value for name, value in vars(streams).items() if name.endswith("_STREAM")}
    assert len(set(ids.values())) == len(ids) == 8


def test_no_module_seeds_a_stream_with_a_literal_id():
    literal = re.compile(r"SeedSequence\(\[[^\]]*,\s*\d")
    offenders = [str(path) for path in PACKAGE.rglob("*.py") if literal.search(path.read_text())]
    assert offenders == []

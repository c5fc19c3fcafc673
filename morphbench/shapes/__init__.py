"""Morphologies: the assembly as validated plain data, loaded from the TOML files in ``shapes/``."""

from morphbench.shapes.loader import load_shape, params_from_dict, params_from_table, read_toml, shape_from_table
from morphbench.shapes.model import Body, Link, Shape

__all__ = ["Body", "Link", "Shape", "load_shape", "params_from_dict", "params_from_table", "read_toml", "shape_from_table"]

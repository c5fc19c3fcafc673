"""Morphologies: the assembly as validated plain data, loaded from the TOML files in ``shapes/``."""

from morphbench.shapes.checks import check_shape, components, is_connected
from morphbench.shapes.drawing import draw
from morphbench.shapes.export import export_scene, scene
from morphbench.shapes.generators import CustomLink, CustomUnit, chain, custom, grid, lattice, site_position
from morphbench.readers import params_from_dict, params_from_table  # the generic readers, exported here as before
from morphbench.shapes.loader import GENERATORS, load_shape, read_toml, shape_from_table
from morphbench.shapes.meshes import body_mesh, mass_properties
from morphbench.shapes.model import Body, Link, Shape
from morphbench.shapes.transforms import cut, cut_apart, pieces, remove_links, rotate, shuffle

__all__ = [
    "Body", "CustomLink", "CustomUnit", "GENERATORS", "Link", "Shape", "body_mesh", "chain", "check_shape",
    "components", "custom", "cut", "cut_apart", "draw", "export_scene", "grid", "is_connected", "lattice", "load_shape",
    "mass_properties", "params_from_dict", "params_from_table", "pieces", "read_toml", "remove_links", "rotate",
    "scene", "shape_from_table", "shuffle", "site_position",
]

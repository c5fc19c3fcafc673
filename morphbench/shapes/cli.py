"""``morphbench shapes list|check|export|show``: look at morphology files without simulating them.

``add_shapes_commands(subparsers)`` adds the ``shapes`` command to the main parser's sub-parsers; each sub-command
sets ``func(args) -> int`` (0 on success) and raises ``ConfigError`` for bad input (the main command prints it on one
line and exits with 2). ``python -m morphbench.shapes.cli ...`` runs the same commands on their own.

    morphbench shapes list [DIR]                 name, units, bodies, links, description of every DIR/*.toml
    morphbench shapes check FILE...              validate; one OK line per file, exit 2 at the first bad one
    morphbench shapes export FILE --out OUT.glb  a 3-D scene (.glb, .gltf, .obj, .ply): bodies and links
    morphbench shapes show FILE --png OUT.png    a top view and a side view

FILE is a morphology file, or the bare name of a shape of the shipped library (``chain-2``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from morphbench import data_path
from morphbench.progress import announced
from morphbench.errors import ConfigError
from morphbench.files import check_path, is_dir
from morphbench.shapes.checks import components
from morphbench.shapes.export import SCENE_SUFFIXES
from morphbench.shapes.loader import load_shape, resolve_shape_path

PACKAGE_SHAPES = data_path("shapes")
"""The shipped library (in the installed package, or next to it in a source checkout)."""
FILE_HELP = "a morphology file, or the name of a shipped shape (chain-2; see 'morphbench shapes list')"
def load_announced(file: str | Path, quiet: bool = False):
    """``load_shape`` of FILE (a path or a library name), announced if it is slow (a large generated shape)."""
    with announced(f"reading, generating and checking {file}", quiet):
        return load_shape(resolve_shape_path(file))


def default_directory() -> Path:
    """``shapes/`` in the working directory if there is one, else the shipped library."""
    local = Path("shapes")
    return local if local.is_dir() else PACKAGE_SHAPES


def add_shapes_commands(subparsers) -> argparse.ArgumentParser:
    """Add ``shapes`` with its sub-commands to ``subparsers`` (from ``add_subparsers``); return its parser."""
    shapes = subparsers.add_parser("shapes", help="list, check, export or draw morphology files (no simulation)",
                                   description="Look at morphology files without simulating them.")
    sub = shapes.add_subparsers(dest="shapes_command", required=True, metavar="{list,check,export,show}")

    listing = sub.add_parser("list", help="name, units, bodies, links and description of every file in a directory")
    listing.add_argument("directory", nargs="?", default=None,
                         help="directory of morphology files (default: ./shapes, else the shipped library)")
    listing.set_defaults(func=cmd_list)

    check = sub.add_parser("check", help="validate morphology files (exit 2 at the first bad one)")
    check.add_argument("files", nargs="+", metavar="FILE", help=FILE_HELP)
    check.set_defaults(func=cmd_check)

    export = sub.add_parser("export", help="write a 3-D scene of a shape: one mesh per body, a cylinder per link")
    export.add_argument("file", metavar="FILE", help=FILE_HELP)
    export.add_argument("--out", required=True, help=f"output file ({', '.join(SCENE_SUFFIXES)})")
    export.set_defaults(func=cmd_export)

    show = sub.add_parser("show", help="draw a shape at rest (top and side view) to a PNG")
    show.add_argument("file", metavar="FILE", help=FILE_HELP)
    show.add_argument("--png", required=True, help="output picture (.png)")
    show.set_defaults(func=cmd_show)
    return shapes


def _counts(shape) -> str:
    return f"{shape.n_units} units, {len(shape.bodies)} bodies, {len(shape.links)} links"


def cmd_list(args) -> int:
    directory = Path(args.directory) if args.directory is not None else default_directory()
    if not is_dir(directory):
        raise ConfigError("shapes list", "DIRECTORY", "a directory of morphology files (.toml)", str(directory))
    files = sorted(directory.glob("*.toml"))
    if not files:
        raise ConfigError("shapes list", "DIRECTORY", "a directory with at least one .toml file", str(directory))
    shapes = [load_announced(path) for path in files]  # a bad file stops the listing with its one-line message
    width = max(len(s.name) for s in shapes)
    print(f"{'name':<{width}}  units  bodies  links  description")
    for s in shapes:
        print(f"{s.name:<{width}}  {s.n_units:>5}  {len(s.bodies):>6}  {len(s.links):>5}  {s.description}")
    return 0


def cmd_check(args) -> int:
    for file in args.files:
        shape = load_announced(file)
        n_pieces = len(components(shape))
        pieces = f", {n_pieces} pieces (cut)" if n_pieces > 1 else ""
        print(f"OK {file}: {shape.name}, {_counts(shape)}{pieces}")
    return 0


def cmd_export(args) -> int:
    from morphbench.shapes.export import export_scene

    return _write(args.file, "--out", args.out, SCENE_SUFFIXES, export_scene, "exporting")


def cmd_show(args) -> int:
    from morphbench.shapes.export import draw

    return _write(args.file, "--png", args.png, (".png",), draw, "drawing")


def _write(file: str, flag: str, output: str, suffixes, writer, verb: str) -> int:
    """Load a shape and write it to ``output`` with ``writer(shape, path)`` (what it does: ``verb``), the output
    checked first."""
    out = Path(output)
    if out.suffix.lower() not in suffixes:
        raise ConfigError(flag, output, f"a file name ending in {', '.join(suffixes)}")
    if is_dir(check_path(output, flag)):
        raise ConfigError(flag, output, "a file name (this is a directory)")
    shape = load_announced(file)
    try:
        with announced(f"{verb} {len(shape.bodies):,} bodies and {len(shape.links):,} links into {out}"):
            writer(shape, out)
    except OSError as exc:
        raise ConfigError(flag, output, f"a file that can be written ({exc.strerror or exc})") from None
    print(f"{shape.name}: {_counts(shape)} -> {out}")
    return 0

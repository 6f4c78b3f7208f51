"""Sphinx configuration of the aiauv-pin documentation (``sphinx-build -W -b html docs/source
docs/_build/html``)."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

project = "aiauv-pin"
author = "aiauv-pin developers"
copyright = "aiauv-pin developers"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3

autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "show-inheritance": False}
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_ivar = True

html_theme = "furo"
html_title = "aiauv-pin"
exclude_patterns = ["_build", "_generated"]


def _write_sweep_parameters(app) -> None:
    """The table of sweep parameters, generated from the code so that it cannot drift."""
    from aiauv_pin.scenario.sweep_spec import PARAMETERS

    lines = ["| parameter | kind | meaning |", "|---|---|---|"]
    for name, (kind, meaning) in PARAMETERS.items():
        if isinstance(kind, tuple):
            kind = "one of " + ", ".join(f"`{option}`" for option in kind[1])
        lines.append(f"| `{name}` | {kind} | {meaning.replace('|', '/')} |")
    folder = Path(app.srcdir) / "_generated"
    folder.mkdir(exist_ok=True)
    text = "\n".join(lines) + "\n"
    target = folder / "sweep_parameters.md"
    if not target.exists() or target.read_text() != text:
        target.write_text(text)


def _write_generated(app, name: str, text: str) -> None:
    """Write ``_generated/<name>`` when its text changed (tables generated from the code)."""
    folder = Path(app.srcdir) / "_generated"
    folder.mkdir(exist_ok=True)
    target = folder / name
    if not target.exists() or target.read_text() != text:
        target.write_text(text)


def _write_scenario_keys(app) -> None:
    """The table of scenario-file keys, generated from the schema so that it cannot drift."""
    from aiauv_pin.scenario.parameters import markdown_table

    _write_generated(app, "scenario_keys.md", markdown_table())


def _write_vehicle_keys(app) -> None:
    """The table of vehicle-spec keys with units and ranges, generated from the schema."""
    from aiauv_pin.builders.vehicle_spec_schema import markdown_keys

    _write_generated(app, "vehicle_keys.md", markdown_keys())


def setup(app) -> None:
    app.connect("builder-inited", _write_sweep_parameters)
    app.connect("builder-inited", _write_scenario_keys)
    app.connect("builder-inited", _write_vehicle_keys)

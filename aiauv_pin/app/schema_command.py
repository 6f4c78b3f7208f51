"""``aiauv schema scenario|sweep|vehicle``: print the JSON Schema of a file format.

Above the three schemas (:mod:`aiauv_pin.scenario.file_schemas`, :mod:`aiauv_pin.scenario.sweep_spec`,
:mod:`aiauv_pin.builders.vehicle_spec_schema`), so that none of them imports another's floor.
"""

from __future__ import annotations

import json

from pydantic import BaseModel

from aiauv_pin._internal.schema_validation import json_schema


def file_models() -> dict[str, type[BaseModel]]:
    """The models ``aiauv schema`` prints, by file kind."""
    from aiauv_pin.builders.vehicle_spec_schema import VehicleSpecFile
    from aiauv_pin.scenario.file_schemas import ScenarioFile
    from aiauv_pin.scenario.sweep_spec import sweep_file_model

    return {"scenario": ScenarioFile, "sweep": sweep_file_model(), "vehicle": VehicleSpecFile}


def add_schema_parser(subparsers) -> None:
    """Register ``aiauv schema scenario|sweep|vehicle`` on ``add_subparsers()``."""
    parser = subparsers.add_parser(
        "schema",
        help="print the JSON Schema of scenario files, sweep specs or vehicle specs",
        description="Print the JSON Schema (draft 2020-12) of a file format, for editors that "
        "complete and check TOML files against a schema (e.g. Taplo / Even Better TOML).",
    )
    parser.add_argument("kind", choices=("scenario", "sweep", "vehicle"), help="file format")
    parser.set_defaults(handler=_run_schema)


def _run_schema(args) -> int:
    print(json.dumps(json_schema(file_models()[args.kind]), indent=2))
    return 0

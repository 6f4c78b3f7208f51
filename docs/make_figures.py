"""Regenerate the README's result figures, ``docs/figures/{uniform,stabilised}/``.

Runs the paper's scenario on both bundled vehicles at the scenario's defaults (what ``aiauv
simulate --case CASE`` runs), draws the figures as the command does
(:func:`aiauv_pin.results.outputs.write_figures`, 200 dpi) and stores each PNG at half that resolution
(Lanczos), at the highest zlib level: small files for the README, which shows them side by side.

    .venv/bin/python docs/make_figures.py
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from PIL import Image

import aiauv_pin
from aiauv_pin.results.outputs import write_figures
from aiauv_pin.scenario.definition import Scenario, run_scenario

HERE = Path(__file__).resolve().parent / "figures"


def main() -> None:
    for case in ("uniform", "stabilised"):
        vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf(case))
        result = run_scenario(vehicle, Scenario(case=case))
        target = HERE / case
        target.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory() as folder:
            for drawn in write_figures(result, Path(folder), vehicle_name=case):  # the folder
                with Image.open(drawn) as image:
                    half = image.resize(
                        (image.width // 2, image.height // 2), Image.Resampling.LANCZOS
                    )
                    half.save(target / drawn.name, optimize=True, compress_level=9)
                print(target / drawn.name)


if __name__ == "__main__":
    main()

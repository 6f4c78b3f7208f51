"""Figures (formats, log-scale error panels, equal 3-D axes, titles) and command-line conveniences."""

from __future__ import annotations

import argparse
import json
import struct
import subprocess
import sys

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from aiauv_pin import load_vehicle
from aiauv_pin.app import cli
from aiauv_pin.results import figures, outputs
from aiauv_pin.scenario.definition import PaperScenario, run_paper_scenario
from aiauv_pin.simulation import compilation


@pytest.fixture(scope="module")
def short_result():
    vehicle = load_vehicle(backend="pinocchio")
    return run_paper_scenario(
        vehicle, PaperScenario(duration=0.5, dt=0.01, method="rk4"), progress=False, compiled=False
    )


def _png_size(path) -> tuple[int, int]:
    header = path.read_bytes()[:24]
    assert header[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", header[16:24])


def test_png_at_200_dpi_and_vector_formats(short_result, tmp_path):
    written = outputs.write_figures(short_result, tmp_path / "png", parallel=False)
    assert [p.name for p in written] == list(outputs.FIGURES)
    # fig3 is 6 x 3.2 inches; tight_layout keeps the canvas size
    assert _png_size(tmp_path / "png" / "fig3_surge.png") == (1200, 640)
    svg = outputs.write_figures(short_result, tmp_path / "svg", parallel=False, figure_format="svg")
    assert all(p.suffix == ".svg" and "<svg" in p.read_text()[:500] for p in svg)
    pdf = outputs.write_figures(short_result, tmp_path / "pdf", parallel=False, figure_format="pdf")
    assert all(p.read_bytes()[:5] == b"%PDF-" for p in pdf)
    with pytest.raises(ValueError, match="unknown figure format 'gif'"):
        outputs.write_figures(short_result, tmp_path, figure_format="gif")


@pytest.mark.parametrize(
    "name", ["fig2_cross_track.png", "fig4_phi_tilde.png", "fig5_omega_tilde.png"]
)
def test_error_figures_have_a_log_companion(short_result, name):
    fig = figures._draw(name, outputs.figure_data(short_result, vehicle_name="my_vehicle"))
    linear, log = fig.axes[:2]
    assert linear.get_yscale() == "linear" and log.get_yscale() == "log"
    assert "my_vehicle" in linear.get_title()
    # the log panel draws |error| of each linear curve
    for line, magnitude in zip(linear.get_lines()[1:], log.get_lines(), strict=False):
        y = np.asarray(line.get_ydata(), dtype=float)
        np.testing.assert_allclose(
            np.asarray(magnitude.get_ydata(), dtype=float),
            np.where(np.abs(y) > 0, np.abs(y), np.nan),
        )


def test_path_figure_has_equal_axes_and_draws_given_points(short_result):
    helix = np.column_stack(
        [np.linspace(0, 3, 50), np.cos(np.linspace(0, 6, 50)), np.sin(np.linspace(0, 6, 50))]
    )
    fig = figures._draw("path_3d.png", outputs.figure_data(short_result, path_points=helix))
    ax = fig.axes[0]
    spans = [np.diff(limits)[0] for limits in (ax.get_xlim(), ax.get_ylim(), ax.get_zlim())]
    np.testing.assert_allclose(spans, spans[0], rtol=1e-12)
    path_line = next(line for line in ax.get_lines() if line.get_label() == "path")
    x, y, z = path_line.get_data_3d()
    np.testing.assert_array_equal(np.column_stack([x, y, z]), helix)
    assert "uniform" in ax.get_title()  # no vehicle name given: the case
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        figures._draw(
            "path_3d.png", outputs.figure_data(short_result, path_points=np.zeros((4, 2)))
        )


def test_version_and_module_entry_point(capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"aiauv {cli._version()}"
    run = subprocess.run(
        [sys.executable, "-m", "aiauv_pin", "--version"], capture_output=True, text=True, check=True
    )
    assert run.stdout.startswith("aiauv ")


def _parsers(parser: argparse.ArgumentParser):
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                yield from _parsers(sub)


def test_every_option_has_help_text():
    missing = [
        f"{parser.prog} {action.dest}"
        for parser in _parsers(cli.build_parser())
        for action in parser._actions
        if not isinstance(action, argparse._SubParsersAction) and not action.help
    ]
    assert missing == []


def test_figure_formats_agree():
    assert cli.FIGURE_FORMATS == outputs.FIGURE_FORMATS


def test_compile_notice_when_numba_compiles_and_only_then(capsys):
    numba = pytest.importorskip("numba")
    add_one = numba.njit(lambda x: x + 1)  # not cached: compiled in this process
    with compilation.CompilationWatch() as watch:
        assert add_one(1) == 2
        assert add_one(2) == 3  # the same signature: compiled once
    assert len(watch.compiled) == 1 and watch.compiled_now
    assert capsys.readouterr().err.strip() == compilation.COMPILE_NOTICE
    with compilation.CompilationWatch() as watch:
        assert add_one(3) == 4
    assert not watch.compiled_now
    assert capsys.readouterr().err == ""
    add_one(1.5)  # outside a watch: not seen by an exited one
    assert not watch.compiled_now


def test_simulate_records_setup_time_apart_from_the_run(tmp_path, capsys):
    out = tmp_path / "run"
    status = cli.main(
        [
            "simulate",
            "--duration",
            "0.5",
            "--no-html",
            "--quiet",
            "--out",
            str(out),
            "--figure-format",
            "svg",
        ]
    )
    assert status == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["setup_time"] > 0.0 and isinstance(summary["compiled_now"], bool)
    assert summary["real_time_factor"] == pytest.approx(
        summary["simulated_time"] / summary["wall_time"]
    )
    assert (out / "figures" / "fig2_cross_track.svg").is_file()
    assert not (out / "figures" / "fig2_cross_track.png").exists()

"""Playback of an annotated example-robot-data arm, rendered in headless Chromium (pixels).

Skipped where Chromium is absent, except in CI (see ``test_browser.py``).
"""

from __future__ import annotations

import colorsys
import re

import numpy as np
import pytest
from test_browser import screenshot

import aiauv_pin
from aiauv_pin.app.annotate_command import annotate_file
from aiauv_pin.description.robots import example_robot_urdf
from aiauv_pin.results import playback, viewer

pytestmark = pytest.mark.browser


def _hues(pixels: np.ndarray) -> np.ndarray:
    flat = pixels.reshape(-1, 3) / 255.0
    return np.array([colorsys.rgb_to_hsv(*p) for p in flat]).reshape(*pixels.shape[:2], 3)


def test_annotated_arm_is_drawn_in_distinct_colours(tmp_path):
    urdf = tmp_path / "ur5.urdf"
    annotate_file(example_robot_urdf("ur_description/urdf/ur5_robot.urdf"), urdf, neutral=True)
    arm = aiauv_pin.load_vehicle(urdf)
    q0 = arm.neutral_configuration()
    run = aiauv_pin.simulate(arm, q0, np.zeros(arm.nv), duration=2.0, dt=0.01)
    # collision meshes (STL, package://) only: a page of 1 MB instead of 3.5, quick to render
    text = re.sub(r"<visual>.*?</visual>", "", urdf.read_text(encoding="utf-8"), flags=re.S)
    page = playback.write_playback(arm, run, tmp_path / "playback.html", urdf=text, max_frames=50)
    commands = playback.read_commands(page.read_text(encoding="utf-8"))
    empty_commands = [
        c
        for c in commands
        if c["type"] != "set_animation" and not c["path"].startswith(viewer.LINKS)
    ]
    empty = tmp_path / "empty.html"
    empty.write_text(playback.html_page(empty_commands), encoding="utf-8")
    shown = screenshot(page, tmp_path, "arm")
    blank = screenshot(empty, tmp_path, "empty")
    assert np.ptp(blank[:, :, 2]) > 50  # WebGL rendered at all
    drawn = np.abs(shown - blank).sum(axis=2) > 100
    assert drawn.sum() > 0.01 * drawn.size, f"only {drawn.sum()} pixels of the arm"
    rows, cols = np.nonzero(drawn)
    height, width = drawn.shape
    assert 0.15 * width < cols.mean() < 0.85 * width
    assert 0.15 * height < rows.mean() < 0.85 * height
    # the links' distinct colours: several well-populated hues among the saturated arm pixels
    hsv = _hues(shown)
    saturated = drawn & (hsv[..., 1] > 0.35) & (hsv[..., 2] > 0.25)
    counts = np.bincount((hsv[..., 0][saturated] * 12).astype(int) % 12, minlength=12)
    assert (counts > 150).sum() >= 3, counts

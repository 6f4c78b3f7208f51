"""The playback page opened from disk in headless Chromium really shows the vehicle.

Skipped where Chromium is absent, except in CI (``CI`` set), where a missing browser is a failure.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from test_playback import URDF, synthetic_trajectory

import aiauv_pin
from aiauv_pin.results import playback, viewer

pytestmark = pytest.mark.browser

WIDTH, HEIGHT = 800, 600


def _chromium() -> str:
    found = shutil.which("chromium") or shutil.which("chromium-browser")
    if found is None and Path("/usr/bin/chromium").exists():
        found = "/usr/bin/chromium"
    if found is None:
        if os.environ.get("CI"):
            pytest.fail(
                "headless Chromium is required in CI but was not found (apt-get install chromium)"
            )
        pytest.skip("chromium not installed")
    return found


def screenshot(page: Path, tmp_path: Path, name: str) -> np.ndarray:
    """Render a page from disk in headless Chromium (software WebGL) and return its RGB pixels."""
    png = tmp_path / f"{name}.png"
    profile = tmp_path / f"profile-{name}"
    command = [
        _chromium(),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader",  # WebGL on the CPU: no GPU in CI
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
        f"--user-data-dir={profile}",
        f"--screenshot={png}",
        f"--window-size={WIDTH},{HEIGHT}",
        "--virtual-time-budget=2500",
        page.resolve().as_uri(),
    ]
    result = subprocess.run(command, capture_output=True, text=True, timeout=180, check=False)
    assert png.exists(), f"no screenshot (exit {result.returncode}): {result.stderr[-2000:]}"
    return np.asarray(Image.open(png).convert("RGB"), dtype=float)


def hull_mask(pixels: np.ndarray) -> np.ndarray:
    """Pixels of the hull's amber (URDF colour (1, 0.72, 0.1), shaded): red > green >> blue."""
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    return (r > 110) & (r - b > 90) & (g > 0.45 * r) & (g < 0.95 * r)


def test_vehicle_is_drawn(tmp_path):
    vehicle = aiauv_pin.load_vehicle()
    run = synthetic_trajectory(vehicle, 6.0)
    page = playback.write_playback(vehicle, run, tmp_path / "playback.html", urdf=URDF)
    # the same page without the vehicle: path, grid and camera only
    commands = playback.read_commands(page.read_text(encoding="utf-8"))
    empty_commands = [
        c
        for c in commands
        if c["type"] != "set_animation" and not c["path"].startswith(viewer.LINKS)
    ]
    empty = tmp_path / "empty.html"
    empty.write_text(playback.html_page(empty_commands), encoding="utf-8")

    shown = screenshot(page, tmp_path, "playback")
    blank = screenshot(empty, tmp_path, "empty")
    assert shown.shape == blank.shape == (HEIGHT, WIDTH, 3)

    # the page rendered WebGL at all: the background gradient and the path are there in both
    assert np.ptp(blank[:, :, 2]) > 50

    hull = hull_mask(shown)
    assert hull_mask(blank).sum() == 0
    assert hull.sum() > 0.01 * WIDTH * HEIGHT, f"only {hull.sum()} hull pixels"
    # framed: the hull's pixels are around the middle of the view, not cut off at an edge
    rows, cols = np.nonzero(hull)
    assert 0.2 * WIDTH < cols.mean() < 0.8 * WIDTH
    assert 0.2 * HEIGHT < rows.mean() < 0.8 * HEIGHT
    # and the two screenshots differ where the hull is
    difference = np.abs(shown - blank).sum(axis=2)
    assert np.median(difference[hull]) > 100

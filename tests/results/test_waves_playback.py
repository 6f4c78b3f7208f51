"""The sea surface in the HTML playback (aiauv_pin.results.playback.surface_commands)."""

from __future__ import annotations

import math

import numpy as np

import aiauv_pin
from aiauv_hydro.currents import Current
from aiauv_hydro.waves import Waves
from aiauv_pin.results import playback


def test_surface_strips_heave_with_the_wave(tmp_path):
    vehicle = aiauv_pin.load_vehicle()
    sea = Waves(height=1.0, period=6.0, heading=math.pi, surface_z=5.0, phase=0.4)
    q0 = vehicle.neutral_configuration()
    run = aiauv_pin.simulate(
        vehicle, q0, np.zeros(vehicle.nv), 2.0, 0.01, current=Current.waves(sea)
    )
    commands = playback.playback_commands(vehicle, run, sea=sea)
    strips = [c for c in commands if c["type"] == "set_object" and "/surface/" in c["path"]]
    assert len(strips) == playback.SURFACE_STRIPS
    (animation,) = [c for c in commands if c["type"] == "set_animation"]
    tracks = {a["path"]: a["clip"]["tracks"][0] for a in animation["animations"]}
    k = (2.0 * math.pi / 6.0) ** 2 / 9.81
    for strip in strips:
        track = tracks[strip["path"]]
        times = np.array(track["times"])
        assert times[0] == 0.0 and times[-1] >= 2.0 - 1e-9
        assert np.allclose(np.diff(times), 1.0 / playback.SURFACE_FPS, atol=1e-4)
        xyz = np.array(track["values"]).reshape(-1, 3)
        theta = -k * xyz[:, 0] - 2.0 * math.pi / 6.0 * (times + run.t[0]) + 0.4  # heading -x
        np.testing.assert_allclose(xyz[:, 2], 5.0 + 0.5 * np.cos(theta), atol=1e-4)
    # no sea: no surface
    plain = playback.playback_commands(vehicle, run)
    assert not any("/surface/" in c.get("path", "") for c in plain)
    page = playback.write_playback(vehicle, run, tmp_path / "playback.html", sea=sea)
    assert "/aiauv/surface/0" in page.read_text(encoding="utf-8")

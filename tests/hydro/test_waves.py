"""Linear waves against closed forms (aiauv_hydro.waves; docs/source/waves.md).

Tolerances, stated before running:

* dispersion: residual of ``omega^2 = g k tanh(k h)`` below 1e-13 (relative); deep limit
  ``k = omega^2 / g`` to 1e-12 at ``k h > 20``; shallow limit ``k = omega / sqrt(g h)`` to 1e-4
  at ``k h = 0.01`` (the first neglected term is ``(k h)^2 / 6 = 1.7e-5``);
* kinematics: orbit radius ``A e^{k z}`` (deep) and ellipse semi-axes ``A cosh(k(z+h))/sinh(kh)``,
  ``A sinh(k(z+h))/sinh(kh)`` (finite depth) to 1e-12 relative (same formulas, rounding only);
* spectra: Pierson-Moskowitz variance ``H_s^2 / 16`` to 1e-5 (quadrature on a fine grid);
  JONSWAP to 2 % for ``1 <= gamma <= 7`` (DNV's normalising factor ``A_gamma`` is an
  approximation); components' ``sum a_i^2 / 2 = H_s^2 / 16`` to 1e-12;
* a 3 h record of 200 components: sample variance within 5 % of ``H_s^2 / 16`` (cross terms
  between components average out as ``1 / (d omega T)``), mean within 0.02 ``H_s``;
* acceleration = central difference of the velocity (step 1e-4 s) to 1e-6 of ``a omega^2``; the
  surface rises with the water, ``d eta / dt = w(z = 0)``, to the same tolerance;
* a stream-function (``fenton``) wave: velocity, acceleration and elevation equal to raschii's own
  (``FentonWave.velocity``, ``acceleration``, ``surface_elevation``) to 1e-12 relative to the
  largest value (same series, summed in another order).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from aiauv_hydro.currents import WAVES, Current, builtin_current, current_from_mapping
from aiauv_hydro.spec import HydroError
from aiauv_hydro.waves import (
    Waves,
    spectra,
    wave_acceleration,
    wave_elevation,
    wave_velocity,
    wavenumber,
)
from aiauv_hydro.waves.kinematics import elevation_series

G = 9.81


def test_dispersion_residual_and_limits():
    omega = np.linspace(0.05, 10.0, 400)
    for depth in (0.5, 3.0, 20.0, 200.0, 5000.0):
        k = wavenumber(omega, depth, G)
        residual = G * k * np.tanh(k * depth) - omega**2
        assert np.max(np.abs(residual) / omega**2) < 1e-13
    deep = wavenumber(omega, math.inf, G)
    np.testing.assert_array_equal(deep, omega**2 / G)
    big = wavenumber(omega[omega > 2.0], 50.0, G)  # k h > 20
    np.testing.assert_allclose(big, omega[omega > 2.0] ** 2 / G, rtol=1e-12)
    depth = 10.0
    k_shallow = 0.01 / depth
    omega_shallow = math.sqrt(G * k_shallow * math.tanh(k_shallow * depth))
    k = wavenumber(omega_shallow, depth, G)
    assert k == pytest.approx(k_shallow, rel=1e-13)
    assert k == pytest.approx(omega_shallow / math.sqrt(G * depth), rel=1e-4)


def _velocity(sea_parameters, t, x, y, z):
    return np.array(wave_velocity(t, x, y, z, sea_parameters))


def test_deep_water_orbits_are_circles_of_radius_a_exp_kz():
    sea = Waves(height=1.0, period=6.0, surface_z=5.0)
    p = sea.parameters()
    omega = 2.0 * math.pi / 6.0
    k = omega**2 / G
    for depth_below in (0.0, 2.0, 5.0, 20.0):
        z = 5.0 - depth_below
        radius = 0.5 * math.exp(-k * depth_below)
        for t in np.linspace(0.0, 6.0, 13):
            v = _velocity(p, t, 1.3, -0.4, z)
            assert math.hypot(v[0], v[2]) / omega == pytest.approx(radius, rel=1e-12)
            assert v[1] == 0.0


def test_finite_depth_ellipse_semi_axes():
    depth, amplitude, period = 8.0, 0.4, 7.0
    sea = Waves(height=2 * amplitude, period=period, depth=depth, heading=math.pi / 2)
    p = sea.parameters()
    omega = 2.0 * math.pi / period
    k = float(wavenumber(omega, depth, G))
    for z in (0.0, -1.0, -4.0, -8.0):
        horizontal = amplitude * math.cosh(k * (z + depth)) / math.sinh(k * depth)
        vertical = amplitude * math.sinh(k * (z + depth)) / math.sinh(k * depth)
        crest = _velocity(p, 0.0, 0.0, 0.0, z)  # theta = 0: heading +y, horizontal speed at max
        quarter = _velocity(p, -period / 4.0, 0.0, 0.0, z)  # theta = pi / 2: vertical at max
        assert crest[1] / omega == pytest.approx(horizontal, rel=1e-12)
        assert abs(crest[0]) < 1e-15 and abs(crest[2]) < 1e-12 * omega * amplitude
        assert quarter[2] / omega == pytest.approx(vertical, rel=1e-12, abs=1e-15)
    below = _velocity(p, 0.3, 0.0, 0.0, -30.0)  # below the floor: the floor's kinematics
    np.testing.assert_array_equal(below, _velocity(p, 0.3, 0.0, 0.0, -depth))
    above = _velocity(p, 0.3, 0.0, 0.0, 0.6)  # above the mean level: the level's
    np.testing.assert_array_equal(above, _velocity(p, 0.3, 0.0, 0.0, 0.0))


def test_spectra_variance():
    hs, tp = 2.0, 9.0
    wp = 2.0 * math.pi / tp
    omega = np.linspace(0.05 * wp, 60.0 * wp, 2_000_001)
    pm = np.trapezoid(spectra.pierson_moskowitz(omega, hs, tp), omega)
    assert pm == pytest.approx(hs**2 / 16.0, rel=1e-5)
    for gamma in (1.0, 2.0, 3.3, 5.0, 7.0):
        variance = np.trapezoid(spectra.jonswap(omega, hs, tp, gamma), omega)
        assert variance == pytest.approx(hs**2 / 16.0, rel=0.02)
    assert spectra.default_peak_enhancement(1.0, 3.0) == 5.0
    assert spectra.default_peak_enhancement(1.0, 6.0) == 1.0
    assert spectra.default_peak_enhancement(1.0, 4.0) == pytest.approx(math.exp(5.75 - 4.6))


@pytest.mark.parametrize("spreading", ["none", "cos_n", "cos_2s"])
def test_components_carry_the_variance_and_seeds_reproduce(spreading):
    options = dict(type="jonswap", height=1.5, period=8.0, components=150, spreading=spreading)
    sea = Waves(seed=7, **options)
    assert sea.variance == pytest.approx(1.5**2 / 16.0, rel=1e-12)
    np.testing.assert_array_equal(sea.parameters(), Waves(seed=7, **options).parameters())
    assert not np.array_equal(sea.parameters(), Waves(seed=8, **options).parameters())
    directions = sea.table[3]
    if spreading == "none":
        np.testing.assert_array_equal(directions, 0.0)
    else:
        half = math.pi / 2 if spreading == "cos_n" else math.pi
        assert np.all(np.abs(directions) < half) and np.std(directions) > 0.1
        assert abs(np.mean(directions)) < 0.05  # symmetric about the main direction


def test_spreading_densities_integrate_to_one():
    theta = np.linspace(-math.pi, math.pi, 200_001)
    for kind, exponent in (("cos_n", 2.0), ("cos_n", 6.0), ("cos_2s", 1.0), ("cos_2s", 15.0)):
        integral = np.trapezoid(spectra.spreading_density(theta, kind, exponent), theta)
        assert integral == pytest.approx(1.0, rel=1e-6)


def test_long_record_has_the_sea_variance():
    hs = 1.5
    sea = Waves(type="jonswap", height=hs, period=8.0, components=200, seed=3)
    times = np.arange(0.0, 3 * 3600.0, 0.5)
    eta = np.empty_like(times)
    elevation_series(times, 2.0, -1.0, sea.parameters(), eta)
    assert np.var(eta) == pytest.approx(hs**2 / 16.0, rel=0.05)
    assert abs(np.mean(eta)) < 0.02 * hs


@pytest.mark.parametrize(
    "sea",
    [
        Waves(height=1.0, period=6.0, heading=0.7, depth=15.0, phase=0.3),
        Waves(type="pierson_moskowitz", height=1.0, period=7.0, spreading="cos_n", depth=40.0),
        Waves(type="jonswap", height=1.5, period=8.0, spreading="cos_2s", spreading_exponent=4),
    ],
)
def test_acceleration_is_the_time_derivative_of_the_velocity(sea):
    p = sea.parameters((0.2, -0.1, 0.0))
    a_max = float(np.max(sea.table[0] * sea.table[1] ** 2))
    step = 1e-4
    for t, x, y, z in ((0.0, 0.0, 0.0, -1.0), (3.7, 5.0, -2.0, -6.0), (11.1, -3.0, 8.0, -0.2)):
        forward = np.array(wave_velocity(t + step, x, y, z, p))
        backward = np.array(wave_velocity(t - step, x, y, z, p))
        difference = (forward - backward) / (2.0 * step)
        np.testing.assert_allclose(wave_acceleration(t, x, y, z, p), difference, atol=1e-6 * a_max)
        rise = (wave_elevation(t + step, x, y, p) - wave_elevation(t - step, x, y, p)) / (2 * step)
        w_surface = wave_velocity(t, x, y, 0.0, p)[2]
        assert rise == pytest.approx(w_surface, abs=1e-6 * a_max)


def test_waves_current_dispatch_and_description():
    sea = Waves(height=1.0, period=6.0, heading=math.pi, surface_z=5.0)
    water = Current.waves(sea, velocity=(0.1, 0.0, 0.0))
    assert water.kind_code == WAVES and water.user_function is None
    point = (2.0, 1.0, 0.0)
    expected = np.array(wave_velocity(1.5, *point, water.parameters))
    np.testing.assert_array_equal(builtin_current(WAVES, 1.5, *point, water.parameters), expected)
    np.testing.assert_array_equal(water.velocity(1.5, point), expected)
    still = np.array(wave_velocity(1.5, *point, sea.parameters()))
    np.testing.assert_allclose(expected - still, [0.1, 0.0, 0.0], atol=1e-15)
    assert water.describe()["waves"] == sea.describe()
    assert Waves.from_mapping(sea.describe()) == sea
    with pytest.raises(HydroError, match="reads 13 parameters, got 14"):
        Current(wave_velocity, np.append(water.parameters, 0.0), "waves")
    with pytest.raises(HydroError, match="unknown current type 'waves'"):
        current_from_mapping({"type": "waves"})  # waves have their own table, [waves]


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"height": -1.0}, r"^waves\.height: expected >= 0, got -1\.0$"),
        ({"height": 1.0, "period": 2.0}, r"^waves\.height: H / L = .* breaking limit 0\.142"),
        ({"height": 1.0, "period": 3.0, "depth": 0.9}, r"^waves\.height: .*breaking limit 0\.0"),
        ({"period": 0.0}, r"^waves\.period: expected > 0, got 0\.0$"),
        ({"depth": -3.0}, r"^waves\.depth: expected > 0"),
        ({"type": "jonswap", "height": 4.0, "period": 7.0}, r"^waves\.period: T_p = 7 s .*3\.6"),
        ({"type": "jonswap", "peak_enhancement": 9.0}, r"^waves\.peak_enhancement: .*\[1, 7\]"),
        ({"type": "jonswap", "components": 0}, r"^waves\.components: expected 1 to"),
        ({"type": "swell"}, r"^waves\.type: unknown sea 'swell'"),
        ({"type": "jonswap", "spreading": "cos"}, r"^waves\.spreading: unknown spreading"),
    ],
)
def test_bad_parameters_get_one_line(options, message):
    with pytest.raises(HydroError, match=message) as caught:
        Waves(**options)
    assert "\n" not in str(caught.value)


def test_point_below_the_floor_and_unknown_key():
    sea = Waves(depth=30.0, surface_z=5.0)
    sea.check_point(-24.9, "the start")
    with pytest.raises(HydroError, match=r"^waves\.depth: the sea floor \(z = -25 m\) is above"):
        sea.check_point(-26.0, "the start")
    with pytest.raises(HydroError, match=r"^waves: unknown key 'amplitude'$"):
        Waves.from_mapping({"amplitude": 1.0})


def test_point_above_the_surface():
    with pytest.raises(HydroError, match=r"^waves\.surface_z: the start \(z = 2 m\) is above"):
        Waves().check_point(2.0, "the start")


def test_fenton_wave_is_raschii_s():
    raschii = pytest.importorskip("raschii")
    height, period, depth = 2.0, 7.0, 10.0
    sea = Waves(type="fenton", height=height, period=period, depth=depth, order=12)
    wave = raschii.FentonWave(height, depth, period=period, N=12)
    p = sea.parameters()
    scale = float(np.max(np.abs(wave.velocity(np.linspace(0, wave.length, 50), depth))))
    for x, zeta, t in ((0.0, 0.0, 0.0), (3.0, -2.0, 1.1), (-7.0, -9.0, 2.5), (20.0, -4.0, 5.0)):
        at = (np.array([x]), np.array([zeta + depth]), t)  # raschii: z from the floor, +x
        ours = np.array(wave_velocity(t, x, 0.0, zeta, p))[[0, 2]]
        np.testing.assert_allclose(ours, np.ravel(wave.velocity(*at)), atol=1e-12 * scale)
        ours = np.array(wave_acceleration(t, x, 0.0, zeta, p))[[0, 2]]
        reference = np.ravel(wave.acceleration(*at))
        np.testing.assert_allclose(ours, reference, atol=1e-12 * scale * sea.table[1][0])
        eta = wave_elevation(t, x, 0.0, p)
        assert eta == pytest.approx(wave.surface_elevation(np.array([x]), t)[0] - depth, abs=1e-12)
    assert sea.describe() == {
        "type": "fenton",
        "height": 2.0,
        "period": 7.0,
        "heading": 0.0,
        "depth": 10.0,
        "surface_z": 0.0,
        "phase": 0.0,
        "order": 12,
    }
    with pytest.raises(HydroError, match=r"^waves\.depth: a fenton wave needs a finite depth$"):
        Waves(type="fenton")

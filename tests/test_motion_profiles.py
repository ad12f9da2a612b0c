"""Time laws: boundary values, derivatives against finite differences, peaks against a dense grid."""

import math

import numpy as np
import pytest

from wbik.errors import WbikError
from wbik.motion.profiles import LAWS, time_law

TAU = np.linspace(0.0, 1.0, 200001)


@pytest.mark.parametrize("name", sorted(LAWS))
def test_ends_and_monotonic(name):
    law = time_law(name)
    assert law.s(0.0) == pytest.approx(0.0, abs=1e-15)
    assert law.s(1.0) == pytest.approx(1.0, abs=1e-15)
    assert np.all(np.diff(law.s(TAU)) >= 0.0)


@pytest.mark.parametrize("name", sorted(LAWS))
def test_derivatives_match_finite_differences(name):
    law = time_law(name)
    tau = np.linspace(0.01, 0.99, 97)
    h = 1e-6
    numeric_first = (law.s(tau + h) - law.s(tau - h)) / (2 * h)
    numeric_second = (law.ds(tau + h) - law.ds(tau - h)) / (2 * h)
    assert np.allclose(law.ds(tau), numeric_first, atol=1e-7)
    assert np.allclose(law.dds(tau), numeric_second, atol=1e-5)


@pytest.mark.parametrize("name", ["cubic", "quintic"])
def test_rest_to_rest(name):
    law = time_law(name)
    assert law.ds(np.array([0.0, 1.0])) == pytest.approx([0.0, 0.0], abs=1e-15)
    if name == "quintic":  # minimum jerk also starts and ends with zero acceleration
        assert law.dds(np.array([0.0, 1.0])) == pytest.approx([0.0, 0.0], abs=1e-15)


def test_peaks_are_the_hand_values():
    # cubic: s' = 6 t (1 - t) peaks at 3/2; |s''| = |6 - 12 t| peaks at 6.
    # quintic: s' = 30 t^2 (1 - t)^2 peaks at 30/16; s'' peaks at t = 1/2 - sqrt(3)/6.
    assert LAWS["cubic"].peak_velocity == pytest.approx(1.5)
    assert LAWS["cubic"].peak_acceleration == pytest.approx(6.0)
    assert LAWS["quintic"].peak_velocity == pytest.approx(30 / 16)
    t = 0.5 - math.sqrt(3) / 6
    assert LAWS["quintic"].peak_acceleration == pytest.approx(60 * t * (1 - t) * (1 - 2 * t))
    for law in (LAWS["cubic"], LAWS["quintic"]):
        assert np.max(law.ds(TAU)) == pytest.approx(law.peak_velocity, rel=1e-9)
        assert np.max(np.abs(law.dds(TAU))) == pytest.approx(law.peak_acceleration, rel=1e-8)
    assert math.isinf(LAWS["linear"].peak_acceleration)


@pytest.mark.parametrize("name", sorted(LAWS))
def test_inverse(name):
    law = time_law(name)
    tau = np.linspace(0.0, 1.0, 51)
    assert np.allclose(law.inverse(law.s(tau)), tau, atol=1e-9)


def test_aliases_and_unknown_name():
    assert time_law("minimum_jerk") is LAWS["quintic"]
    with pytest.raises(WbikError, match="known time laws"):
        time_law("trapezoid")


def test_the_laws_are_the_polynomials_of_the_module_docstring():
    tau = np.linspace(0.0, 1.0, 101)
    np.testing.assert_allclose(LAWS["linear"].s(tau), tau, atol=1e-15)
    np.testing.assert_allclose(LAWS["cubic"].s(tau), 3 * tau**2 - 2 * tau**3, atol=1e-15)
    np.testing.assert_allclose(LAWS["quintic"].s(tau), 10 * tau**3 - 15 * tau**4 + 6 * tau**5, atol=1e-14)
    np.testing.assert_allclose(LAWS["quintic"].dds(tau), 60 * tau * (1 - tau) * (1 - 2 * tau), atol=1e-13)

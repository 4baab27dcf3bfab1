"""The averaging, closed-form and KapitzaPendulum spellings before kapitza 0.2 (issue 20):
each still works, warns with a DeprecationWarning that names the new call and points at
the caller's line, and gives the very numbers of the new call."""
import math
import warnings

import numpy as np
import pytest

import kapitza.closed_forms as closed_forms
from kapitza.averaging import average
from kapitza.pendulum import KapitzaPendulum
from lagrange_core import problems

P = {"m": 1.0, "l": 1.0, "g": 9.81}
DRIVE = {**P, "A": 0.05, "omega": 150.0}


@pytest.fixture(scope="module")
def vertical():
    return average(problems.driven_pendulum("vertical"))


def same(old, new):
    """Two results (arrays, floats or dataclasses of them) hold identical numbers."""
    if hasattr(old, "__dataclass_fields__"):
        assert type(old) is type(new)
        for name in old.__dataclass_fields__:
            same(getattr(old, name), getattr(new, name))
    elif isinstance(old, (tuple, list)):
        assert len(old) == len(new)
        for a, b in zip(old, new, strict=True):
            same(a, b)
    elif isinstance(old, (str, type(None), bool)):
        assert old == new
    else:
        np.testing.assert_array_equal(old, new)


def test_average_omega_keyword_and_position(vertical):
    system = problems.driven_pendulum("vertical")
    with pytest.warns(DeprecationWarning, match=r"average\(omega=\.\.\.\).*"
                                                r"average\(frequency=\.\.\.\)"):
        old = average(system, omega="omega")
    with pytest.warns(DeprecationWarning, match="frequency by position"):
        positional = average(system, "omega")
    new = average(system, frequency="omega")
    assert old is new and positional is new            # the same (cached) AveragedSystem
    same(old.slow_modes(DRIVE, [math.pi]), vertical.slow_modes(DRIVE, [math.pi]))
    with pytest.raises(TypeError, match="both omega= .* and frequency="):
        average(system, omega="omega", frequency="omega")


def test_averaged_system_stability_window(vertical):
    omega = np.array([10.0, 50.0, 100.0])
    with pytest.warns(DeprecationWarning, match=r"stability_window.*AveragedSystem\.window"):
        old = vertical.stability_window(omega, [math.pi], params=P, A_max=0.1)
    same(old, vertical.window(P, [math.pi], omega=omega, A_range=(0.0, 0.1)))
    assert math.isnan(old.A_min[0]) and old.A_min[2] * 100.0 == pytest.approx(
        math.sqrt(2 * 9.81), rel=1e-12)
    with pytest.warns(DeprecationWarning):
        unbounded = vertical.stability_window(omega, [math.pi], params=P)
    same(unbounded, vertical.window(P, [math.pi], omega=omega))
    assert vertical.stability_window.__deprecated__.startswith("AveragedSystem.window")


def test_minimum_amplitude_upper(vertical):
    params = {**P, "omega": 100.0}
    with pytest.warns(DeprecationWarning, match=r"upper=.*A_range=\(0\.0, upper\)"):
        old = vertical.minimum_amplitude(params, [math.pi], upper=1.0)
    new = vertical.minimum_amplitude(params, [math.pi], A_range=(0.0, 1.0))
    assert old == new and new * 100.0 == pytest.approx(math.sqrt(2 * 9.81), rel=1e-10)
    # the amplitude's name by position, as kapitza.verification wrote it
    with pytest.warns(DeprecationWarning, match="amplitude by position"):
        assert vertical.minimum_amplitude(params, [math.pi], "A") == \
            vertical.minimum_amplitude(params, [math.pi], amplitude="A")
    with pytest.raises(ValueError, match="up to 0.01"):
        vertical.minimum_amplitude(params, [math.pi], A_range=(0.0, 0.01))


def test_options_by_position_and_state_before_params(vertical):
    with pytest.warns(DeprecationWarning, match="warn by position"):
        old = vertical.slow_modes(DRIVE, [math.pi], False)
    same(old, vertical.slow_modes(DRIVE, [math.pi], warn=False))
    with pytest.warns(DeprecationWarning, match=r"evaluate\(q, params\).*evaluate\(params, q\)"):
        old = vertical.evaluate([math.pi], DRIVE)
    same(old, vertical.evaluate(DRIVE, [math.pi]))
    with pytest.warns(DeprecationWarning, match=r"mean_drag\(q, params\)"):
        old = vertical.mean_drag({"theta": 3.0}, DRIVE)                  # q as a dict too
    same(old, vertical.mean_drag(DRIVE, [3.0]))


def test_pendulum_stability_window():
    omega = np.array([30.0, 60.0, 500.0])
    with pytest.warns(DeprecationWarning, match=r"pendulum_stability_window.*pendulum_window"):
        old = closed_forms.pendulum_stability_window(omega, l=0.8, damping=0.3, tol=1e-9)
    same(old, closed_forms.pendulum_window(omega, l=0.8, damping=0.3, tol=1e-9))
    assert old.method == "floquet"


def test_averaging_window():
    omega = np.array([30.0, 60.0, 500.0])
    with pytest.warns(DeprecationWarning, match=r"averaging_window.*method='averaging'"):
        old = closed_forms.averaging_window(omega, l=0.8, damping=0.3, order=2)
    same(old, closed_forms.pendulum_window(omega, l=0.8, damping=0.3, method="averaging",
                                           order=2))
    with pytest.warns(DeprecationWarning):
        first = closed_forms.averaging_window(60.0, order=1)
    same(first, closed_forms.pendulum_window(60.0, method="averaging", order=1))
    assert first.method == "averaging" and first.order == 1


def test_pendulum_effective_potential_old_order():
    theta = np.linspace(-3.0, 3.0, 7)
    with pytest.warns(DeprecationWarning, match=r"\(theta, A, omega\).*\(A, omega, theta=theta\)"):
        old = closed_forms.pendulum_effective_potential(theta, 0.05, 150.0, l=0.7,
                                                        drive="horizontal")
    new = closed_forms.pendulum_effective_potential(0.05, 150.0, theta=theta, l=0.7,
                                                    drive="horizontal")
    same(old, new)
    np.testing.assert_allclose(new, -9.81 * 0.7 * np.cos(theta)
                               + (0.05 * 150.0 * np.cos(theta)) ** 2 / 4, rtol=1e-14)
    with pytest.raises(TypeError, match="theta"):
        closed_forms.pendulum_effective_potential(0.05, 150.0)


def test_kapitza_pendulum_stability_window():
    pend = KapitzaPendulum(l=0.9, damping=0.1)
    with pytest.warns(DeprecationWarning, match=r"KapitzaPendulum\.window"):
        old = pend.stability_window([40.0, 80.0], "inverted", 1e-9)
    same(old, pend.window([40.0, 80.0], "inverted", tol=1e-9))
    with pytest.warns(DeprecationWarning):
        old = pend.stability_window(80.0, method="averaging", order=1)
    same(old, pend.window(80.0, method="averaging", order=1))


def test_kapitza_pendulum_simulate_old_order():
    pend = KapitzaPendulum()
    A, omega = 0.05, 2 * math.pi * 60
    t_eval = np.linspace(0.0, 0.5, 11)
    with pytest.warns(DeprecationWarning, match=r"simulate\(theta0, theta_dot0, t_span, A, "
                                                r"omega\).*simulate\(A, omega, theta0"):
        old = pend.simulate(math.pi - 0.1, 0.2, (0.0, 0.5), A, omega, t_eval=t_eval)
    new = pend.simulate(A, omega, math.pi - 0.1, 0.2, (0.0, 0.5), t_eval=t_eval)
    same(old.q, new.q)
    same(old.qdot, new.qdot)
    # the drive by keyword after the old positional state, as scripts wrote it
    with pytest.warns(DeprecationWarning):
        keywords = pend.simulate(math.pi - 0.1, 0.2, (0.0, 0.5), A=A, omega=omega,
                                 t_eval=t_eval)
    same(keywords.q, new.q)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pend.simulate(A=A, omega=omega, theta0=math.pi - 0.1, theta_dot0=0.2,
                      t_span=(0.0, 0.5), t_eval=t_eval)


def test_kapitza_pendulum_effective_potential_old_order():
    pend = KapitzaPendulum(l=0.6)
    theta = np.array([0.0, 1.0, math.pi])
    with pytest.warns(DeprecationWarning, match=r"effective_potential\(theta, A, omega\)"):
        old = pend.effective_potential(theta, 0.05, 150.0)
    same(old, pend.effective_potential(0.05, 150.0, theta=theta))


def test_kapitza_pendulum_options_by_position():
    pend = KapitzaPendulum()
    with pytest.warns(DeprecationWarning, match="order by position"):
        old = pend.averaged(0.05, 150.0, 2)
    same(old, pend.averaged(0.05, 150.0, order=2))
    with pytest.warns(DeprecationWarning, match="tol by position"):
        old = pend.floquet(0.05, 150.0, "inverted", 1e-8)
    same(old, pend.floquet(0.05, 150.0, "inverted", tol=1e-8))


def test_warnings_point_at_the_callers_line():
    """``-W error::DeprecationWarning`` must find the user's line, not kapitza's."""
    pend = KapitzaPendulum()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pend.stability_window(100.0)
        pend.effective_potential(1.0, 0.05, 150.0)
        closed_forms.averaging_window(100.0)
        closed_forms.pendulum_stability_window(100.0)
        average(problems.driven_pendulum("vertical"), omega="omega")
    deprecations = [w for w in caught if issubclass(w.category, DeprecationWarning)]
    assert len(deprecations) == 5
    assert {w.filename for w in deprecations} == {__file__}

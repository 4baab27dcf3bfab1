"""KapitzaPendulum at the edges (issue 10, items 10 and 12): the physical pendulum against
a rigid body stated independently in lagrange_core, inputs of every kind, empty grids."""
import math

import numpy as np
import pytest

import kapitza
from kapitza import KapitzaPendulum
from lagrange_core import problems

L_ROD, G = 0.9, 9.81


@pytest.fixture(scope="module")
def rod_system():
    """A uniform rod on a vertically shaken pivot, as a lagrange_core RigidBody."""
    return problems.physical_pendulum(driven=True)


def rod_params(A, omega, m=2.0):
    return dict(m=m, I_c=m * L_ROD**2 / 12, d=L_ROD / 2, g=G, A=A, omega=omega)


def test_rod_motion_equals_the_rigid_body(rod_system):
    """θ(t) of KapitzaPendulum.rod(L) (the point mass at l_eq = 2L/3) equals the rigid
    body's, integrated from its own Lagrangian (I ω²/2 of the body + m v_c²/2)."""
    pend = KapitzaPendulum.rod(L_ROD, g=G)
    assert pend.l == pytest.approx(2 * L_ROD / 3, rel=1e-15)
    A, omega = 0.04, 2 * math.pi * 50
    t_eval = np.linspace(0.0, 2.0, 41)
    ours = pend.simulate(A, omega, math.pi - 0.2, 0.0, (0.0, 2.0), rtol=1e-11, t_eval=t_eval)
    body = rod_system.simulate([math.pi - 0.2], [0.0], (0.0, 2.0), rod_params(A, omega),
                               rtol=1e-11, t_eval=t_eval)
    # the same equation of motion up to the rounding of its coefficient (l_eq = 2L/3 against
    # I_c/(m d) + d): at rtol 1e-11 both take the same steps, so they differ by rounding
    # carried along 2 s near the upright (measured 6.9e-14 rad), not by the tolerance;
    # 5e-12 keeps ×70 for other CPUs
    np.testing.assert_allclose(ours.q[:, 0], body.q[:, 0], rtol=0, atol=5e-12)
    assert np.max(np.abs(ours.q[:, 0] - math.pi)) < 0.25          # held upright


def test_rod_window_equals_the_rigid_bodys_floquet(rod_system):
    """The rod's exact window edges (Mathieu, l_eq) are where the rigid body's own
    monodromy (kapitza.floquet_point on the RigidBody system) changes stability."""
    pend = KapitzaPendulum.rod(L_ROD, g=G)
    omega = 2 * math.pi * 30
    win = pend.window(omega)
    lower, upper = win.A_min, win.A_max

    def stable(A):
        return kapitza.floquet_point(rod_system, rod_params(A, omega), [math.pi]).stable

    assert stable(1.002 * lower) and stable(0.998 * upper)          # just inside
    assert not stable(0.998 * lower) and not stable(1.002 * upper)  # just outside


def test_physical_pendulum_equivalent_length_and_bad_values():
    assert KapitzaPendulum.physical(2.0, 0.5, 4.0).l == 1.0
    with pytest.raises(ValueError, match="distance must be > 0"):
        KapitzaPendulum.physical(1.0, 0.0)
    with pytest.raises(ValueError, match="inertia must be a real number.*a string"):
        KapitzaPendulum.physical("1", 0.5)


@pytest.mark.parametrize("value", [np.int64(1), np.float32(1.0), np.array(1.0)])
def test_numbers_of_every_kind(value):
    assert KapitzaPendulum(l=value).l == 1.0


def test_strings_booleans_and_bad_drives_are_refused():
    with pytest.raises(ValueError, match="l must be a finite number > 0"):
        KapitzaPendulum(l=True)
    pend = KapitzaPendulum(l=1.0)
    with pytest.raises(ValueError, match="A must be a number"):
        pend.averaged(A="0.01", omega=100.0)
    with pytest.raises(ValueError, match="A must be a number"):
        pend.floquet(A="0.01", omega=100.0)
    with pytest.raises(ValueError, match="A must be finite and ≥ 0"):
        pend.simulate(-0.1, 100.0, 3.0, 0.0, (0, 0.1))
    with pytest.raises(ValueError, match="omega must be finite and > 0"):
        pend.simulate(0.1, 0.0, 3.0, 0.0, (0, 0.1))
    with pytest.raises(ValueError, match="method must be 'floquet'.*got 'exact'"):
        pend.window(100.0, method="exact")
    with pytest.raises(ValueError, match="about='inverted' only"):
        pend.window(100.0, "hanging", method="averaging")
    with pytest.raises(ValueError, match="horizontal drive"):
        KapitzaPendulum(drive="horizontal").window(100.0)


def test_empty_axes_give_empty_maps():
    pend = KapitzaPendulum(l=1.0)
    for A, omega, shape in (([], [100.0], (0, 1)), ([0.1], [], (1, 0)), ([], [], (0, 0))):
        m = pend.stability_map(A, omega)
        assert m.stable.shape == shape and len(m.to_dataframe()) == 0
    assert KapitzaPendulum(l=1.0, damping=0.2).stability_map([], [50.0]).stable.shape == (0, 1)
    assert np.size(pend.averaged(A=[], omega=100.0).inverted.stable) == 0


@pytest.mark.parametrize("call, shown", [
    (lambda: kapitza.KapitzaPendulum().measure(np.float64(-1.0), 100.0, 3.0), "got -1.0."),
    (lambda: kapitza.pendulum_window(np.float64(0.0)), "got 0.0."),
    (lambda: kapitza.KapitzaPendulum(l=np.array(-2.0)), "got -2.0."),
])
def test_api_messages_show_plain_numbers(call, shown):
    """Issue 22.8 in the API (the CLI cleans its own messages): a numpy scalar or 0-d array
    is shown as the number, never ``array(-1.)`` or ``np.float64(0.0)``."""
    with pytest.raises(ValueError) as info:
        call()
    message = str(info.value)
    assert shown in message and "array(" not in message and "np.float" not in message

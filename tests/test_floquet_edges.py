"""Floquet and Mathieu edge cases (issue 10, items 6–8): the stable flag of undamped
systems with 3+ coordinates, slow drives and huge amplitudes, progress and Ctrl-C.

Independent references: the Mathieu monodromy trace by RK4 (kapitza.mathieu, another
integrator on another form of the equation), scipy.integrate.solve_ivp on the system's
compiled Jacobian (tests/helpers.py), and closed forms (the undriven inverted pendulum
grows by exactly e^(ω0 T) per period).
"""
import math

import numpy as np
import pytest
from helpers import G, L, W0

from kapitza import floquet as fq
from kapitza import mathieu as mm
from kapitza.pendulum import KapitzaPendulum


@pytest.fixture(scope="module")
def pendulum():
    return KapitzaPendulum(l=L, g=G)


# -- item 7: slow drives, huge amplitudes ----------------------------------------------

@pytest.mark.parametrize("A, w", [(1e3, 0.5), (1e3, 60.0), (1e4, 2.0), (1e4, 10.0)])
def test_huge_amplitude_growth_against_mathieu(pendulum, A, w):
    # these points raised SystemError (LinAlgError: singular matrix) from inside numba
    r = pendulum.floquet(A, w)
    a, q, _ = mm.mathieu_parameters(A, w, L, G, 0.0, "inverted")
    _, log_tr, _ = mm.mathieu_monodromy_trace(a, q, tol=1e-12)
    assert not r.stable and r.flags == ()
    assert r.log_growth == pytest.approx(float(log_tr), rel=1e-10)     # |λ| ≈ |tr| when huge


def test_slow_drive_point_is_reported_not_raised(pendulum):
    # ω = 1e-300: T = 6e300 s; the drive's A ω² vanishes, so the upright pendulum falls
    # exactly as the undriven one: |λ| = e^(ω0 T) per period
    w = 1e-300
    r = pendulum.floquet(0.1, w)
    assert not r.stable and r.boundary == "T"
    assert r.log_growth == pytest.approx(W0 * 2 * math.pi / w, rel=1e-12)
    assert len(r.flags) == 1 and "not integrated" in r.flags[0] and "estimate" in r.flags[0]
    # the hanging pendulum cannot be decided this way: said so, not claimed stable
    h = pendulum.floquet(0.1, w, about="hanging")
    assert not h.stable and "undecided" in h.flags[0]


def test_one_bad_point_does_not_abort_the_grid(pendulum):
    A = np.array([0.05, 0.2, 1e4])
    w = np.array([1e-300, 60.0, 2.0])
    g = fq.floquet_grid(pendulum.system, dict(pendulum.params(0.0, 1.0), A=A[:, None],
                                              omega=w[None, :]), [math.pi])
    assert g.shape == (3, 3)
    # the ordinary points equal their own computation, with no flags
    for i in range(3):
        for j in (1, 2):
            alone = pendulum.floquet(A[i], w[j])
            assert g.point((i, j)).trace == pytest.approx(alone.trace, rel=1e-12)
            assert g.stable[i, j] == alone.stable and g.flags[3 * i + j] == ()
    assert g.stable[1, 1] and not g.stable[:, 0].any()
    assert np.allclose(g.log_growth[:, 0], W0 * 2 * math.pi / w[0], rtol=1e-12)
    assert all("not integrated" in g.flags[3 * i][0] for i in range(3))
    assert np.all(g.margin[:, 0] == np.inf)           # e^(1e301): certainly unstable
    m = fq.stability_map(pendulum.system, dict(m=1.0, l=L, g=G), [math.pi], A, w)
    assert m.flagged_points == 3 and np.isfinite(m.error_estimate)
    assert m.stable.tolist() == g.stable.tolist()

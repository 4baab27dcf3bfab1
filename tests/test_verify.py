"""Verification (issue 11.4): averaging, Floquet and simulation compared point by point.

The pendulum's grid spans the lower (Kapitza) boundary, with two frequencies placed on it:
at ω_in the amplitude 3 cm lies 0.1 % above the exact edge (stable, but a release 0.1 rad
from the upright lies beyond the separatrix, a² > 2δ: it falls), at ω_out 5 cm lies 0.01 %
below it (unstable, first-order averaging still calls it stable).  Those are the only
disagreements, and they lie at the boundary.
"""
import math

import numpy as np
import pytest
import scipy.optimize
import sympy as sp

import kapitza
from kapitza import KapitzaPendulum, Verification
from kapitza.verification import fit_order
from lagrange_core import problems
from lagrange_core import t as t_sym

G, L = 9.81, 1.0
PEND = KapitzaPendulum(l=L, g=G)
W0 = PEND.omega0
RELEASE = 0.1                       # rad from the upright
#: Floquet and simulation may disagree only this close to a boundary (relative, in A):
#: the separatrix of a release at angle a lies a²/4 = 0.25 % above the lower edge, and a
#: point 0.1 % below it grows by e^(σt) with σ² ≈ 2 ω0² δ, too slowly to matter beyond;
#: four times a²/4.
NEAR = RELEASE**2
A_GRID = np.array([0.01, 0.02, 0.03, 0.05, 0.08, 0.12])


def _on_edge(A):
    """ω (rad/s) at which the exact lower edge of the window is A."""
    return scipy.optimize.brentq(lambda w: float(PEND.window(w).A_min) - A, 20.0,
                                 2000.0, xtol=1e-13, rtol=1e-14)


@pytest.fixture(scope="module")
def pendulum():
    w_in, w_out = _on_edge(0.03 / 1.001), _on_edge(0.05 * 1.0001)
    omega = np.array([2 * math.pi * 10, w_out, w_in, 2 * math.pi * 30, 2 * math.pi * 45,
                      2 * math.pi * 60])
    return PEND.verify(A_GRID[:, None], omega[None, :], theta0=math.pi - RELEASE,
                       periods=1000)


@pytest.fixture(scope="module")
def chain_verification():
    a, w = sp.symbols("A omega", positive=True)
    chain = problems.n_link_pendulum(2, pivot=(0, a * sp.cos(w * t_sym)))
    params = dict(g=G, l1=1.0, l2=1.0, m1=1.0, m2=1.0)
    return kapitza.verify(chain, params, [math.pi, math.pi], A=np.array([0.01, 0.02, 0.03,
                                                                          0.05])[:, None],
                          omega=np.array([200.0, 300.0, 400.0])[None, :], periods=600)


def test_pendulum_grid_classifications(pendulum):
    v = pendulum
    assert isinstance(v, Verification) and v.shape == (6, 6)
    assert v.methods == ("averaging", "averaging_2", "floquet", "simulation")
    # the exact window decides Floquet's classification: A_min < A < A_max
    edges = PEND.window(v.omega[0])
    np.testing.assert_array_equal(v.stable_floquet, (v.A > edges.A_min) & (v.A < edges.A_max))
    assert 0 < v.stable_floquet.sum() < v.stable_floquet.size
    assert set(np.unique(v.simulation_status)) <= {"finished", "left_band"}
    # the two points placed on the boundary, located
    np.testing.assert_allclose(v.boundary_distance[2, 2], 1 - 1 / 1.001, rtol=1e-6)
    np.testing.assert_allclose(v.boundary_distance[3, 1], 1e-4, rtol=1e-4)
    others = np.ones(v.shape, bool)
    others[2, 2] = others[3, 1] = False
    assert np.all(v.boundary_distance[others] > 0.05)


def test_floquet_and_simulation_disagree_only_at_the_boundary(pendulum):
    v = pendulum
    compared, agree = v.compare("floquet", "simulation")
    assert compared.all()
    bad = ~agree
    assert bad.sum() >= 1
    assert np.all(v.boundary_distance[bad] < NEAR), v.boundary_distance[bad]
    # the release beyond the separatrix of the point 0.1 % inside the window falls
    assert v.stable_floquet[2, 2] and not v.stable_simulation[2, 2]
    # every disagreement is in the table, located
    table = v.disagreements
    rows = table[(table["first"] == "floquet") & (table["second"] == "simulation")]
    assert len(rows) == bad.sum()
    assert np.all(rows.boundary_distance < NEAR)
    np.testing.assert_allclose(rows.A_over_l, v.A[bad] / L)
    np.testing.assert_allclose(rows.omega_over_omega0, v.omega[bad] / W0)
    # where both are stable the slow frequencies agree within the stated errors
    stats = v.agreement.set_index(["first", "second", "quantity"])
    assert stats.loc[("floquet", "simulation", "omega_slow"), "fraction"] == 1.0
    assert stats.loc[("floquet", "simulation", "omega_slow"), "compared"] >= 15


def test_averaging_against_floquet(pendulum):
    v = pendulum
    stats = v.agreement.set_index(["first", "second", "quantity"])
    for first in ("averaging", "averaging_2"):
        assert stats.loc[(first, "floquet", "omega_slow"), "fraction"] == 1.0
    # first order misses the exact lower edge by O(ε²) (7A²/32 relative at the edge): the
    # point 0.01 % below it is its only disagreement
    compared, agree = v.compare("averaging", "floquet")
    assert np.argwhere(~agree).tolist() == [[3, 1]]
    assert v.stable_averaging[3, 1] and not v.stable_floquet[3, 1]
    assert not v.averaging_valid[3, 1]              # and averaging flags itself there
    assert v.compare("averaging_2", "floquet")[1].all()


def test_order_of_first_order_averaging(pendulum):
    first, second = pendulum.fits
    assert pendulum.exponent_theory == 2.0 and first.theory == 2.0 and second.theory == 4.0
    assert abs(pendulum.exponent - 2.0) < 0.3
    assert pendulum.exponent_error < 0.05
    assert abs(second.exponent - 4.0) < 0.3
    assert first.used.sum() >= 10 and second.used.sum() >= 4
    np.testing.assert_allclose(first.epsilon, W0 / first.omega)
    np.testing.assert_allclose(first.A * first.omega, 2 * math.sqrt(G * L))
    assert list(first.to_dataframe().columns) == ["epsilon", "omega", "A", "error", "floor",
                                                  "used", "order"]


def test_fixed_amplitude_ratio_has_no_order():
    """At fixed A/l first-order averaging's error tends to (25/32)(A/l)², not to 0 (the
    reason the fit runs along A ω = const)."""
    w = W0 * np.geomspace(100, 1000, 6)
    A = np.full_like(w, 0.05)
    grid = kapitza.floquet_grid(PEND.system, PEND.params(A, w), [math.pi])
    exact = grid.omega_slow[:, 0]
    error = np.abs(PEND.averaged(A, w).inverted.omega_slow / exact - 1)
    p, se, c, used = fit_order(W0 / w, error, np.zeros_like(w))
    assert abs(p) < 0.1 and used.all()
    np.testing.assert_allclose(error[-1], 25 / 32 * 0.05**2, rtol=0.01)


def test_pendulum_dataframe(pendulum):
    df = pendulum.to_dataframe()
    assert len(df) == 36
    methods = ["averaging", "averaging_2", "floquet", "simulation"]
    assert list(df.columns) == (
        ["A", "omega", "A_over_l", "omega_over_omega0", "boundary_distance",
         "nearest_boundary"]
        + [f"{k}_{m}" for m in methods for k in ("stable", "omega_slow", "tolerance")]
        + ["averaging_valid", "floquet_margin", "simulation_status", "fall_time", "amplitude",
           "disagreements"])
    flagged = df.disagreements != ""
    assert flagged.sum() == len(set(pendulum.disagreements.point))
    assert "floquet≠simulation (stability)" in df.disagreements.iloc[2 * 6 + 2]


def test_pendulum_figure(pendulum, tmp_path):
    import matplotlib.figure
    fig = pendulum.figure()
    assert isinstance(fig, matplotlib.figure.Figure) and len(fig.axes) == 2
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "simulation ≠ Floquet (stability): 1" in labels
    assert "averaging (order 1) ≠ Floquet (stability): 1" in labels
    # the marked points sit on the disagreeing grid points (dimensionless axes)
    marked = [c.get_offsets() for c in ax.collections if len(c.get_offsets()) == 1]
    points = {(round(x, 9), round(y, 9)) for off in marked for x, y in np.asarray(off)}
    for i, j in ((2, 2), (3, 1)):
        assert (round(pendulum.omega[i, j] / W0, 9), round(pendulum.A[i, j] / L, 9)) in points
    assert any("fitted p = 2.0" in t.get_text() for t in fig.axes[1].get_legend().get_texts())
    fig.savefig(tmp_path / "verification.png")
    assert kapitza.verification_figure(pendulum, dimensionless=False).axes[0].get_xlabel() \
        .startswith("drive angular frequency")


def test_chain_through_general_verify(chain_verification):
    v = chain_verification
    assert v.shape == (4, 3)
    assert v.methods == ("averaging", "floquet", "simulation")
    assert v.stable_averaging_2 is None and v.omega_slow_averaging_2 is None
    assert any("next-order averaging: none" in note for note in v.notes)
    assert v.omega_slow_floquet.shape == (4, 3, 2)           # two slow modes
    # Acheson: the minimum drive A ω = √2 g / ω1 (first order); the located Floquet
    # boundaries agree with it to O(ε²)
    mp = kapitza.multiple_pendulum_upright([1.0, 1.0], [1.0, 1.0], g=G)
    np.testing.assert_allclose(v.boundary_A * v.boundary_omega, mp.minimum_drive, rtol=0.02)
    assert len(v.boundary_A) == 3
    stats = v.agreement.set_index(["first", "second", "quantity"])
    for pair in (("floquet", "simulation"), ("averaging", "floquet")):
        for quantity in ("stability", "omega_slow"):
            compared, agree = v.compare(*pair, quantity)
            assert np.all(v.boundary_distance[compared & ~agree] < NEAR)
        assert stats.loc[pair + ("omega_slow",), "compared"] >= 6
    assert stats.loc[("floquet", "simulation", "omega_slow"), "fraction"] == 1.0
    fit, = v.fits
    assert abs(v.exponent - 2.0) < 0.3 and fit.theory == 2.0
    cols = v.to_dataframe().columns
    assert {"omega_slow_floquet_0", "omega_slow_floquet_1", "tolerance_simulation_1"} <= set(cols)
    assert "A_over_l" not in cols                       # no length given
    assert len(v.figure().axes) == 2


def test_refusals(chain_verification):
    v = chain_verification
    with pytest.raises(ValueError, match="no method 'averaging_2'"):
        v.compare("averaging_2", "floquet")
    with pytest.raises(ValueError, match="quantity"):
        v.compare("averaging", "floquet", "amplitude")
    sys_ = PEND.system
    with pytest.raises(ValueError, match="'B' is not a parameter"):
        kapitza.verify(sys_, dict(m=1.0, l=1.0, g=G), [math.pi], A=0.05, omega=200.0,
                       amplitude="B")
    with pytest.raises(ValueError, match="scalars"):
        kapitza.verify(sys_, dict(m=1.0, l=np.ones(2), g=G), [math.pi], A=0.05, omega=200.0)
    with pytest.raises(ValueError, match="line must be"):
        PEND.verify(0.05, 200.0, line=3.0, periods=50)
    with pytest.raises(ValueError, match="horizontal"):
        KapitzaPendulum(drive="horizontal").verify(0.05, 200.0)
    with pytest.raises(ValueError, match="no field 'omega_slow_averaging_2'"):
        v.modes("omega_slow_averaging_2")
    with pytest.raises(ValueError, match="pass one of"):
        v.modes("stable_floquet")


def test_a_verification_is_data_that_draws_itself(chain_verification):
    """Rebuilt from its fields alone (nothing injected by verify), a Verification compares
    and draws itself as the original does; modes() gives every slow-frequency field a mode
    axis."""
    v = chain_verification
    copy = Verification(**{f: getattr(v, f) for f in v.__dataclass_fields__})
    for pair in (("floquet", "simulation"), ("averaging", "floquet")):
        for a, b in zip(copy.compare(*pair, "omega_slow"), v.compare(*pair, "omega_slow"),
                        strict=True):
            np.testing.assert_array_equal(a, b)
    assert copy.agreement.equals(v.agreement)
    assert len(copy.figure(dimensionless=False).axes) == 2
    assert v.modes("omega_slow_floquet").shape == (4, 3, 2)
    np.testing.assert_array_equal(v.modes("tolerance_simulation"), v.tolerance_simulation)


def test_modes_adds_the_axis_of_one_coordinate(pendulum):
    x = pendulum.modes("omega_slow_averaging_2")
    assert x.shape == pendulum.shape + (1,)
    np.testing.assert_array_equal(x[..., 0], pendulum.omega_slow_averaging_2)


@pytest.mark.parametrize("damping,about", [(0.0, "inverted"), (0.4, "inverted"),
                                           (0.3, "hanging")])
def test_the_pendulums_floquet_from_mathieu_equals_the_general_monodromys(damping, about):
    """KapitzaPendulum.verify takes Floquet's numbers from the Mathieu equation's trace
    (closed_forms._floquet); they equal floquet_grid's (the general monodromy of the
    system's Jacobian) — verdict, boundary label, Ω within the sum of both stated errors,
    multipliers to 1e-9 — over a grid that crosses both edges of the window and, hanging,
    the parametric resonance near 2ω0; the trace equals scipy's monodromy's."""
    from kapitza.closed_forms import pendulum_floquet
    from kapitza.verification._verify import _floquet_fields

    from helpers import pendulum_monodromy
    pend = KapitzaPendulum(l=L, g=G, damping=damping)
    A = np.array([0.005, 0.02, 0.05, 0.1, 0.2, 0.4, 0.6])[:, None]
    omega = np.array([1.9 * W0, 2.05 * W0, 40.0, 90.0])[None, :]
    A, omega = np.broadcast_arrays(A, omega)
    ours = pendulum_floquet(A, omega, l=L, g=G, damping=damping, about=about)
    grid = kapitza.floquet_grid(pend.system, pend.params(A, omega),
                                [math.pi if about == "inverted" else 0.0])
    stable, slow, slow_tol, _ = _floquet_fields(grid)
    assert (ours.stable == stable).all() and ours.stable.any() and (~ours.stable).any()
    assert (ours.label == np.asarray(grid.label)).all()
    assert (ours.boundary == np.asarray(grid.boundary)).all()
    both = ours.stable
    assert np.all(np.abs(ours.omega_slow[both] - slow[..., 0][both])
                  <= ours.omega_slow_error[both] + slow_tol[..., 0][both])
    # small but for the √δ turn at the edges, where sin ΩT → 0
    assert np.median(ours.omega_slow_error[both] / ours.omega_slow[both]) < 1e-8
    assert np.allclose(np.sort_complex(ours.multipliers),
                       np.sort_complex(np.asarray(grid.multipliers)), rtol=1e-9, atol=1e-12)
    sign = -1 if about == "inverted" else 1
    for i, j in [(2, 2), (5, 3), (0, 1), (3, 0)]:
        reference = np.trace(pendulum_monodromy(A[i, j], omega[i, j], sign, gamma=damping))
        assert ours.trace[i, j] == pytest.approx(reference, rel=1e-8, abs=1e-10)

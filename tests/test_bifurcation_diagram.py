"""Bifurcation diagrams, Poincaré sections and basins (kapitza.chaos) against references.

* The damped driven pendulum θ̈ + θ̇/Q + sin θ = F cos ω_d t (Q = 2, ω_d = 2/3) doubles its
  period on the way to chaos (Baker & Gollub, *Chaotic Dynamics*, ch. 3; Giordano &
  Nakanishi, *Computational Physics*, fig. 3.10): after the transient a start leaves one
  strobe point at F = 1.35, two at F = 1.45, four at F = 1.47, a cloud at F = 1.5.
* The strobe samples are the trajectory's own: equal to scipy's DOP853 (an independent
  integrator) at the strobe times.
* :func:`kapitza.chaos.basin` gives, cell for cell, the basin maps of
  ``studies/inverted_basin.py`` (computed there by hand with
  ``KapitzaPendulum.measure_grid``, stored in studies/results/inverted_basin/) and their
  areas in findings.json.
"""
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import sympy as sp
from scipy.integrate import ode

from kapitza.chaos import basin, bifurcation_diagram, lyapunov_grid, poincare_section
from kapitza.results import ComputationInterrupted
from kapitza.results._chaos import Basin, BifurcationDiagram, PoincareSection
from lagrange_core import System, coordinates, problems, t

STUDY = Path(__file__).resolve().parents[1] / "studies" / "results" / "inverted_basin"
W0 = math.sqrt(9.81)
FIXED = dict(Q=2.0, omega=2 / 3)


@pytest.fixture(scope="module")
def ddp():
    (th,), (thd,) = coordinates("theta")
    Q, F, w = sp.symbols("Q F omega", positive=True)
    return System([th], lagrangian=thd**2 / 2 + sp.cos(th), dissipation=thd**2 / (2 * Q),
                  forces={th: F * sp.cos(w * t)}, name="damped driven pendulum")


@pytest.fixture(scope="module")
def cascade(ddp):
    # rtol 1e-9: at F = 1.47, inside the narrow period-4 window, the orbit's multiplier is
    # near 1 in modulus and the integration's noise (~rtol per period) is amplified by
    # 1/(1 − |μ|); at the default 1e-8 the samples of some starts differ by more than
    # orbit_period's 1e-6 after 300 or 500 transient periods (with the scalar DOP853 and
    # the lanes alike, depending on the rounding), at 1e-9 every start reads period 4.
    return bifurcation_diagram(ddp, FIXED, parameter="F", values=[1.35, 1.45, 1.47, 1.5],
                               q0=np.array([-0.5, 0.0, 0.5, 1.0]), periods=64, transient=300,
                               angles="theta", rtol=1e-9, progress=False)


def _distinct(points, tol=1e-6):
    """How many distinct points (rows) ``points`` holds, to ``tol``."""
    kept = []
    for p in points:
        if not any(np.max(np.abs(p - k)) <= tol for k in kept):
            kept.append(p)
    return len(kept)


def test_period_doubling_cascade(cascade):
    assert isinstance(cascade, BifurcationDiagram)
    assert cascade.q.shape == (4, 4, 64, 1) and set(cascade.status.ravel()) == {"finished"}
    periods = cascade.orbit_period()
    assert periods[0].tolist() == [1, 1, 1, 1]
    assert periods[1].tolist() == [2, 2, 2, 2]
    assert periods[2].tolist() == [4, 4, 4, 4]
    assert periods[3].tolist() == [0, 0, 0, 0]            # chaos: no period ≤ 64
    x = np.concatenate([cascade.q_wrapped, cascade.qdot], axis=-1)
    for v, expected in ((0, 1), (1, 2), (2, 4)):
        for s in range(4):
            assert _distinct(x[v, s]) == expected
    assert _distinct(x[3, 0]) == 64                        # the cloud: every point new


def test_strobe_samples_are_the_trajectory(ddp, cascade):
    """Start 0.5 at F = 1.45 against scipy's DOP853 stopped at t = (300 + k) T.

    Hairer's Fortran DOP853 (``scipy.integrate.ode``), the method of solve_ivp's "DOP853"
    at the same tolerances: solve_ivp's Python driver spent 2.8 s on this run,
    the Fortran one 0.4 s; the two agree to 3e-11, far inside the bound 1e-7."""
    F, w, Q = 1.45, 2 / 3, 2.0
    T = 2 * math.pi / w
    times = (300 + np.arange(64)) * T

    def f(tt, y):
        return [y[1], -y[1] / Q - math.sin(y[0]) + F * math.cos(w * tt)]
    run = ode(f).set_integrator("dop853", rtol=1e-12, atol=1e-12, nsteps=10**6)
    run.set_initial_value([0.5, 0.0], 0.0)
    ref = np.array([run.integrate(tk) for tk in times]).T
    assert run.successful()
    np.testing.assert_allclose(cascade.q[1, 2, :, 0], ref[0], atol=1e-7)
    np.testing.assert_allclose(cascade.qdot[1, 2, :, 0], ref[1], atol=1e-7)


def test_dataframe_figure_and_about(ddp, cascade, tmp_path):
    df = cascade.to_dataframe()
    assert len(df) == 4 * 4 * 64 and set(df.columns) == {"F", "start", "sample", "theta",
                                                        "theta_dot"}
    assert df.theta.between(-math.pi, math.pi).all()
    fig = cascade.figure()
    fig.savefig(tmp_path / "diagram.png")
    assert fig.axes[0].get_xlabel() == "F"
    # about: kept, and the start when q0 is not given
    d = bifurcation_diagram(ddp, dict(FIXED, F=9.0), about=[0.2], parameter="F",
                            values=[1.35], periods=2, transient=300, progress=False)
    assert d.q0.tolist() == [[0.2]] and d.about.tolist() == [0.2]
    np.testing.assert_allclose(d.q[0, 0, 0], cascade.q[0, 0, 0], atol=1e-6)


def test_one_value_runs_the_kernels_a_grid_compiled(ddp, cascade):
    """One value of one parameter (its arrays broadcast views of scalars, read-only) runs
    the lanes kernels the grid compiled: numba compiles no read-only specialisation
    (~10 s on first use, each)."""
    from kapitza.chaos import _lanes as chaos_lanes
    from lagrange_core import _first_order_lanes
    bifurcation_diagram(ddp, dict(FIXED, F=9.0), about=[0.2], parameter="F", values=[1.35],
                        periods=2, transient=2, progress=False)
    lyapunov_grid(ddp, dict(FIXED, F=1.35), 0.2, periods=4, transient=0, blocks=2,
                  progress=False)
    lyapunov_grid(ddp, dict(FIXED, F=np.array([1.35, 1.4])), 0.2, periods=4, transient=0,
                  blocks=2, progress=False)
    for kernel in (_first_order_lanes._block, chaos_lanes._block):
        assert len(kernel.signatures) == 1, kernel.signatures


def test_frequency_as_the_parameter(ddp):
    """Sweeping ω itself: T varies per value and the samples land on each one's period."""
    w = np.array([0.6, 2 / 3])
    d = bifurcation_diagram(ddp, dict(Q=2.0, F=1.35), parameter="omega", values=w, q0=0.0,
                            periods=8, transient=300, progress=False)
    np.testing.assert_allclose(d.period, 2 * math.pi / w)
    # from rest at ω = 2/3 it runs over the top, a turn per period: period 1 modulo 2π only
    np.testing.assert_allclose(np.diff(d.q[1, 0, :, 0]), -2 * math.pi, rtol=1e-6)
    assert d.orbit_period()[1, 0] == 0
    wrapped = bifurcation_diagram(ddp, dict(Q=2.0, F=1.35), parameter="omega", values=w,
                                  q0=0.0, periods=8, transient=300, angles=True,
                                  progress=False)
    assert wrapped.orbit_period()[1, 0] == 1


def test_poincare_section(ddp, cascade, tmp_path):
    s = poincare_section(ddp, dict(FIXED, F=1.45), 0.5, periods=64, transient=300,
                         angles="theta", rtol=cascade.rtol, progress=False)
    assert isinstance(s, PoincareSection) and s.q.shape == (64, 1)
    np.testing.assert_array_equal(s.q[:, 0], cascade.q[1, 2, :, 0])
    np.testing.assert_allclose(s.times[:2], np.array([300, 301]) * 3 * math.pi)
    several = poincare_section(ddp, dict(FIXED, F=1.5), np.array([0.1, 0.2, 0.3]), periods=50,
                               angles="theta", progress=False)
    assert several.q.shape == (3, 50, 1) and len(several.to_dataframe()) == 150
    several.figure().savefig(tmp_path / "section.png")


def test_interrupted_diagram_keeps_finished_points(ddp):
    calls = []

    def progress(done, total):
        if calls and calls[-1] == total:        # the transient is done: the strobe run's
            raise KeyboardInterrupt             # first chunk
        calls.append(done)
    with pytest.raises(ComputationInterrupted) as info:
        bifurcation_diagram(ddp, FIXED, parameter="F", values=np.linspace(1.0, 1.5, 300),
                            q0=0.0, periods=5, transient=2, progress=progress)
    part = info.value.result
    assert isinstance(part, BifurcationDiagram)
    done = info.value.computed
    assert done.any() and np.all(np.isfinite(part.q[done]))


def test_bad_input(ddp):
    with pytest.raises(ValueError, match="parameter must name"):
        bifurcation_diagram(ddp, FIXED, parameter="G", values=[1.0])
    with pytest.raises(ValueError, match="angles"):
        bifurcation_diagram(ddp, FIXED, parameter="F", values=[1.0], angles="phi")
    with pytest.raises(ValueError, match="values must be a 1-D"):
        bifurcation_diagram(ddp, FIXED, parameter="F", values=[[1.0, 2.0]])


# -- basins ------------------------------------------------------------------------------------

@pytest.mark.parametrize("kappa", [1.6, 2.5, 5.0])
def test_basin_reproduces_the_inverted_basin_study(kappa, tmp_path):
    maps = pd.read_parquet(STUDY / "inverted_basin_maps.parquet")
    findings = json.loads((STUDY / "findings.json").read_text())
    d = maps[maps.kappa == kappa]
    n = int(round(math.sqrt(len(d))))
    phi0 = d.phi0.to_numpy().reshape(n, n)
    rate = d.theta_dot0.to_numpy().reshape(n, n)
    b = basin(problems.driven_pendulum("vertical"),
              dict(A=float(d.A_l.iloc[0]), omega=40 * W0, g=9.81, l=1.0, m=1.0), math.pi,
              q0=math.pi - phi0, qdot0=rate, periods=800, band=0.8 * math.pi, rtol=1e-7,
              progress=False)
    assert isinstance(b, Basin)
    np.testing.assert_array_equal(b.stays, d.stays_up.to_numpy().reshape(n, n))
    assert b.area == pytest.approx(findings[f"map_kappa{kappa:g}_basin_area_sim"], rel=1e-12)
    assert np.all(np.isnan(b.exit_time[b.stays])) and np.all(b.exit_time[~b.stays] > 0)
    if kappa == 2.5:
        b.figure().savefig(tmp_path / "basin.png")
        assert len(b.to_dataframe()) == n * n


def test_basin_refuses_a_start_outside_the_band():
    s = problems.driven_pendulum("vertical")
    with pytest.raises(ValueError, match="outside the band"):
        basin(s, dict(A=0.05, omega=200.0, g=9.81, l=1.0, m=1.0), math.pi,
              q0=np.array([3.0, 0.5]), band=1.0)


def test_lyapunov_map_figure(ddp, tmp_path):
    g = lyapunov_grid(ddp, dict(Q=2.0, F=np.array([1.35, 1.5])[:, None],
                                omega=np.array([0.6, 2 / 3])[None, :]), 0.2, periods=40,
                      transient=10, progress=False)
    fig = g.figure()
    fig.savefig(tmp_path / "map.png")
    assert fig.axes[0].get_xlabel() == "omega" and fig.axes[0].get_ylabel() == "F"

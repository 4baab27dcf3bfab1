"""One small result of every type the public API returns, computed once per process (each
in well under a second with the kernels warm): the cases of tests/test_repr_html.py and
tests/test_xarray.py.  Their physics is tested elsewhere; these tests check how they are
shown and labelled, so the grids are as small as still makes a grid (2–15 points an axis).
"""
import functools
import math
import warnings

import numpy as np

import kapitza
from kapitza import KapitzaPendulum
from lagrange_core import problems

G, L = 9.81, 1.0
PENDULUM = KapitzaPendulum(l=L, g=G)
P = dict(m=1.0, l=L, g=G)


@functools.cache
def vertical():
    return problems.driven_pendulum("vertical")


def _quiet(build):
    """A builder whose expected warnings (short records, a branch cut short) are silenced:
    the cards must show them, which the tests check on the fields."""
    @functools.wraps(build)
    def run():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return build()
    return run


#: name → builder (the cases); GRIDDED are those with to_xarray().
BUILDERS = {
    "stability_map": lambda: PENDULUM.stability_map(np.linspace(0.0, 0.3, 12),
                                                    np.linspace(20.0, 200.0, 15)),
    "stability_map_general": lambda: kapitza.stability_map(
        vertical(), P, [math.pi], A=np.linspace(0.01, 0.2, 4), omega=np.array([100.0, 300.0])),
    "adaptive_map": lambda: kapitza.adaptive_map(
        vertical(), P, [math.pi], A=np.linspace(0.01, 0.3, 9), omega=np.linspace(60, 300, 9)),
    "window": lambda: PENDULUM.window(np.linspace(10.0, 100.0, 12)),
    "window_averaging": lambda: PENDULUM.window(np.linspace(3.0, 100.0, 12),
                                                method="averaging"),
    "window_general": lambda: kapitza.window(vertical(), P, [math.pi],
                                             omega=np.array([100.0, 200.0])),
    "boundaries": lambda: kapitza.boundaries(vertical(), P, [math.pi],
                                             omega=np.linspace(100, 200, 4), A_range=(0.0, 0.5)),
    "ince_strutt_chart": lambda: kapitza.ince_strutt_chart(q_max=5, a_range=(-5, 10), r_max=2,
                                                           n=20),
    "floquet_point": lambda: PENDULUM.floquet(0.05, 200.0),
    "floquet_grid": lambda: kapitza.floquet_grid(
        vertical(), dict(P, A=np.linspace(0.01, 0.1, 3)[:, None],
                         omega=np.array([150.0, 250.0])[None, :]), [math.pi]),
    "monodromy_data": lambda: kapitza.monodromy_data(
        vertical(), dict(P, A=np.linspace(0.01, 0.1, 3), omega=200.0), [math.pi]),
    "pendulum_averaging": lambda: PENDULUM.averaged(np.array([0.02, 0.05, 0.1])[:, None],
                                                    np.array([100.0, 200.0])[None, :]),
    "pendulum_averaging_one": lambda: PENDULUM.averaged(0.05, 30.0),
    "averaging_prediction": _quiet(lambda: kapitza.average(vertical()).predict(
        dict(P, A=0.05, omega=200.0))),
    "slow_modes": _quiet(lambda: kapitza.average(vertical()).predict(
        dict(P, A=0.05, omega=200.0)).equilibria[-1]),
    "slow_mode_sweep": lambda: kapitza.average(vertical()).sweep(
        dict(P, A=np.array([0.02, 0.05]), omega=200.0), [math.pi]),
    "equilibrium_prediction": lambda: PENDULUM.averaged(0.02, 100.0).inverted,
    "multiple_pendulum": lambda: kapitza.multiple_pendulum_upright(
        [1.0, 1.0], [1.0, 1.0], A=np.array([0.01, 0.02]), omega=400.0),
    "measurement": lambda: kapitza.measure(vertical(), dict(P, A=0.05, omega=200.0), [math.pi],
                                           [math.pi - 0.05], periods=200),
    "measurement_grid": lambda: PENDULUM.measure_grid(
        np.array([0.02, 0.05, 0.1])[:, None], np.array([150.0, 250.0])[None, :],
        math.pi - 0.05, periods=100),
    "periodic_orbit": lambda: kapitza.periodic_orbit(
        problems.driven_pendulum("horizontal"), dict(P, A=0.05, omega=200.0), [1.37]),
    "verification": _quiet(lambda: PENDULUM.verify(np.array([0.02, 0.05])[:, None],
                                                   np.array([150.0, 300.0])[None, :],
                                                   periods=100)),
    "order_fit": lambda: result("verification").fits[0],     # the case above's, not again
    "branch": _quiet(lambda: kapitza.continuation(
        vertical(), dict(P, A=0.1, omega=20 * math.sqrt(G / L)), [math.pi], stop=0.4,
        max_points=8, progress=False)),
    "lyapunov_spectrum": _quiet(lambda: kapitza.lyapunov(
        vertical(), dict(P, A=0.05, omega=200.0), [math.pi - 0.1], periods=50)),
    "lyapunov_grid": _quiet(lambda: kapitza.lyapunov_grid(
        vertical(), dict(P, A=np.array([0.02, 0.05])[:, None],
                         omega=np.array([150.0, 250.0])[None, :]), [math.pi - 0.1],
        periods=30)),
    "bifurcation_diagram": _quiet(lambda: kapitza.bifurcation_diagram(
        vertical(), dict(P, A=0.05, omega=200.0), [math.pi], parameter="A",
        values=np.linspace(0.03, 0.06, 3), periods=8, transient=20)),
    "poincare_section": _quiet(lambda: kapitza.poincare_section(
        vertical(), dict(P, A=0.05, omega=200.0), [math.pi - 0.1], periods=30)),
    "basin": _quiet(lambda: kapitza.basin(
        vertical(), dict(P, A=0.05, omega=200.0), [math.pi],
        q0=np.linspace(2.9, 3.3, 4)[:, None], qdot0=np.linspace(-1.0, 1.0, 3)[None, :],
        periods=30)),
}

#: The cases whose type has to_xarray() (every gridded result).
GRIDDED = [name for name in BUILDERS if name not in (
    "floquet_point", "averaging_prediction", "slow_modes", "equilibrium_prediction",
    "periodic_orbit", "lyapunov_spectrum")]


@functools.cache
def result(name):
    """The case ``name``, computed once per process."""
    return BUILDERS[name]()


#: A scene whose sweeps are small: the pendulum over 4 amplitudes × 3 frequencies.
SWEEP_AXES = ('A = { start = 0.02, stop = 0.1, num = 4 }\n'
              'omega = { start = 100.0, stop = 300.0, num = 3, scale = "log" }')

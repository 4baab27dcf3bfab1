"""lagrange_core.work_precision (lagrange_core/accuracy_cost.py): errors measured against a
closed form (the pendulum returns to its start after one period, T = 4 K(sin²(θ0/2)) / ω0),
the reference's own accuracy, the trends with tolerance, peers skipped cleanly, bad input,
and the figure."""
from __future__ import annotations

import importlib
import math

import numpy as np
import pytest
from scipy.special import ellipk

from lagrange_core import WorkPrecision, problems, work_precision

wp_module = importlib.import_module("lagrange_core.accuracy_cost")

G, L = 9.81, 1.0
THETA0 = 1.0                                       # rad: a large swing, far from linear
# the exact period of the pendulum (scipy's ellipk takes m = k², k = sin(θ0/2))
PERIOD = 4 * ellipk(math.sin(THETA0 / 2) ** 2) / math.sqrt(G / L)
SPAN = (0.0, 3 * PERIOD)                           # θ(3T) = θ0 exactly
P = dict(g=G, l=L, m=1.0)
RTOLS = (1e-4, 1e-7, 1e-10)


@pytest.fixture(scope="module")
def pendulum():
    return problems.pendulum()


@pytest.fixture(scope="module")
def exact(pendulum):
    """Measured against the closed form θ(3T) = θ0."""
    return work_precision(pendulum, [THETA0], [0.0], SPAN, P, methods=("rkn12", "dop853"),
                          rtols=RTOLS, reference=[THETA0], repeat=1,
                          peers=("scipy:DOP853",))


@pytest.fixture(scope="module")
def own(pendulum):
    """Measured against the default reference (ours, cross-checked)."""
    return work_precision(pendulum, [THETA0], [0.0], SPAN, P, methods=("rkn12", "dop853"),
                          rtols=RTOLS, repeat=1, peers=())


def test_the_default_reference_agrees_with_the_closed_form(own):
    assert abs(own.reference_q[0] - THETA0) < 1e-12
    # its stated own error (the cross-check's difference) is of the size of its true error
    assert own.reference_error < 1e-12
    assert own.default_method == "rkn12" and "cross-checked" in own.reference


def test_errors_against_the_closed_form_stay_within_the_tolerance_band(exact):
    assert set(exact.methods) == {"rkn12", "dop853", "scipy:DOP853"}
    for name in exact.methods:
        sel = exact.method == name
        # three periods of a smooth oscillation: the global error stays within 10 × rtol
        assert np.all(exact.error[sel] <= 10 * exact.rtol[sel]), name
        # and tightening the tolerance 1000-fold buys at least 100-fold
        err = exact.error[sel]
        assert err[-1] < err[0] / 100, name


def test_the_own_reference_measures_the_same_errors_as_the_closed_form(exact, own):
    for name in ("rkn12", "dop853"):
        a, b = exact.error[exact.method == name], own.error[own.method == name]
        assert np.allclose(a, b, rtol=0, atol=1e-12), name


def test_steps_and_evaluations_grow_as_the_tolerance_tightens(exact):
    for name in exact.methods:
        sel = exact.method == name
        assert np.all(np.diff(exact.rtol[sel]) < 0)              # loosest first
        assert np.all(np.diff(exact.steps[sel]) > 0), name
        assert np.all(np.diff(exact.evaluations[sel]) > 0), name
    assert np.all(exact.seconds > 0) and np.all(np.isfinite(exact.seconds))


def test_the_table_and_time_to_reach(exact):
    df = exact.to_dataframe()
    assert len(df) == len(exact) == 9
    assert list(df.columns) == ["method", "kind", "rtol", "error", "seconds", "steps",
                                "evaluations", "resolved", "default"]
    assert set(df.loc[df.default, "method"]) == {"rkn12"}
    assert set(df.loc[df.kind == "peer", "method"]) == {"scipy:DOP853"}
    level = 1e-6
    reach = exact.time_to_reach(level)
    for name in exact.methods:
        rows = df[(df.method == name) & (df.error <= level)]
        assert reach[name] == rows.seconds.min()
    assert math.isnan(exact.time_to_reach(1e-30)["rkn12"])
    # the compiled DOP853 and scipy's take the same steps on the same right-hand side
    ours = df[df.method == "dop853"].steps.to_numpy()
    scipy_ = df[df.method == "scipy:DOP853"].steps.to_numpy()
    assert np.all(np.abs(ours - scipy_) <= 0.02 * ours + 2)


def test_a_level_below_the_reference_accuracy_is_not_judged(own):
    assert own.reference_error > 0
    assert all(math.isnan(v) for v in own.time_to_reach(own.reference_error).values())
    assert not own.resolved[own.error <= 10 * own.reference_error].any()


def test_peers_that_are_missing_or_do_not_apply_are_skipped_with_the_reason(monkeypatch):
    damped = problems.driven_pendulum(damping=True)     # velocity-dependent: no RKN
    monkeypatch.setattr(wp_module, "_have_heyoka", lambda: False)
    res = work_precision(damped, [0.3], [0.0], (0.0, 1.0),
                         dict(A=0.0, g=G, l=L, m=1.0, omega=10.0, gamma=0.5),
                         methods=("rkn12", "dop853"), rtols=(1e-6,), repeat=1,
                         peers=("heyoka",))
    reasons = dict(res.skipped)
    assert set(res.methods) == {"dop853"}
    assert "heyoka is not installed" in reasons["heyoka"]
    assert "q̈ = f(q, t)" in reasons["rkn12"] or "velocit" in reasons["rkn12"]
    assert res.default_method == "dop853" and "rk8" in res.reference
    assert res.error[0] < 1e-5 and res.reference_error < 1e-11


def test_heyoka_against_the_closed_form(pendulum):
    pytest.importorskip("heyoka")
    res = work_precision(pendulum, [THETA0], [0.0], SPAN, P, methods=("rkn12",),
                         rtols=(1e-6, 1e-10), reference=[THETA0], repeat=1, peers=("heyoka",))
    sel = res.method == "heyoka"
    assert sel.sum() == 2 and np.all(res.error[sel] <= 10 * res.rtol[sel])
    assert np.all(np.isnan(res.evaluations[sel]))


@pytest.mark.parametrize("kw, words", [
    (dict(methods=("rk45",)), "unknown method 'rk45'"),
    (dict(methods=("yoshida6",)), "fixed step"),
    (dict(rtols=()), "rtols is empty"),
    (dict(rtols=(1e-16,)), "rtols must lie in"),
    (dict(repeat=0), "repeat must be"),
    (dict(max_seconds=-1.0), "max_seconds"),
    (dict(reference=[1.0, 2.0]), "reference must be"),
    (dict(reference="exact"), "reference must be"),
    (dict(rounds=0), "rounds must be"),
])
def test_bad_input_is_refused_with_the_argument_named(pendulum, kw, words):
    with pytest.raises(ValueError, match=words):
        work_precision(pendulum, [THETA0], [0.0], (0.0, 1.0), P, **kw)


def test_bad_span_and_level(pendulum, exact):
    with pytest.raises(ValueError, match="t_span"):
        work_precision(pendulum, [THETA0], [0.0], (1.0, 0.0), P)
    with pytest.raises(ValueError, match="error must be a positive"):
        exact.time_to_reach(-1.0)


def test_the_figure_draws_one_line_per_method_and_marks_the_default(exact):
    from kapitza.figures import work_precision_figure
    fig = work_precision_figure(exact)
    labels = [ln.get_label() for ln in fig.axes[0].lines if not ln.get_label().startswith("_")]
    assert "rkn12 (default)" in labels and "dop853" in labels and "scipy:DOP853" in labels
    assert fig.axes[0].get_xscale() == "log" and fig.axes[0].get_yscale() == "log"
    with pytest.raises(TypeError, match="WorkPrecision"):
        work_precision_figure(exact.to_dataframe())
    assert isinstance(exact, WorkPrecision)


def test_a_missing_parameter_and_a_bad_start_are_named(pendulum):
    with pytest.raises(ValueError, match="l"):
        work_precision(pendulum, [THETA0], [0.0], (0.0, 1.0), dict(g=G, m=1.0))
    with pytest.raises(ValueError, match="q0"):
        work_precision(pendulum, [THETA0, 0.0], [0.0], (0.0, 1.0), P)


def test_ctrl_c_keeps_the_finished_runs(pendulum, monkeypatch):
    calls = {"n": 0}
    real = wp_module.best_time

    def interrupting(fn, repeat=3, clock=None):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return real(fn, repeat)
    monkeypatch.setattr(wp_module, "best_time", interrupting)
    res = work_precision(pendulum, {"theta": THETA0}, {"theta": 0.0}, SPAN, P,
                         methods=("rkn12",), rtols=RTOLS, repeat=1, peers=())
    assert res.interrupted and len(res) == 2
    assert np.all(res.error <= 10 * res.rtol)

"""Floquet and Mathieu edge cases (issue 10, items 6–8): the stable flag of undamped
systems with 3+ coordinates, slow drives and huge amplitudes, progress and Ctrl-C.

Independent references: the Mathieu monodromy trace by RKN 12 (kapitza.mathieu, another
integrator on another form of the equation), scipy.integrate.solve_ivp on the system's
compiled Jacobian (tests/helpers.py), and closed forms (the undriven inverted pendulum
grows by exactly e^(ω0 T) per period).
"""
import math

import numpy as np
import pytest

from kapitza import floquet as fq
from kapitza.closed_forms import _mathieu as mm
from kapitza.pendulum import KapitzaPendulum

from helpers import W0, G, L, ctrl_c_in_process


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
    # |λ| ≈ |tr| when huge.  floquet_point's monodromy to relative tol = 1e-10 is log|λ| to
    # 1e-10 absolute: relative 1e-10 / log|λ| ≤ 1.3e-12 (log|λ| = 76 … 240 here); measured
    # 1.2e-11 absolute, ≤ 4.9e-14 relative; bound 2e-12 (×40)
    assert r.log_growth == pytest.approx(float(log_tr), rel=2e-12)


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
    m = fq.stability_map(pendulum.system, dict(m=1.0, l=L, g=G), [math.pi], A=A, omega=w)
    assert m.flagged_points == 3 and np.isfinite(m.error_estimate)
    assert m.stable.tolist() == g.stable.tolist()


# -- item 6: the stable flag of undamped systems with 3+ coordinates -------------------

TP = {"g": G, "l1": 1.0, "l2": 1.0, "l3": 1.0, "m1": 1.0, "m2": 1.0, "m3": 1.0}
UP3 = [math.pi] * 3
EDGE3 = 0.068706532019068      # the triple pendulum's lower window edge at ω = 100 rad/s


@pytest.fixture(scope="module")
def triple():
    import sympy as sp

    from lagrange_core import problems
    from lagrange_core import t as t_sym
    A, w = sp.symbols("A omega", positive=True)
    return problems.n_link_pendulum(3, pivot=(0, A * sp.cos(w * t_sym)))


def _reference_multipliers(system, A):
    from helpers import jacobian_monodromy
    M = jacobian_monodromy(system, dict(TP, A=A, omega=100.0), UP3, rtol=1e-12)
    lam = np.linalg.eigvals(M)
    return lam[np.argsort(-np.abs(lam))]


def test_triple_pendulum_small_growth_is_unstable(triple):
    # 1e-9 (relative) below the edge the upright chain grows by 5.7e-6 per period; with an
    # error estimate of 1e-9 it was called stable (max log|λ| ≤ √(10·error) = 1e-4)
    A = EDGE3 * (1 - 1e-9)
    r = fq.floquet_point(triple, dict(TP, A=A, omega=100.0), UP3)
    lam = _reference_multipliers(triple, A)
    assert abs(lam[0].imag) < 1e-9 and 4e-6 < math.log(abs(lam[0])) < 8e-6   # solve_ivp
    assert r.error_estimate > 1e-10 and math.sqrt(10 * r.error_estimate) > 1e-4
    assert not r.stable and r.boundary == "T"
    assert r.log_growth == pytest.approx(math.log(abs(lam[0])), rel=1e-3)
    # 3e-8 inside the window: a rotation by 3.1e-5 rad per period, on the unit circle
    A = EDGE3 * (1 + 3e-8)
    r = fq.floquet_point(triple, dict(TP, A=A, omega=100.0), UP3)
    lam = _reference_multipliers(triple, A)
    assert abs(lam[0].imag) > 3e-5 > 30 * abs(abs(lam[0]) - 1)                 # solve_ivp
    assert r.stable and r.log_growth == pytest.approx(0.0, abs=1e-12)
    assert np.allclose(np.abs(r.multipliers), 1.0, atol=1e-12)


def test_triple_pendulum_uncertified_counts_only_the_uncertain(triple):
    # a sweep through the window, no point near an edge: every classification is certain
    A = np.linspace(0.0, 0.1, 21)
    m = fq.stability_map(triple, TP, UP3, A=A, omega=[100.0], tol=1e-10)
    assert m.stable.sum() >= 1 and m.uncertified_points == 0 and m.flagged_points == 0
    for i in range(0, 21, 4):
        lam = _reference_multipliers(triple, A[i])
        assert m.stable[i, 0] == bool(np.max(np.abs(lam)) < 1 + 1e-6)
    # points 1e-9 from the edge are within the error estimate: counted, whichever side
    near = fq.stability_map(triple, TP, UP3, A=EDGE3 * np.array([1 - 1e-9, 1 + 1e-9]),
                            omega=[100.0])
    assert near.uncertified_points == 2


# -- item 8: chunks, progress, Ctrl-C --------------------------------------------------

from kapitza.results._results import ComputationInterrupted, FloquetGrid  # noqa: E402


def _stop(done, total):
    raise KeyboardInterrupt


def _stop_in(stage):
    """A progress callback raising Ctrl-C's KeyboardInterrupt at its first call in ``stage``
    of a general Floquet grid (0 sampling J(t), 1 integration, 2 analysis): each stage
    reports its own (done, total) and ends with done == total."""
    ended = [0]

    def progress(done, total):
        if ended[0] == stage:
            raise KeyboardInterrupt
        ended[0] += done == total
    return progress


def test_floquet_grid_interrupt_keeps_finished_points():
    p = KapitzaPendulum(l=L, g=G, damping=0.5)
    A = np.linspace(0.0, 0.6, 40)
    w = np.linspace(20.0, 200.0, 40)
    params = dict(p.params(0.0, 1.0), A=A[:, None], omega=w[None, :])
    with pytest.raises(ComputationInterrupted) as info:
        fq.floquet_grid(p.system, params, [math.pi], progress=_stop_in(1))
    e = info.value
    assert isinstance(e, KeyboardInterrupt) and e.computed.shape == (40, 40)
    n = int(e.computed.sum())
    assert 0 < n < 1600 and e.computed.ravel()[:n].all()      # the first chunk, in order
    g = e.result
    i, j = np.nonzero(e.computed)
    a, q, c = mm.mathieu_parameters(A[i], w[j], L, G, p.damping, "inverted")
    ref = mm.mathieu_trace(a, q, c, tol=1e-13)
    assert np.allclose(g.trace[i, j], ref, rtol=1e-8, atol=1e-9)
    assert np.isnan(g.trace[~e.computed]).all() and not g.stable[~e.computed].any()
    assert all(g.flags[k] == ("not computed: interrupted (Ctrl-C)",)
               for k in np.flatnonzero(~e.computed))
    # the general map carries its partial map
    with pytest.raises(ComputationInterrupted) as info:
        fq.stability_map(p.system, dict(m=1.0, l=L, g=G, gamma=0.5), [math.pi], A=A, omega=w,
                         progress=_stop_in(1))
    assert info.value.computed.sum() == n
    assert np.array_equal(info.value.result.stable[e.computed], g.stable[e.computed])


def test_mathieu_map_interrupt_keeps_finished_rows():
    p = KapitzaPendulum(l=L, g=G, damping=0.5)
    A = np.linspace(0.0, 0.6, 30)
    w = np.linspace(5.0, 200.0, 25)
    with pytest.raises(ComputationInterrupted) as info:
        p.stability_map(A, w, progress=_stop)
    e = info.value
    rows = np.nonzero(e.computed.all(axis=1))[0]
    assert rows.tolist() == [0, 1] and not e.computed[2:].any()
    a, q, c = mm.mathieu_parameters(A[:2, None], w[None, :], L, G, p.damping, "inverted")
    ref = np.vectorize(lambda *x: mm.mathieu_trace(*x, tol=1e-13))(a, q, c)
    assert np.allclose(e.result.trace[:2], ref, rtol=1e-8, atol=1e-9)
    assert np.isnan(e.result.trace[2:]).all() and not e.result.stable[2:].any()
    full = p.stability_map(A, w, progress=False)
    assert np.array_equal(full.stable[:2], e.result.stable[:2])


def test_progress_line_only_on_request(capsys):
    p = KapitzaPendulum(l=L, g=G, damping=0.5)
    A, w = np.linspace(0.0, 0.6, 60), np.linspace(5.0, 200.0, 60)
    calls = []
    p.stability_map(A, w, progress=lambda d, t: calls.append((d, t)))
    done = [d for d, _ in calls]
    assert calls[-1] == (60, 60) and all(np.diff(done) > 0)
    p.stability_map(A, w)                    # stderr is not a terminal here: quiet
    p.stability_map(A, w, progress=False)
    assert capsys.readouterr().err == ""
    with pytest.raises(ValueError, match="progress"):
        p.stability_map(A, w, progress="yes")


def test_ctrl_c_stops_a_long_map_within_a_second():
    p = KapitzaPendulum(l=1.0, g=9.81, damping=0.3)
    # 1500 x 1500 damped points: ~7 s on this machine (the trace ~3 µs a point), never
    # done before the Ctrl-C 1 s in
    A, w = np.linspace(0.0, 0.7, 1500), np.linspace(2.0, 400.0, 1500) * np.sqrt(9.81)
    p.stability_map(A[:2], w[:2], progress=False)            # compiled / loaded
    e, t, sent = ctrl_c_in_process(lambda: p.stability_map(A, w, progress=False), 1.0)
    assert t - sent < 1.0
    rows = e.computed.all(axis=1)
    n = int(rows.sum())
    tr = e.result.trace
    assert 0 < n < 1500 and rows[:n].all()
    assert np.isfinite(tr[rows]).all() and np.isnan(tr[~rows]).all()


def test_a_map_stopped_inside_a_chunk_keeps_the_rows_before():
    """The damped map's kernel skips the rows it has not started once Ctrl-C sets the stop
    flag (a chunk of expensive rows ran 1.1 s on a loaded machine, past the test above's
    bound): here the flag is set after the first chunk of 2 rows, as a Ctrl-C that came
    after the loop's own look would (not the handler's "hit", which the loop reads
    between chunks); the next chunk stops at once and the map keeps exactly those rows,
    the rest NaN (fails before: the chunk ran to its end)."""
    import signal

    from lagrange_core import progress as _progress
    calls = []

    def ctrl_c_after_the_first_chunk(done, total):
        calls.append(done)
        if len(calls) == 1:
            _progress.KERNEL_STOP[0] = 1
    p = KapitzaPendulum(l=L, g=G, damping=0.3)
    A, w = np.linspace(0.0, 0.7, 40), np.linspace(2.0, 400.0, 30) * W0
    # Python's own Ctrl-C handler, as in an interactive run (a worker started by a
    # background job has SIGINT ignored, and the deferral then stands aside)
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(ComputationInterrupted) as info:
            p.stability_map(A, w, progress=ctrl_c_after_the_first_chunk)
    finally:
        signal.signal(signal.SIGINT, old)
        stop_left = int(_progress.KERNEL_STOP[0])
        _progress.KERNEL_STOP[0] = 0
    rows = info.value.computed.all(axis=1)
    assert calls[0] == 2 and rows.sum() == 2 and rows[:2].all()
    tr = info.value.result.trace
    assert np.isfinite(tr[:2]).all() and np.isnan(tr[2:]).all()
    assert stop_left == 0                                    # reset on the way out
    whole = p.stability_map(A[:2], w, progress=False)
    np.testing.assert_array_equal(tr[:2], whole.trace)


def test_mathieu_map_at_extreme_slow_drives():
    # ω = 1e-3 rad/s: A ω² = 1e-7 m/s² ≪ g, so the damped upright pendulum falls as the
    # undriven one, rate −γ/2 + √(γ²/4 + ω0²) (closed form), for one period T = 2π/ω
    gam = 0.3
    p = KapitzaPendulum(l=L, g=G, damping=gam)
    m = p.stability_map([0.1], [1e-3], progress=False)
    rate = -gam / 2 + math.sqrt(gam**2 / 4 + W0**2)
    assert not m.stable[0, 0]
    # the drive's first-order effect averages out, its second (A ω²/g)² = 1e-16: the closed
    # form is exact to rounding; the trace's tolerance 1e-10 (relative to |tr|) is an
    # absolute error of log|tr| ≈ 1.9e4, so relative 5e-15; bound 4× that (measured: equal)
    assert m.log_growth[0, 0] == pytest.approx(rate * 2 * math.pi / 1e-3, rel=2e-14)
    # ω = 1e-100: the trace overflows: NaN, unstable and counted as flagged, not a number
    m = p.stability_map([0.1, 0.2], [1e-100, 60.0], progress=False)
    assert np.isnan(m.log_growth[:, 0]).all() and not m.stable[:, 0].any()
    assert m.flagged_points == 2 and "1e-100" in m.flags_example[0]
    assert m.stable[:, 1].all() and np.isfinite(m.error_estimate)
    # ω = 1e-300: a = 4 ω0²/ω² overflows; the error names omega and the way out
    for damping in (0.0, gam):
        with pytest.raises(ValueError, match=r"omega = 1e-300.*floquet\.stability_map"):
            KapitzaPendulum(l=L, g=G, damping=damping).stability_map([0.1], [1e-300])


def test_a_trace_whose_first_run_passes_the_step_budget_is_flagged_at_once():
    """ω = 1e-7 rad/s (a = 4ω0²/ω² ≈ 3.9e15): the trace's first run alone needs ~1.3e8
    steps, over the budget (2^22) — it ran them (over a minute a point; at ω = 1e-10, years)
    and, with √a between 2^62 and 2^63, wrapped its step count negative.  Now NaN at once,
    flagged and reported unstable, as at ω = 1e-100; the trace function says which of
    its traces it did not compute."""
    import time
    p = KapitzaPendulum(l=L, g=G, damping=0.3)
    p.stability_map([0.1], [1e-3], progress=False)            # compiled / loaded
    for w in (1e-7, 1e-10, 2.0 * math.sqrt(G) / 2.0**62.5):     # the last: √a = 2^62.5
        start = time.perf_counter()
        m = p.stability_map([0.1], [w], progress=False)
        assert time.perf_counter() - start < 1.0, w
        assert np.isnan(m.log_growth[0, 0]) and not m.stable[0, 0], w
        assert m.flagged_points == 1 and "rad/s" in m.flags_example[0], w
    with pytest.warns(RuntimeWarning, match=r"1 of 2 traces did not reach tol=1e-12 "
                                            r"\(largest error .*1 not computed \(NaN\)"):
        tr, _, err = mm.mathieu_monodromy_trace([2.0, 1e16], 0.1)
    assert np.isfinite(tr[0]) and err[0] <= 1e-12 and np.isnan(tr[1]) and np.isnan(err[1])


def test_hanging_map_at_very_slow_drive_names_omega():
    # a = 4ω0²/ω² = 4e41 lies above ~1e20 tongues: this raised OverflowError ("int too big")
    with pytest.raises(ValueError, match=r"omega = 1e-20 .*floquet\.stability_map"):
        KapitzaPendulum(l=L, g=G).stability_map([0.1], [1e-20], about="hanging")
    with pytest.raises(ValueError, match="max\\(a\\)"):
        mm.stability_counts(np.array([0.1]), np.array([1e9]))


# -- issue 10, item 1: empty grids give empty results ------------------------------------

def test_empty_grids_give_empty_results(pendulum):
    # an empty parameter array or axis raised IndexError in _prepare / _sample_fourier
    base = dict(m=1.0, l=L, g=G)
    g = fq.floquet_grid(pendulum.system, dict(base, A=np.array([]), omega=60.0), [math.pi])
    assert g.shape == (0,) and g.stable.shape == (0,) and g.multipliers.shape == (0, 2)
    assert g.flags == () and len(g.to_dataframe()) == 0
    g = fq.floquet_grid(pendulum.system, dict(base, A=np.zeros((3, 0)),
                                              omega=np.full((3, 1), 60.0)), [math.pi])
    assert g.shape == (3, 0) and g.trace.shape == (3, 0) and len(g.to_dataframe()) == 0
    d = fq.monodromy_data(pendulum.system, dict(base, A=np.array([]), omega=60.0), [math.pi])
    assert d.monodromy.shape == (0, 2, 2) and len(d.to_dataframe()) == 0
    for A, w in (([], [60.0]), ([0.1, 0.2], []), ([], [])):
        m = fq.stability_map(pendulum.system, base, [math.pi], A=A, omega=w)
        assert m.stable.shape == m.label.shape == m.trace.shape == (len(A), len(w))
        assert len(m.to_dataframe()) == 0 and m.flagged_points == 0
        assert m.error_estimate == 0.0 and m.max_steps_per_period == 0


# -- issue 10, item 2 / issue 20: the grid's axes are keywords (docs/api-conventions.md) ------

def test_general_map_takes_the_axes_as_keywords(pendulum):
    base = dict(m=1.0, l=L, g=G)
    A, w = np.array([0.05, 0.2]), np.array([60.0, 120.0])
    m = fq.stability_map(pendulum.system, base, [math.pi], A=A, omega=w)
    kw = fq.stability_map(pendulum.system, omega=w, A=A, about=[math.pi], params=base)
    ref = pendulum.stability_map(A, w, about="inverted")
    assert m.stable.tolist() == kw.stable.tolist() == ref.stable.tolist()
    # axes by position after about (the order before 0.1) are refused, naming the new call
    with pytest.raises(TypeError, match=r"stability_map\(system, params, about, A=A, omega"):
        fq.stability_map(pendulum.system, base, [math.pi], A, w)
    with pytest.raises(TypeError, match="params must be a dict"):
        fq.stability_map(pendulum.system, [0.1], [math.pi], A=A, omega=w)


# -- issue 10, item 3: Ctrl-C while J(t) is sampled and while the points are analysed -----

@pytest.fixture(scope="module")
def stage_grid():
    """The damped 100 × 100 grid the stages are interrupted in, and its whole result:
    computed once for the three stages, which only read it."""
    p = KapitzaPendulum(l=L, g=G, damping=0.5)
    A = np.linspace(0.0, 0.6, 100)
    w = np.linspace(20.0, 200.0, 100)
    base = dict(m=1.0, l=L, g=G, gamma=0.5)
    params = dict(base, A=A[:, None], omega=w[None, :])
    full = fq.floquet_grid(p.system, params, [math.pi], progress=False)
    return p, A, w, base, params, full


@pytest.mark.parametrize("stage", [0, 1, 2])
def test_floquet_grid_interrupt_at_each_stage(stage, stage_grid):
    p, A, w, base, params, full = stage_grid
    with pytest.raises(ComputationInterrupted) as info:
        fq.floquet_grid(p.system, params, [math.pi], progress=_stop_in(stage))
    e = info.value
    g, done = e.result, e.computed
    assert isinstance(g, FloquetGrid) and g.shape == done.shape == (100, 100)
    n = int(done.sum())
    # sampling: nothing finished; integration: its first chunk; analysis: the first 4096
    assert n == {0: 0, 1: 64, 2: 4096}[stage] and done.ravel()[:n].all()
    assert np.array_equal(g.trace[done], full.trace[done])
    assert np.array_equal(g.stable[done], full.stable[done])
    assert np.isnan(g.trace[~done]).all() and not g.stable[~done].any()
    assert np.isnan(g.log_growth[~done]).all() and np.all(g.label[~done] == 3)
    assert all(g.flags[k] == ("not computed: interrupted (Ctrl-C)",)
               for k in np.flatnonzero(~done))
    # the general map and the monodromy data carry the same points
    with pytest.raises(ComputationInterrupted) as info:
        fq.stability_map(p.system, base, [math.pi], A=A, omega=w, progress=_stop_in(stage))
    m = info.value.result
    assert np.array_equal(info.value.computed, done) and m.stable.shape == (100, 100)
    assert np.array_equal(m.stable, g.stable) and m.flagged_points >= 10000 - n
    if stage < 2:
        with pytest.raises(ComputationInterrupted) as info:
            fq.monodromy_data(p.system, params, [math.pi], progress=_stop_in(stage))
        d = info.value.result
        ok = info.value.computed
        assert int(ok.sum()) == n and np.isnan(d.monodromy[~ok]).all()
        assert np.array_equal(d.monodromy[ok], full.monodromy[ok])


@pytest.mark.parametrize("delay", [0.1, 0.6])
def test_ctrl_c_stops_a_general_map_within_a_second(delay):
    # early (J(t) is being sampled) or later (integration or analysis): stopped within
    # a second, never a plain KeyboardInterrupt from the NumPy code between the chunks
    # (ctrl_c_in_process fails on one).  (Not at 0 s: a signal that lands before the
    # call has begun is a plain Ctrl-C with nothing to keep.)
    p = KapitzaPendulum(l=1.0, g=9.81, damping=0.3)
    base = dict(m=1.0, l=1.0, g=9.81, gamma=0.3)
    A, w = np.linspace(0.0, 0.7, 600), np.linspace(2.0, 400.0, 600) * np.sqrt(9.81)
    fq.stability_map(p.system, base, [math.pi], A=A[:2], omega=w[:2], progress=False)
    e, t, sent = ctrl_c_in_process(
        lambda: fq.stability_map(p.system, base, [math.pi], A=A, omega=w, progress=False),
        delay)
    assert t - sent < 1.0
    c = e.computed.ravel()
    n = int(c.sum())
    tr = e.result.trace.ravel()
    assert n < 360000 and c[:n].all()
    assert np.isfinite(tr[c]).all() and np.isnan(tr[~c]).all()

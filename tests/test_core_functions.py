"""Non-smooth functions in a statement: Max, Min, Heaviside, Piecewise, Abs, sign (issue 10).

They compile (the LLVM program of lagrange_core._ir: select instructions) with their
derivatives where defined; the derivative of a step is taken as 0, as sympy's is away from
the jump.  Checked against sympy's own −dV/dx and d²V/dx² at points away from the kinks,
and by integrating a piecewise potential with two methods and checking the energy.
"""
import numpy as np
import pytest
import sympy as sp

import lagrange_core as lc

(X,), _ = lc.coordinates("x")
K, M = sp.symbols("k m", positive=True)
POTENTIALS = {
    "Max": K * sp.Max(X, 0) ** 2 / 2 + K * sp.Max(X, X**2, -1) / 4,
    "Min": K * sp.Min(X, 0) ** 2 / 2 + K * sp.Min(2 * X, X**3) / 3,
    "Heaviside": K * sp.Heaviside(X) * X**2 / 2 + K * sp.Heaviside(X - 0.3, 0) * X,
    "Piecewise": sp.Piecewise((K * X**2 / 2, X > 0), (K * X**4, (X > -1) & (X <= 0)),
                              (K * (4 * X + 3), True)),
    "Abs": K * sp.Abs(X) ** 3 / 3,
    "sign": K * sp.sign(X) * X**2 / 2,
}
POINTS = [-1.7, -0.6, 0.25, 0.7, 1.9]       # away from every kink and jump
PARAMS = dict(k=2.0, m=1.3)


@pytest.mark.parametrize("name", sorted(POTENTIALS))
def test_force_and_jacobian_match_sympy(name):
    V = POTENTIALS[name]
    system = lc.System([X], particles=[lc.Particle(M, (X,))], potential=V, name=name)
    subs = {K: PARAMS["k"], M: PARAMS["m"]}
    def reference(order):           # sympy's derivative, its DiracDeltas 0 (off the jumps)
        d = (-sp.diff(V, X, order) / M).subs(subs).replace(sp.DiracDelta, lambda *a: 0)
        return sp.lambdify(X, d, "numpy")

    force, stiffness = reference(1), reference(2)
    p = system.parameter_array(PARAMS)
    for x in POINTS:
        a = system.accelerations([x], [0.0], 0.0, PARAMS)[0]
        assert a == pytest.approx(float(force(x)), rel=1e-13, abs=1e-13)
        J = np.empty((2, 2))
        assert system.kernels.jacobian(0.0, np.array([x, 0.0]), p, J) == 0
        assert J[1, 0] == pytest.approx(float(stiffness(x)), rel=1e-12, abs=1e-12)


def test_piecewise_well_conserves_energy_with_either_method():
    """A particle in the piecewise well (harmonic for x > 0, quartic below) bounces; the
    RKN (drive kernel, printed by sympy) and DOP853 (the program) runs agree and conserve
    the energy."""
    V = POTENTIALS["Piecewise"]
    system = lc.System([X], particles=[lc.Particle(M, (X,))], potential=V)
    runs = [system.simulate([0.8], [0.0], (0.0, 6.0), PARAMS, rtol=1e-11, method=meth,
                            t_eval=np.linspace(0, 6, 31)) for meth in ("rkn12", "dop853")]
    for tr in runs:
        assert tr.status == "success"
        assert np.max(np.abs(tr.energy - tr.energy[0])) < 1e-8 * abs(tr.energy[0])
        assert tr.q.min() < -0.3          # it does cross into the quartic branch
    assert np.max(np.abs(runs[0].q - runs[1].q)) < 1e-6


def test_piecewise_without_a_true_branch_is_nan_not_a_number():
    """sympy leaves a Piecewise undefined where no condition holds: the kernels give NaN
    there (and the integrator reports the non-finite state), never a made-up value."""
    V = sp.Piecewise((K * X**2 / 2, X > 0))
    system = lc.System([X], particles=[lc.Particle(M, (X,))], potential=V)
    assert system.accelerations([0.5], [0.0], 0.0, PARAMS)[0] == pytest.approx(-2.0 * 0.5 / 1.3)
    assert np.isnan(system.accelerations([-0.5], [0.0], 0.0, PARAMS)[0])

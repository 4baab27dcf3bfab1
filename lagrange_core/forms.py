"""Special forms the derived equations can take, which some integrators need.

Decided once per statement from the :class:`~lagrange_core.derive.Equations` and recorded
in the generated kernel module (``RKN_FORM``, ``RKN_REASON``), so a process that loads the
kernels from the store never derives to ask again.
"""
from __future__ import annotations

import numpy as np
import symengine as se
import sympy as sp

__all__ = ["rkn_form"]


def rkn_form(equations) -> tuple[bool, str]:
    """Whether the equations have the form q̈ = f(q, t) that RKN and symplectic methods need.

    Returns
    -------
    (eligible, reason) : (bool, str)
        ``reason`` says why not ("" when eligible), without naming the system (the
        statement's name is not part of its cache key).

    F is checked after expansion, so velocity terms that cancel (the driven pendulum's
    θ̇² terms do) do not count; a random numeric probe settles most cases before sympy's
    ``simplify`` is tried.
    """
    system = equations.system
    if system.n_constraints:
        return (False, f"it has {system.n_constraints} constraint(s); the multipliers depend "
                "on the velocities (γ contains q̇²)")
    rng = np.random.default_rng(12345)
    velocities = {se.sympify(qd): qd for qd in system.qdot}
    for i, Fi in enumerate(equations.forcing_se):
        # only the velocities that occur in F_i (cheap for large sparse systems)
        for v_se in Fi.free_symbols & set(velocities):
            qd = velocities[v_se]
            d = se.expand(se.diff(Fi, v_se))
            if d == 0:
                continue
            # a numeric probe first (simplify of a large expression is slow): clearly
            # nonzero at a random point means it truly depends on q̇
            point = {s: float(rng.uniform(0.3, 1.7)) for s in d.free_symbols}
            try:
                probe = abs(complex(d.subs(point)))
            except (TypeError, ValueError, RuntimeError):
                probe = float("nan")
            if probe > 1e-9 or sp.simplify(sp.sympify(d)) != 0:
                return (False, f"the generalized force F[{i}] depends on the velocity "
                        f"{qd.name} (∂F/∂{qd.name} = {_short(d)})")
    return True, ""


def _short(expr, limit=120) -> str:
    """``expr`` printed for a message, cut at ``limit`` characters.  Printed by symengine:
    sympy's printer took ~0.3 s for a random chain's derivative, 4.8 of the 5.3 s that
    deciding the form took for the property tests' 21 systems."""
    text = str(expr)
    return text if len(text) <= limit else text[:limit] + " …"

"""The single pendulum's window of drive amplitudes, exact or by averaging: one function.

:func:`pendulum_window` is the closed-form member of kapitza's one window family
(``docs/api-conventions.md`` §3): exact by default (the Mathieu equation's
characteristic values, :func:`kapitza.closed_forms._mathieu.exact_window`), by averaging
of order 1 or 2 with ``method="averaging"``
(:func:`kapitza.closed_forms._pendulum.averaged_window`).  Its names before kapitza 0.2,
``pendulum_stability_window`` (exact) and ``averaging_window``, still work and warn.
"""
from __future__ import annotations

import numpy as np

from .. import _arguments as arguments
from .._deprecation import warn_deprecated
from ..results import StabilityWindow
from ._mathieu import exact_window
from ._mathieu import pendulum_stability_window as pendulum_stability_window
from ._pendulum import averaged_window

__all__ = ["pendulum_window", "pendulum_stability_window", "averaging_window"]


def pendulum_window(omega, *, l=1.0, g=9.81, damping=0.0, about="inverted", tol=1e-10,
                    method="floquet", order=2, warn=True) -> StabilityWindow:
    """The window of drive amplitudes A_min < A < A_max that holds the vertically driven
    pendulum's equilibrium, per ω.

    ``method="floquet"`` (default): exact.  Root-finding on the Floquet condition of
    the Mathieu equation at each ω — undamped, the characteristic curves a0(q) = a
    (A_min, the Kapitza limit) and b1(q) = a (A_max, the first period-2T resonance) for
    the inverted pendulum; for the hanging one A_min = 0 and A_max where the first
    resonance tongue is reached; damped, |tr M| = 1 + e^(−γT) — with each edge
    certified: the condition changes sign across A·(1 ± ``accuracy``), ``accuracy`` ≤
    ``tol``.

    ``method="averaging"``: the averaging prediction of order ``order`` (inverted only).
    Order 1: A_min = √(2 g l)/ω, A_max = +inf (first order cannot see the upper limit);
    order 2: A_min from the next order, (undamped) A²ω²(1 − 7A²/(16 l²)) ≈ 2 g l,
    relative error O(ε⁴) (ε = ω0/ω), and A_max from the parametric resonance,
    → 0.4540 l as ω → ∞.  With validity flags (``fast_drive``, ``small_amplitude``,
    ``converged``, ``valid``) as for :func:`kapitza.closed_forms.pendulum_averaged`.

    Parameters
    ----------
    omega : float or array
        Drive angular frequency (rad/s, > 0); a scalar gives a window of scalar fields.
    l, g, damping : float
        Length (m), gravity (m/s²), viscous damping rate γ (1/s).
    about : {"inverted", "hanging"}
        The equilibrium (``method="averaging"``: "inverted" only).
    tol : float
        ``method="floquet"``: the requested relative accuracy of A_min and A_max.
    method : {"floquet", "averaging"}
    order : {1, 2}
        ``method="averaging"``: the order of averaging.
    warn : bool
        ``method="averaging"``: emit :class:`~kapitza.averaging.AveragingValidityWarning`
        for a scalar ω whose window is not valid (arrays only set the flags).

    Returns
    -------
    kapitza.results.StabilityWindow
        ``method`` says which; A_min, A_max (m) per ω, NaN where there is no window
        (e.g. ω too low to hold the pendulum upright).  Exact: ``accuracy`` (the
        certified relative accuracy), ``tol``.  Averaging: ``order``, ``exists``,
        ``frequency_ratio``, ``error_estimate`` (how far the next order moves A_min),
        the validity flags.

    Raises
    ------
    ValueError
        Bad ``omega``, ``l``, ``g``, ``damping``, ``about``, ``tol``, ``order``, an
        unknown ``method``, or ``method="averaging"`` with ``about="hanging"``.

    Examples
    --------
    At ω = 10⁴ ω0 the upper edge is the first parametric resonance, A_max → 0.4540 l:

    >>> import math
    >>> win = pendulum_window(1e4 * math.sqrt(9.81), l=1.0, g=9.81)
    >>> print(f"{win.A_max:.4f} m")
    0.4540 m
    >>> bool(win.accuracy <= 1e-10)          # certified to the requested tol
    True

    The next order of averaging against the exact window (l = 1 m, ω = 50 and 500 rad/s):

    >>> exact = pendulum_window([50.0, 500.0])
    >>> second = pendulum_window([50.0, 500.0], method="averaging", order=2)
    >>> print(second.A_min.round(5), exact.A_min.round(5))
    [0.08874 0.00886] [0.08874 0.00886]
    >>> print(second.A_max.round(4), exact.A_max.round(4))
    [0.4606 0.4541] [0.4606 0.4541]
    """
    # one check of ω for both methods (a grid axis: 1-d, finite, > 0), and ω not so slow
    # that a = ±4 g/(l ω²) overflows (that surfaced as numpy's or an internal message)
    w = arguments.grid_axis("omega", omega, "rad/s", positive=True)
    l_, g_, _ = arguments.pendulum_constants(l, g, damping)
    with np.errstate(over="ignore", divide="ignore"):
        too_slow = w[~np.isfinite(4.0 * g_ / (l_ * w * w))]
    if too_slow.size:
        raise ValueError(f"pendulum_window: omega = {float(too_slow[0])!r} rad/s is too slow for "
                         "the Mathieu form: a = ±4 g/(l ω²) overflows. Use ω ≥ 1e-150 rad/s.")
    if method == "averaging":
        if arguments.about_sign(about) > 0:
            raise ValueError(f"pendulum_window: the averaging window is for about='inverted' "
                             f"only, got about={about!r}; use method='floquet' for the "
                             "hanging pendulum.")
        return averaged_window(omega, l=l, g=g, damping=damping, order=order, warn=warn,
                               stacklevel=3)
    if method != "floquet":
        raise ValueError(f"pendulum_window: method must be 'floquet' (exact) or 'averaging', "
                         f"got {method!r}.")
    return exact_window(omega, l=l, g=g, damping=damping, about=about, tol=tol)


def averaging_window(omega, *, l=1.0, g=9.81, damping=0.0, order=2,
                     warn=True) -> StabilityWindow:
    """Deprecated since kapitza 0.2.0: ``pendulum_window(omega, method="averaging", ...)``.

    Same arguments and numbers as before: the averaging window of order ``order`` of the
    upright pendulum (see :func:`pendulum_window`).
    """
    warn_deprecated("kapitza.averaging_window(omega, ...)",
                    "kapitza.pendulum_window(omega, method='averaging', ...)")
    return averaged_window(omega, l=l, g=g, damping=damping, order=order, warn=warn,
                           stacklevel=3)


averaging_window.__deprecated__ = "kapitza.pendulum_window(omega, method='averaging')"

"""The Kapitza pendulum: one object for averaging, Floquet and direct integration.

Conventions (shared/PHYSICS.md): θ from the downward vertical (θ = π upright);
pivot y_p = A cos ωt (vertical drive) or x_p = A cos ωt (horizontal drive);
viscous damping γ (1/s):

    θ̈ = −γ θ̇ − (g − A ω² cos ωt) sin θ / l          (vertical drive)

The analyses live in their own modules (:mod:`kapitza.averaging`,
:mod:`kapitza.floquet`); this class holds the pendulum's constants and routes
to them, so a user meets one object.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from lagrange_core import problems

__all__ = ["KapitzaPendulum"]

_DRIVES = ("vertical", "horizontal")


@functools.lru_cache(maxsize=None)
def _driven_pendulum(drive: str, damped: bool):
    # one System per variant and process: derivation and kernels are shared
    return problems.driven_pendulum(drive, damping=damped)


@dataclass(frozen=True)
class KapitzaPendulum:
    """A pendulum whose pivot is shaken as A cos ωt.

    Parameters
    ----------
    l : float
        Rod length (m), > 0.
    g : float
        Gravitational acceleration (m/s²), ≥ 0.
    damping : float
        Linear viscous damping rate γ (1/s), ≥ 0.
    drive : {"vertical", "horizontal"}
        Direction of the pivot's oscillation.
    """

    l: float = 1.0
    g: float = 9.81
    damping: float = 0.0
    drive: str = "vertical"

    def __post_init__(self):
        for name in ("l", "g", "damping"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"KapitzaPendulum: {name} must be a finite number, got {value!r}.")
        if self.l <= 0:
            raise ValueError(f"KapitzaPendulum: the length l must be > 0 (m), got {self.l}.")
        if self.g < 0 or self.damping < 0:
            raise ValueError("KapitzaPendulum: g and damping must be ≥ 0, got "
                             f"g={self.g}, damping={self.damping}.")
        if self.drive not in _DRIVES:
            raise ValueError(f"KapitzaPendulum: drive must be one of {_DRIVES}, got {self.drive!r}.")

    @property
    def omega0(self) -> float:
        """Small-oscillation angular frequency √(g/l) of the undriven pendulum (rad/s)."""
        return math.sqrt(self.g / self.l)

    @property
    def system(self):
        """The lagrange_core system (``problems.driven_pendulum``) behind this pendulum."""
        return _driven_pendulum(self.drive, self.damping > 0)

    def params(self, A: float, omega: float) -> dict:
        """Parameter dict of :attr:`system` for drive amplitude A (m) and ω (rad/s); m = 1 kg."""
        p = {"m": 1.0, "l": self.l, "g": self.g, "A": A, "omega": omega}
        if self.damping > 0:
            p["gamma"] = self.damping
        return p

    # -- averaging (kapitza.averaging) ------------------------------------------------------
    def effective_potential(self, theta, A, omega):
        """Kapitza effective potential per unit mass U_eff(θ)/m (J/kg), first-order averaging.

        Vertical drive: −g l cos θ + A² ω² sin² θ / 4; horizontal: −g l cos θ +
        A² ω² cos² θ / 4.  Broadcasts over θ (rad), A (m), ω (rad/s).  See
        :func:`kapitza.averaging.pendulum_effective_potential`.
        """
        from .averaging import pendulum_effective_potential
        return pendulum_effective_potential(theta, A, omega, l=self.l, g=self.g, drive=self.drive)

    def averaged(self, A, omega, order: int = 1, warn: bool = True):
        """Averaged predictions: equilibria, stability, slow frequencies, validity flags.

        ``A`` (m) and ``omega`` (rad/s) may be arrays (closed forms, numpy speed).
        ``order=2`` adds the next order (vertical drive).  Returns
        :class:`kapitza.averaging.PendulumAveraging` with ``.inverted``, ``.hanging``
        (and ``.tilted`` for the horizontal drive); see
        :func:`kapitza.averaging.pendulum_averaged` for formulas and accuracy.
        """
        from .averaging import pendulum_averaged
        return pendulum_averaged(A, omega, l=self.l, g=self.g, damping=self.damping,
                                 drive=self.drive, order=order, warn=warn)

    def stability_window(self, omega, about: str = "inverted", tol: float = 1e-10, *,
                         method: str = "floquet", order: int = 2):
        """Amplitudes A_min < A < A_max that stabilise the pendulum at each ω (vertical drive).

        method="floquet" (default): exact, by root-finding on the Floquet condition
        (characteristic curves a0, b1 of the Mathieu equation; with damping
        |tr M| = 1 + e^(−γT)) to relative accuracy ``tol``; returns a
        :class:`kapitza.floquet.FloquetWindow` with the certified accuracy.  See
        :func:`kapitza.mathieu.pendulum_stability_window`.

        method="averaging": the averaging prediction of order ``order`` (inverted
        only); see :func:`kapitza.averaging.stability_window`.
        """
        if self.drive != "vertical":
            raise ValueError("stability_window is defined for the vertical drive; the "
                             "horizontally driven pendulum has no stable upright state.")
        if method == "averaging":
            from .averaging import stability_window
            return stability_window(omega, l=self.l, g=self.g, damping=self.damping, order=order)
        if method != "floquet":
            raise ValueError(f"method must be 'floquet' or 'averaging', got {method!r}.")
        from .floquet import FloquetWindow
        from .mathieu import pendulum_stability_window
        w = np.atleast_1d(np.asarray(omega, dtype=float))
        Amin, Amax, acc = pendulum_stability_window(w, l=self.l, g=self.g, gamma=self.damping,
                                                    about=about, tol=tol)
        return FloquetWindow(omega=w, A_min=Amin, A_max=Amax, accuracy=acc, about=about,
                             tol=tol)

    # -- Floquet (kapitza.floquet, kapitza.mathieu) ---------------------------------------
    def _equilibrium(self, about):
        if self.drive != "vertical":
            raise ValueError("Floquet analysis needs an equilibrium that persists under the "
                             "drive; with the horizontal drive neither θ = 0 nor θ = π does. "
                             "Use drive='vertical'.")
        if about == "inverted":
            return [math.pi]
        if about == "hanging":
            return [0.0]
        raise ValueError(f"about must be 'inverted' (θ = π) or 'hanging' (θ = 0), got {about!r}.")

    def floquet(self, A: float, omega: float, about: str = "inverted", tol: float = 1e-10):
        """Floquet analysis of the linearised pendulum about θ = π or θ = 0 (vertical drive).

        Integrates the monodromy of the system's exact Jacobian over one drive
        period (:func:`kapitza.floquet.floquet`) to relative accuracy ``tol``.

        Returns
        -------
        kapitza.floquet.FloquetResult
            ``trace``, ``multipliers``, ``stable``, ``omega_slow`` (rad/s; the exact
            linear slow frequency: cos(πβ) = tr M e^(γT/2)/2, Ω = βω/2), guards.
        """
        from .floquet import floquet
        q = self._equilibrium(about)
        for name, v in (("A", A), ("omega", omega)):
            if np.ndim(v) != 0 or not np.isfinite(v):
                raise ValueError(f"{name} must be a finite scalar, got {v!r}; use "
                                 "stability_map for grids.")
        if A < 0 or omega <= 0:
            raise ValueError(f"need A ≥ 0 (m) and omega > 0 (rad/s), got A={A}, omega={omega}.")
        return floquet(self.system, self.params(float(A), float(omega)), q, tol=tol)

    def stability_map(self, A, omega, about: str = "inverted", *, trace: bool = False,
                      tol: float = 1e-10):
        """Stability of θ = π (or θ = 0) over the grid A × ω (vertical drive).

        Undamped: characteristic values of the Mathieu equation once per A and a
        comparison for every ω (the whole grid in milliseconds; boundaries exact
        to ≈ 1e-15 relative); damped or ``trace=True``: the monodromy trace at
        every point to ``tol``.  See :func:`kapitza.mathieu.pendulum_stability_map`.

        Returns
        -------
        kapitza.floquet.StabilityMap
            axes A (m), omega (rad/s); ``stable``, ``label`` / ``boundary`` (period
            T or 2T bounds each unstable region), ``trace``, ``log_growth``;
            ``to_dataframe()``, ``figure()`` (with the averaging prediction).
        """
        from .mathieu import pendulum_stability_map
        self._equilibrium(about)
        return pendulum_stability_map(A, omega, l=self.l, g=self.g, gamma=self.damping,
                                      about=about, trace=trace, tol=tol)

    # -- direct integration (lagrange_core) --------------------------------------------
    def simulate(self, theta0: float, theta_dot0: float, t_span, A: float, omega: float, *,
                 method=None, rtol: float = 1e-9, t_eval=None, **options):
        """Integrate the full nonlinear motion θ(t), the check on averaging and Floquet.

        Parameters
        ----------
        theta0, theta_dot0 : float
            Initial angle (rad, from the downward vertical) and angular velocity (rad/s).
        t_span : (t0, t1)
            Time interval (s).
        A, omega : float
            Drive amplitude (m) and angular frequency (rad/s).
        method, rtol, t_eval, **options
            As for :meth:`lagrange_core.System.simulate` (default: the adaptive
            Runge–Kutta–Nyström 12(10) method when undamped, DOP853 when damped).

        Returns
        -------
        lagrange_core.integrate.Trajectory
            ``t``, ``q`` (column ``theta``), ``qdot``, ``energy``, ``error_estimate``, ...
        """
        return self.system.simulate([theta0], [theta_dot0], t_span, self.params(A, omega),
                                    method=method, rtol=rtol, t_eval=t_eval, **options)

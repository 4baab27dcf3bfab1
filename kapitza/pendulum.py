"""The Kapitza pendulum: one object for averaging, Floquet and direct integration.

Conventions (shared/PHYSICS.md): θ from the downward vertical (θ = π upright);
pivot y_p = A cos ωt (vertical drive) or x_p = A cos ωt (horizontal drive);
viscous damping γ (1/s):

    θ̈ = −γ θ̇ − (g − A ω² cos ωt) sin θ / l          (vertical drive)

The analyses live in their own rooms (:mod:`kapitza.closed_forms`, :mod:`kapitza.floquet`,
:mod:`kapitza.simulation`, :mod:`kapitza.verification`) and return the value types of
:mod:`kapitza.results`; this class holds the pendulum's constants and routes to
them, so a user meets one object.  Its methods take the drive first, then the state
(``docs/api-conventions.md`` §2): ``pend.simulate(A, omega, theta0, theta_dot0, t_span)``.
"""
from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from lagrange_core import problems
from lagrange_core.checks import real_array

from . import _arguments as arguments
from . import closed_forms
from . import floquet as _floquet
from ._deprecation import keyword_options, state_was_first, warn_deprecated
from .floquet import floquet_point
from .results import (
    ComputationInterrupted,
    FloquetResult,
    Measurement,
    PendulumAveraging,
    PeriodicOrbit,
    StabilityMap,
    StabilityWindow,
    Verification,
)
from .simulation import DEFAULT_PERIODS, pendulum_about, periodic_orbit, point, squeeze
from .simulation import measure_grid as measure_system_grid
from .verification import line_argument, pendulum_verification

__all__ = ["KapitzaPendulum"]


@functools.cache
def _driven_pendulum(drive: str, damped: bool):
    # one System per variant and process: derivation and kernels are shared
    return problems.driven_pendulum(drive, damping=damped)




def _check_release(where, theta0, centre, band, about):
    """theta0 within the band about the state the run is measured about (the general
    measure_grid checks the same, in its own names: q0, about), and not so large that a
    float cannot resolve the band there (θ0 = 1e300 made the band's ends equal)."""
    half = arguments.real_number(band, "band", unit="rad", minimum=0.0, strict=True)
    theta0, centre = np.broadcast_arrays(theta0, np.asarray(centre, dtype=float))
    lost = (centre - half) == (centre + half)
    if np.any(lost):
        raise ValueError(f"{where}theta0 = {float(theta0[lost].flat[0])!r} rad is too large to "
                         f"measure about: a float there cannot resolve the band of ±{half:g} "
                         "rad; give the angle within a few turns of 0 (θ0 mod 2π).")
    outside = ~(np.abs(theta0 - centre) < half)
    if np.any(outside):
        raise ValueError(f"{where}theta0 = {float(theta0[outside].flat[0])!r} rad lies outside "
                         f"the band |θ − θ*| < {half:g} rad about the state it is measured "
                         f"about, θ* = {float(centre[outside].flat[0]):.6g} rad ("
                         + (f"about={about!r}" if about is not None else "about=None: the "
                            "upright state, or the tilted one of the horizontal drive")
                         + "); release it near that state, pass the state it starts near as "
                         "about, a wider band, or band=None.")


#: ``simulate``'s arguments before kapitza 0.2, in their order then
_OLD_SIMULATE = ("theta0", "theta_dot0", "t_span", "A", "omega")


def _drive_was_last(method: Callable) -> Callable:
    """Before kapitza 0.2 ``simulate(theta0, theta_dot0, t_span, A, omega)``: a call whose
    third positional argument is a pair (the time span, not the angle θ0) is that order;
    it still works and warns."""
    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        if len(args) >= 3 and np.ndim(args[2]) == 1 and np.size(args[2]) == 2:
            if len(args) > len(_OLD_SIMULATE):
                raise TypeError(f"KapitzaPendulum.simulate() takes at most "
                                f"{len(_OLD_SIMULATE)} positional arguments ({len(args)} given).")
            for name in _OLD_SIMULATE[:len(args)]:
                if name in kwargs:
                    raise TypeError(f"KapitzaPendulum.simulate() got {name} twice; call "
                                    "simulate(A, omega, theta0, theta_dot0, t_span).")
            warn_deprecated("KapitzaPendulum.simulate(theta0, theta_dot0, t_span, A, omega)",
                            "KapitzaPendulum.simulate(A, omega, theta0, theta_dot0, t_span)")
            kwargs.update(zip(_OLD_SIMULATE, args, strict=False))
            args = ()
        return method(self, *args, **kwargs)

    return wrapper


@dataclass(frozen=True)
class KapitzaPendulum:
    """A pendulum whose pivot is shaken as A cos ωt.

    Parameters
    ----------
    l : float
        Length (m), > 0: of the massless rod of a point-mass pendulum, or the equivalent
        length I/(m d) of a physical pendulum (:meth:`physical`, :meth:`rod`).
    g : float
        Gravitational acceleration (m/s²), ≥ 0.
    damping : float
        Linear viscous damping rate γ (1/s), ≥ 0.
    drive : {"vertical", "horizontal"}
        Direction of the pivot's oscillation.

    Examples
    --------
    Kapitza's experiment: l = 1 m, A = 5 cm at 60 Hz.  Averaging says the upright
    state is stable with the slow frequency √(A²ω²/2 − g/l); the exact Floquet
    analysis agrees to 0.2 %, and the exact window of amplitudes contains A:

    >>> import math
    >>> pend = KapitzaPendulum(l=1.0, g=9.81)
    >>> w = 2 * math.pi * 60
    >>> avg = pend.averaged(A=0.05, omega=w).inverted
    >>> exact = pend.floquet(A=0.05, omega=w, about="inverted")
    >>> avg.stable, exact.stable
    (True, True)
    >>> print(f"Ω: averaging {avg.omega_slow:.2f} rad/s, exact {exact.omega_slow:.2f} rad/s")
    Ω: averaging 12.96 rad/s, exact 12.98 rad/s
    >>> win = pend.window(w)
    >>> print(f"{win.A_min:.4f} m < A < {win.A_max:.4f} m")
    0.0117 m < A < 0.4541 m
    """

    l: float = 1.0
    g: float = 9.81
    damping: float = 0.0
    drive: str = "vertical"

    def __post_init__(self):
        arguments.pendulum_constants(self.l, self.g, self.damping, where="KapitzaPendulum: ")
        arguments.drive_direction(self.drive, where="KapitzaPendulum: ")

    @classmethod
    def physical(cls, inertia: float, distance: float, mass: float = 1.0, *, g: float = 9.81,
                 damping: float = 0.0, drive: str = "vertical") -> KapitzaPendulum:
        """A physical pendulum: any rigid body pivoted at a shaken point.

        Parameters
        ----------
        inertia : float
            Moment of inertia about the pivot, I (kg m²), > 0.
        distance : float
            Pivot to centre of mass, d (m), > 0.
        mass : float
            m (kg), > 0.
        g, damping, drive
            As for the class; ``damping`` is γ in I θ̈ = −I γ θ̇ − m d (g + ÿ_p) sin θ.

        Its angle obeys I θ̈ = −m d (g + ÿ_p) sin θ: the point-mass equation with l
        replaced by the equivalent length l_eq = I/(m d), the pivot's motion entering
        unchanged (shared/PHYSICS.md).  So every result of the returned pendulum
        (averaging, windows, Floquet, θ(t)) holds exactly for the body, with A the
        pivot's amplitude; only ``simulate``'s ``energy`` is that of the equivalent
        point mass of 1 kg.

        Examples
        --------
        >>> KapitzaPendulum.physical(inertia=2.0, distance=0.5, mass=4.0).l      # I/(m d)
        1.0
        """
        inertia = arguments.real_number(inertia, "inertia", unit="kg m²", minimum=0.0,
                                        strict=True)
        distance = arguments.real_number(distance, "distance", unit="m", minimum=0.0,
                                         strict=True)
        mass = arguments.real_number(mass, "mass", unit="kg", minimum=0.0, strict=True)
        return cls(l=inertia / (mass * distance), g=g, damping=damping, drive=drive)

    @classmethod
    def rod(cls, length: float, *, g: float = 9.81, damping: float = 0.0,
            drive: str = "vertical") -> KapitzaPendulum:
        """A uniform rod of ``length`` L (m) pivoted at one end: l_eq = 2L/3 (I = m L²/3,
        d = L/2; see :meth:`physical`).

        Examples
        --------
        >>> round(KapitzaPendulum.rod(1.5).l, 12)
        1.0
        """
        length = arguments.real_number(length, "length", unit="m", minimum=0.0, strict=True)
        return cls.physical(length**2 / 3, length / 2, 1.0, g=g, damping=damping, drive=drive)

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

    # -- averaging (kapitza.closed_forms) ------------------------------------------------
    @state_was_first("KapitzaPendulum.effective_potential", method=True)
    def effective_potential(self, A, omega, *, theta):
        """Kapitza effective potential per unit mass U_eff(θ)/m (J/kg), first-order averaging.

        Vertical drive: −g l cos θ + A² ω² sin² θ / 4; horizontal: −g l cos θ +
        A² ω² cos² θ / 4.  Broadcasts over A (m), ω (rad/s), θ (rad).  See
        :func:`kapitza.closed_forms.pendulum_effective_potential`.  Before kapitza 0.2
        the order was ``effective_potential(theta, A, omega)``; it still works and warns.

        Examples
        --------
        >>> import math
        >>> print(KapitzaPendulum().effective_potential(0.05, 150.0, theta=math.pi))   # g l
        9.81
        """
        return closed_forms.pendulum_effective_potential(A, omega, theta=theta, l=self.l,
                                                         g=self.g, drive=self.drive)

    @keyword_options("KapitzaPendulum.averaged", 3, ("order", "warn", "progress"))
    def averaged(self, A, omega, *, order: int = 1, warn: bool = True,
                 progress=None) -> PendulumAveraging:
        """Averaged predictions: equilibria, stability, slow frequencies, validity flags.

        ``A`` (m) and ``omega`` (rad/s) may be arrays (closed forms, numpy speed).
        ``order=2`` adds the next order (vertical drive).  Returns
        :class:`kapitza.results.PendulumAveraging` with ``.inverted``, ``.hanging``
        (and ``.tilted`` for the horizontal drive); see
        :func:`kapitza.closed_forms.pendulum_averaged` for formulas and accuracy,
        and for ``progress`` (large arrays run in chunks; Ctrl-C keeps the finished part).
        """
        return closed_forms.pendulum_averaged(A, omega, l=self.l, g=self.g,
                                              damping=self.damping, drive=self.drive,
                                              order=order, warn=warn, progress=progress)

    def window(self, omega, about: str = "inverted", *, tol: float = 1e-10,
               method: str = "floquet", order: int = 2) -> StabilityWindow:
        """Amplitudes A_min < A < A_max that stabilise the pendulum at each ω.

        Vertical drive: method="floquet" (default): exact, by root-finding on the Floquet
        condition (characteristic curves a0, b1 of the Mathieu equation; with damping
        |tr M| = 1 + e^(−γT)) to relative accuracy ``tol``, with the certified
        accuracy.  method="averaging": the averaging prediction of order ``order``
        (inverted only).  See :func:`kapitza.closed_forms.pendulum_window`.

        Horizontal drive: ``about="hanging"`` only (exact): the hanging orbit is stable
        from A = 0 up to the symmetry-breaking pitchfork A_max, where the tilted orbits
        branch off (averaging: A ω = √(2 g l)); :func:`kapitza.window` about the symmetric
        orbit, which is followed in A by shooting on the half-period map (scan up to
        A = 2 l).  The tilted orbits have no window from A = 0 (they are born at A_max):
        map them with :meth:`stability_map`.

        Returns
        -------
        kapitza.results.StabilityWindow
            Its ``method`` field says which.
        """
        if self.drive == "horizontal":
            if about != "hanging" or method != "floquet":
                raise ValueError(
                    f"window(about={about!r}, method={method!r}): with the horizontal drive "
                    "only the hanging orbit has a window of amplitudes from A = 0 (exact, "
                    "method='floquet'): it gives way at the pitchfork where the tilted orbits "
                    "are born, and no angle persists under the drive.  Use about='hanging', "
                    "or stability_map for the tilted and inverted orbits.")
            win = _floquet.window(self.system, self.params(0.0, 1.0), [0.0], omega=omega,
                                  tol=tol)
            return dataclasses.replace(win, about="hanging", l=self.l, g=self.g,
                                       damping=self.damping)
        self._vertical("window")
        return closed_forms.pendulum_window(omega, l=self.l, g=self.g, damping=self.damping,
                                            about=about, tol=tol, method=method, order=order)

    def stability_window(self, omega, about: str = "inverted", tol: float = 1e-10, *,
                         method: str = "floquet", order: int = 2) -> StabilityWindow:
        """Deprecated since kapitza 0.2.0: :meth:`window` (same arguments, ``tol=`` by
        keyword)."""
        warn_deprecated("KapitzaPendulum.stability_window(omega, ...)",
                        "KapitzaPendulum.window(omega, ...)")
        return self.window(omega, about, tol=tol, method=method, order=order)

    stability_window.__deprecated__ = "KapitzaPendulum.window(omega, ...)"

    # -- Floquet (kapitza.floquet, kapitza.closed_forms) ---------------------------------
    def _vertical(self, what):
        if self.drive != "vertical":
            raise ValueError(f"{what} needs an equilibrium that persists under the drive; with "
                             "the horizontal drive neither θ = 0 nor θ = π does. Use "
                             "drive='vertical'.")

    @keyword_options("KapitzaPendulum.floquet", 4, ("tol",))
    def floquet(self, A: float, omega: float, about: str = "inverted", *,
                tol: float = 1e-10) -> FloquetResult | PeriodicOrbit:
        """Floquet analysis of the linearised pendulum about θ = π or θ = 0 (vertical drive),
        or about the periodic orbit of the horizontal drive (``about="tilted"``).

        Vertical drive: integrates the monodromy of the system's exact Jacobian over one
        drive period (:func:`kapitza.floquet.floquet_point`) to relative accuracy ``tol``.
        Horizontal drive: no angle persists under the drive; the slow states are
        T-periodic orbits, found by Newton shooting from the averaging prediction
        (:func:`kapitza.simulation.periodic_orbit`): ``about="tilted"`` (the tilted
        state, cos θ* = 2gl/(Aω)², θ* > 0; it exists when (Aω)² > 2gl), "tilted-" (its
        mirror image), "hanging" or "inverted" (the orbits near θ = 0 and π).

        Returns
        -------
        kapitza.results.FloquetResult or kapitza.results.PeriodicOrbit
            Vertical: ``trace``, ``multipliers``, ``stable``, ``omega_slow`` (rad/s; the
            exact linear slow frequency: cos(πβ) = tr M e^(γT/2)/2, Ω = βω/2), guards.
            Horizontal: the orbit (its period mean ``q_mean``, ``multipliers``, ``stable``,
            ``omega_slow``).
        """
        A, omega = arguments.drive(A, omega)
        if A.ndim:
            raise ValueError(f"A and omega must be scalars here, got shape {A.shape}; use "
                             "stability_map for grids.")
        params = self.params(float(A), float(omega))
        if self.drive == "horizontal":
            guess = self._orbit_guess(about, A, omega)
            if about in ("hanging", "inverted"):
                # the symmetric orbit θ(t + T/2) = 2θc − θ(t), shot on the half period:
                # regular at the pitchfork where the full period map is singular
                return periodic_orbit(self.system, params, [guess], symmetry=[guess],
                                      tol=tol)
            orbit = periodic_orbit(self.system, params, [guess], symmetry=None, tol=tol)
            mean = abs(float(orbit.q_mean[0]))
            if mean < 1e-9 or abs(mean - math.pi) < 1e-9:
                raise ValueError(
                    f"KapitzaPendulum.floquet(about={about!r}): shooting from the averaged "
                    f"tilt {guess:.6g} rad converged to the symmetric orbit about "
                    f"θ = {float(orbit.q_mean[0]):.3g} rad, not a tilted one: at A = "
                    f"{float(A):.6g} m, ω = {float(omega):.6g} rad/s the tilted orbits have "
                    "not yet branched off (or are too close to the hanging one to tell "
                    "apart). Use about='hanging', or a larger A.")
            return orbit
        theta = arguments.about_angle(about)
        return floquet_point(self.system, params, [theta], tol=tol)

    def _orbit_guess(self, about, A, omega):
        """The averaging prediction of a horizontal drive's slow state (rad)."""
        if about in ("hanging", "inverted"):
            return arguments.about_angle(about)
        if about not in ("tilted", "tilted+", "tilted-"):
            raise ValueError(f"about must be 'tilted', 'tilted-', 'hanging' or 'inverted' for "
                             f"the horizontal drive, got {about!r}.")
        c = 2 * self.g * self.l / (float(A) * float(omega)) ** 2
        if c >= 1:
            raise ValueError(f"the horizontal drive tilts the pendulum only when (Aω)² > 2gl; "
                             f"here (Aω)² = {(float(A) * float(omega)) ** 2:.4g} m²/s² ≤ "
                             f"2gl = {2 * self.g * self.l:.4g}. Use about='hanging', or a "
                             "stronger drive.")
        return -math.acos(c) if about == "tilted-" else math.acos(c)

    def stability_map(self, A, omega, about: str = "inverted", *, trace: bool = False,
                      tol: float = 1e-10, progress=None) -> StabilityMap:
        """Stability of θ = π (or θ = 0) over the grid A × ω; with the horizontal drive, of
        its periodic orbits.

        Vertical drive, undamped: characteristic values of the Mathieu equation once per
        A and a comparison for every ω (the whole grid in milliseconds; boundaries exact
        to ≈ 1e-15 relative); damped or ``trace=True``: the monodromy trace at
        every point to ``tol``, in chunks with a progress line on stderr (``progress``)
        and Ctrl-C keeping the finished rows (:class:`kapitza.results.ComputationInterrupted`).
        See :func:`kapitza.closed_forms.pendulum_stability_map`.

        Horizontal drive: no angle persists under the drive; the map is that of the
        periodic orbit ``about`` (:func:`kapitza.stability_map` about an orbit), followed
        over the grid by Newton shooting from point to point (``trace`` is always
        computed; ``tol`` is the shooting's residual, at least 1e-10).  "hanging",
        "inverted": the orbits symmetric about θ = 0, π, shot on the half-period map (regular
        at the pitchfork where the hanging orbit hands over to the tilted ones), each ω
        followed from the smallest A.  "tilted" (θ* > 0), "tilted-": the tilted orbit found
        at the grid's largest A and ω from averaging's cos θ* = 2gl/(Aω)²
        (:meth:`floquet`), then followed over the grid; where it does not exist (below the
        pitchfork) a point has no orbit: unstable, NaN trace, flagged.

        Returns
        -------
        kapitza.results.StabilityMap
            axes A (m), omega (rad/s); ``stable``, ``label`` / ``boundary`` (period
            T or 2T bounds each unstable region), ``trace``, ``log_growth``;
            ``to_dataframe()``.  Draw it with :func:`kapitza.figures.stability_map_figure`
            (overlay e.g. ``window(omega, method="averaging", order=1)``).

        Examples
        --------
        The horizontal drive at ω = 60 rad/s: the hanging orbit holds up to the pitchfork
        at A = 7.38 cm (averaging: √(2gl)/ω = 7.38 cm), where the tilted orbit takes over.

        >>> import numpy as np
        >>> pend = KapitzaPendulum(drive="horizontal")
        >>> A = np.array([0.05, 0.07, 0.08, 0.1])
        >>> pend.stability_map(A, [60.0], about="hanging").stable[:, 0].tolist()
        [True, True, False, False]
        >>> pend.stability_map(A, [60.0], about="tilted").stable[:, 0].tolist()
        [False, False, True, True]
        """
        if self.drive == "horizontal":
            return self._orbit_map(A, omega, about, tol, progress)
        return closed_forms.pendulum_stability_map(A, omega, l=self.l, g=self.g,
                                                   damping=self.damping, about=about,
                                                   trace=trace, tol=tol, progress=progress)

    def _orbit_map(self, A, omega, about, tol, progress) -> StabilityMap:
        """The horizontal drive's map of the periodic orbit ``about`` (see stability_map)."""
        A = arguments.grid_axis("A", A, "m", positive=False)
        omega = arguments.grid_axis("omega", omega, "rad/s", positive=True)
        fixed = {k: v for k, v in self.params(0.0, 1.0).items() if k not in ("A", "omega")}
        if about in ("hanging", "inverted"):
            state = [arguments.about_angle(about)]
        elif about not in ("tilted", "tilted+", "tilted-"):
            raise ValueError(f"about must be 'tilted', 'tilted-', 'hanging' or 'inverted' for "
                             f"the horizontal drive, got {about!r}.")
        elif A.size and omega.size:
            # the tilted orbit where it surely exists: the grid's strongest, fastest drive
            state = self.floquet(float(np.max(A)), float(np.max(omega)), about=about,
                                 tol=min(tol, 1e-10))
        else:
            state = [0.0]
        result = _floquet.stability_map(self.system, fixed, state, A=A, omega=omega,
                                        tol=max(tol, 1e-10), progress=progress)
        return dataclasses.replace(result, about=about, l=self.l, g=self.g,
                                   damping=self.damping, params={})

    # -- direct integration (lagrange_core) --------------------------------------------
    @_drive_was_last
    def simulate(self, A: float, omega: float, theta0: float, theta_dot0: float, t_span, *,
                 method=None, rtol: float = 1e-9, t_eval=None, **options):
        """Integrate the full nonlinear motion θ(t), the check on averaging and Floquet.

        Parameters
        ----------
        A, omega : float
            Drive amplitude (m) and angular frequency (rad/s).
        theta0, theta_dot0 : float
            Initial angle (rad, from the downward vertical) and angular velocity (rad/s).
        t_span : (t0, t1)
            Time interval (s).
        method, rtol, t_eval, **options
            As for :meth:`lagrange_core.System.simulate` (default: the adaptive
            Runge–Kutta–Nyström 12(10) method when undamped, DOP853 when damped).

        Before kapitza 0.2 the order was ``simulate(theta0, theta_dot0, t_span, A, omega)``;
        a call whose third positional argument is a pair (a time span) is taken in that
        order, and warns.

        Returns
        -------
        lagrange_core.integrate.Trajectory
            ``t``, ``q`` (column ``theta``), ``qdot``, ``energy``, ``error_estimate``, ...

        Examples
        --------
        Kapitza's 60 Hz, 5 cm drive holds the pendulum released 0.1 rad from the upright:

        >>> import math
        >>> traj = KapitzaPendulum().simulate(0.05, 2 * math.pi * 60, math.pi - 0.1, 0.0,
        ...                                   (0.0, 1.0))
        >>> bool(abs(traj.q[:, 0] - math.pi).max() < 0.2)
        True
        """
        A, omega = arguments.drive(A, omega, where="KapitzaPendulum.simulate: ")
        if A.ndim:
            raise ValueError(f"KapitzaPendulum.simulate: A and omega must be scalars, got shape "
                             f"{A.shape}; call it once per point.")
        return self.system.simulate([theta0], [theta_dot0], t_span,
                                    self.params(float(A), float(omega)), method=method,
                                    rtol=rtol, t_eval=t_eval, **options)

    # -- measurements from direct integration (kapitza.simulation) ---------------------------
    def measure(self, A: float, omega: float, theta0: float, theta_dot0: float = 0.0, *,
                periods: int = DEFAULT_PERIODS, about=None, band=math.pi / 2,
                observables="all", method=None, rtol: float | None = None, t0: float = 0.0,
                progress=None) -> Measurement:
        """Simulate the full nonlinear motion from (θ0, θ̇0) and measure it.

        Parameters
        ----------
        A, omega : float
            Drive amplitude (m) and angular frequency (rad/s).
        theta0, theta_dot0 : float
            Initial angle (rad, from the downward vertical) and angular velocity (rad/s)
            at t0.
        periods : int
            Drive periods to simulate (strobe samples at t0 + kT, k = 0 … periods).
        about : {"inverted", "hanging", "tilted"}, float or None
            The state the motion is measured about: None takes "inverted" (θ = π) for
            the vertical drive and "tilted" for the horizontal one (the averaged tilt
            cos θ* = 2 g l/(A² ω²) on θ0's side; θ = 0 where A² ω² ≤ 2 g l); a name is
            taken in θ0's turn (θ0 = 3π − 0.1 is measured about 3π); or an angle (rad).
        band : float or None
            The run stops, and has not stayed up, where |θ − about| ≥ band (rad).  The
            default π/2 makes ``stayed_up`` the criterion |θ − π| < π/2 throughout for
            the inverted state.  None: no band.
        observables : "all", "classification", or a list of "amplitude", "omega_slow"
            What to measure (:func:`kapitza.measure_grid`): "classification" only
            decides stayed up / fall time / deviation, without strobe samples or the
            slow-frequency fit (those fields are None), at its own default tolerance.
        method, rtol, t0
            Integration method (None: RKN 12(10) undamped, DOP853 damped), relative
            tolerance (None: 1e-9 with Ω or the amplitude; to classify only 1e-4
            undamped, 1e-6 damped: :func:`kapitza.measure_grid` says why), start time (s;
            the drive's phase).
        progress : None, bool or callable
            A long run (millions of periods) shows a progress line with the time left
            when stderr is a terminal (None), always (True), never (False), or calls
            ``progress(done, total)``.  Ctrl-C stops it within a second and raises
            :class:`~kapitza.results.ComputationInterrupted` whose ``.result`` is the
            measurement of the run so far (status "interrupted", ``t_reached``,
            ``completed_periods``).

        Returns
        -------
        kapitza.results.Measurement
            Python floats: ``stayed_up``, ``fall_time`` (s), ``omega_slow`` (rad/s, from
            the strobe samples θ(t0 + kT), folded into [0, ω/2]) with
            ``omega_slow_error``, ``amplitude`` (slow, rad), ``mean_angle`` (time mean,
            rad: the measured tilt of the horizontal drive), ``growth_rate``, ...;
            ``energy_drift`` is None (a driven pendulum has no conserved energy).
            The estimator and what its error covers: :mod:`kapitza.simulation`.

        Examples
        --------
        Kapitza's 60 Hz, 5 cm drive holds the pendulum up; released 0.01 rad from the
        upright it oscillates at the exact linear slow frequency (Floquet: 12.9804 rad/s)
        less the amplitude's own shift, 2.6e-5 relative at 0.01 rad:

        >>> import math
        >>> pend = KapitzaPendulum(l=1.0, g=9.81)
        >>> m = pend.measure(A=0.05, omega=2 * math.pi * 60, theta0=math.pi - 0.01)
        >>> m.stayed_up, round(m.omega_slow, 4), m.omega_slow_error < 1e-6
        (True, 12.9801, True)
        >>> round(m.amplitude, 4)
        0.01
        """
        A, omega = arguments.drive(A, omega, where="KapitzaPendulum.measure: ")
        if A.ndim or np.ndim(theta0) or np.ndim(theta_dot0):
            raise ValueError("KapitzaPendulum.measure: A, omega, theta0 and theta_dot0 must be "
                             "scalars; use measure_grid for grids.")
        try:
            return point(self.measure_grid(A, omega, theta0, theta_dot0, periods=periods,
                                           about=about, band=band, observables=observables,
                                           method=method, rtol=rtol, t0=t0,
                                           progress=progress))
        except ComputationInterrupted as stop:
            one = ComputationInterrupted(point(stop.result), stop.computed)
            one.args = stop.args             # how far it got
            raise one from None

    def measure_grid(self, A, omega, theta0, theta_dot0=0.0, *,
                     periods: int = DEFAULT_PERIODS, about=None, band=math.pi / 2,
                     observables="all", method=None, rtol: float | None = None,
                     t0: float = 0.0, progress=None) -> Measurement:
        """:meth:`measure` over a grid, through the compiled batch integrator.

        ``A`` (m), ``omega`` (rad/s), ``theta0`` and ``theta_dot0`` broadcast
        numpy-style (``A[:, None], omega[None, :]`` for an (A, ω) grid); ``about`` (an
        angle may be an array) and the other options as for :meth:`measure`;
        ``progress`` as for :meth:`lagrange_core.System.simulate_grid` (a line on stderr
        when it is a terminal; Ctrl-C raises
        :class:`~kapitza.results.ComputationInterrupted` with the finished points).
        ``observables="classification"`` decides stayed up, fall time and deviation at
        the engine's speed (no strobe samples, no slow-frequency fits; rtol 1e-4 by
        default undamped, 1e-6 damped): the classification a stability chart needs.

        Returns
        -------
        kapitza.results.Measurement
            Every field an array of the broadcast shape S (θ is the one coordinate, so
            the per-mode and per-coordinate fields have shape S too); ``to_dataframe()``
            gives one row per point.

        Examples
        --------
        Released 0.1 rad from the upright at 60 Hz: 1 cm of drive lets the pendulum fall
        (the Kapitza limit is 1.17 cm), 3 and 10 cm hold it.

        >>> import math, numpy as np
        >>> pend = KapitzaPendulum()
        >>> m = pend.measure_grid(np.array([0.01, 0.03, 0.1]), 2 * math.pi * 60,
        ...                       math.pi - 0.1, periods=500)
        >>> m.stayed_up.tolist(), bool(m.fall_time[0] > 0)
        ([False, True, True], True)
        >>> c = pend.measure_grid(np.array([0.01, 0.03, 0.1]), 2 * math.pi * 60,
        ...                       math.pi - 0.1, periods=500, observables="classification")
        >>> c.stayed_up.tolist(), c.omega_slow is None, c.rtol
        ([False, True, True], True, 0.0001)
        """
        where = "KapitzaPendulum.measure_grid: "
        A = arguments.amplitude(A, where=where)
        omega = arguments.frequency(omega, where=where)
        theta0 = real_array(theta0, "theta0", unit="rad")
        theta_dot0 = real_array(theta_dot0, "theta_dot0", unit="rad/s")
        try:
            np.broadcast_shapes(A.shape, omega.shape, theta0.shape, theta_dot0.shape)
        except ValueError:
            raise ValueError(f"{where}A, omega, theta0 and theta_dot0 must broadcast together, "
                             f"got shapes {A.shape}, {omega.shape}, {theta0.shape} and "
                             f"{theta_dot0.shape}.") from None
        centre = pendulum_about(about, A, omega, theta0, l=self.l, g=self.g,
                                        drive=self.drive)
        if band is not None:
            _check_release(where, theta0, centre, band, about)
        result = measure_system_grid(
            self.system, self.params(A, omega), np.asarray(centre)[..., None],
            theta0[..., None], theta_dot0[..., None], periods=periods,
            band=band if band is None else arguments.real_number(band, "band", unit="rad",
                                                                 minimum=0.0, strict=True),
            t0=t0, observables=observables, method=method, rtol=rtol, progress=progress)
        return squeeze(result)

    # -- verification: the four methods compared (kapitza.verification) -------------------
    def verify(self, A, omega, *, theta0: float = math.pi - 0.01, theta_dot0: float = 0.0,
               periods: int = DEFAULT_PERIODS, tol: float = 1e-10, rtol: float = 1e-9,
               method=None, line=None, progress=None) -> Verification:
        """First- and next-order averaging, Floquet analysis and direct simulation of the
        upright pendulum (vertical drive), compared point by point.

        Parameters
        ----------
        A, omega : array_like
            Drive amplitudes (m) and angular frequencies (rad/s), broadcast as in
            :meth:`measure_grid` (``A[:, None], omega[None, :]`` for a grid).
        theta0, theta_dot0 : float or array_like
            The simulations' release (rad, rad/s; broadcast too), near θ = π.
        periods, rtol, method
            Drive periods simulated, the integration's tolerance and method
            (:meth:`measure_grid`; stayed up: |θ − π| < π/2 throughout).
        tol : float
            Floquet's tolerance (the trace of the Mathieu equation's monodromy, relative to
            max(1, |tr|): the numbers of :func:`kapitza.floquet_grid` for this system),
            and the exact window's.
        line : None, False or (velocity, omega)
            Where the order of averaging is fitted (None: A ω = 2√(g l), ε = ω0/ω from
            0.1 to 1/300; False: no fit); see :mod:`kapitza.verification`.
        progress
            As for :meth:`measure_grid` (the simulations).

        Returns
        -------
        kapitza.results.Verification
            Per point the four classifications and Ω with their tolerances, agreement
            statistics (``agreement``), every disagreement located by A/l, ω/ω0 and its
            distance to the exact window's nearest edge (``disagreements``), the fitted
            orders of first- and next-order averaging (``exponent``, ``fits``),
            ``to_dataframe()`` and ``figure()``.  Methods and tolerances:
            :mod:`kapitza.verification`.

        Examples
        --------
        Three drives at 40 Hz (the exact window is 1.77 cm < A < 45 cm): 1 cm falls,
        3 and 10 cm hold, and all four methods agree:

        >>> import math, numpy as np
        >>> v = KapitzaPendulum().verify(np.array([0.01, 0.03, 0.1]), 2 * math.pi * 40,
        ...                              periods=400, line=False)
        >>> v.stable_simulation.tolist(), v.stable_floquet.tolist()
        ([False, True, True], [False, True, True])
        >>> len(v.disagreements)
        0
        """
        self._vertical("verify")
        where = "KapitzaPendulum.verify: "
        line = line_argument(line)
        A = arguments.amplitude(A, where=where)
        omega = arguments.frequency(omega, where=where)
        measured = self.measure_grid(A, omega, theta0, theta_dot0, periods=periods,
                                     about="inverted", method=method, rtol=rtol,
                                     progress=progress, observables=("omega_slow", "amplitude"))
        return pendulum_verification(A, omega, measured, l=self.l, g=self.g,
                                     damping=self.damping, tol=tol, rtol=rtol, line=line)

"""Results of direct simulation: what the full motion did, and periodic orbits.

:class:`Measurement` (:func:`kapitza.measure`, :func:`kapitza.measure_grid`) and
:class:`PeriodicOrbit` (:func:`kapitza.periodic_orbit`), both of
:mod:`kapitza.simulation`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["Measurement", "PeriodicOrbit"]

#: Measurement fields with one entry per slow mode (ascending frequency) or per coordinate.
_MODE_FIELDS = ("omega_slow", "omega_slow_error", "refined", "growth_rate")
_COORDINATE_FIELDS = ("about", "amplitude", "mean_angle", "max_deviation")
_POINT_FIELDS = ("period", "stayed_up", "fall_time", "fit_residual", "samples",
                 "energy_drift", "status")


@dataclass(frozen=True)
class Measurement:
    """What direct integration of the full nonlinear motion measured, point by point.

    Built by :func:`kapitza.measure_grid` (a broadcast grid: every field an array of the
    grid's shape S, followed by the axis stated), :func:`kapitza.measure` (one point: 0-d
    fields are Python scalars, and a one-coordinate system's per-mode and per-coordinate
    fields are floats) and :meth:`kapitza.KapitzaPendulum.measure` / ``measure_grid`` (one
    coordinate θ: those fields have the grid's shape).  How each number is measured, and
    what its error estimate covers, is in :mod:`kapitza.simulation`.

    Attributes
    ----------
    coordinates : tuple of str
        The system's coordinates, in order.
    params : dict of str to array
        Every parameter's value at every point (broadcast to S).
    about : array (S + (n,))
        The state the band is centred on: a driven equilibrium (the pendulum's
        θ = π) or an estimate of a periodic orbit's position (the tilt θ* of the
        horizontally driven pendulum) (rad for angles).
    period : array (S)
        The drive period T = 2π/ω (s); the strobe samples are t0 + kT.
    periods : int
        Drive periods simulated (K = periods + 1 strobe samples).
    stayed_up : bool array (S)
        The run finished without leaving the band |q_i − about_i| < band_i (for the
        inverted pendulum: it stayed up, |θ − π| < π/2 throughout); False where it
        left the band or the integration failed (see ``status``).
    fall_time : array (S)
        Time from the start to leaving the band (s); NaN where it did not.
    omega_slow : array (S + (n,))
        Slow angular frequencies (rad/s) of the motion, ascending, from the
        stroboscopic samples up to the stop, folded into [0, ω/2] (aliasing); NaN where
        a mode is not resolved (too few samples, a real multiplier).
    omega_slow_error : array (S + (n,))
        Error estimate of ``omega_slow`` (rad/s): the estimator's error for the
        simulated motion (the record's two halves, the fit's bias); not the
        integration error, not the amplitude dependence (see :mod:`kapitza.simulation`).
    refined : bool array (S + (n,))
        The mode's Ω is its rotation number (else the linear strobe map's value).
    growth_rate : array (S + (n,))
        log|λ| / T of each mode's strobe-map eigenvalue (1/s): ≈ 0 for a stable
        undamped oscillation, ≈ −γ/2 for the damped pendulum, > 0 growing.
    fit_residual : array (S)
        Relative residual of the linear strobe map fit: the harmonic content of the
        slow motion (≈ 0 for small oscillations).
    amplitude : array (S + (n,))
        Slow amplitude per coordinate: half the peak-to-peak range of the strobe
        samples q(t0 + kT) (rad for angles), which hold no fast motion.
    mean_angle : array (S + (n,))
        Time average of each coordinate over the run (rad for angles): the mean tilt
        of the horizontally driven pendulum.
    max_deviation : array (S + (n,))
        max |q − about| over the run, the fast motion included.
    energy_drift : array (S) or None
        max |E(t) − E(t0)| (J) where the system's energy function is conserved (no
        drive, forces or dissipation); None for a driven system, which has none.
    samples : int array (S)
        Strobe samples recorded (up to a stop).
    status : str array (S)
        How each run ended: "finished", "left_band", "underflow", "non_finite",
        "singular", "max_steps" (:data:`lagrange_core.batch.STATUS_NAMES`).
    method : str
        The integration method.
    rtol : float
        Its relative tolerance.
    """

    coordinates: tuple
    params: dict
    about: ArrayLike
    period: ArrayLike
    periods: int
    stayed_up: ArrayLike
    fall_time: ArrayLike
    omega_slow: ArrayLike
    omega_slow_error: ArrayLike
    refined: ArrayLike
    growth_rate: ArrayLike
    fit_residual: ArrayLike
    amplitude: ArrayLike
    mean_angle: ArrayLike
    max_deviation: ArrayLike
    energy_drift: ArrayLike | None
    samples: ArrayLike
    status: ArrayLike
    method: str
    rtol: float

    @property
    def shape(self) -> tuple:
        """The grid's shape S (() for one point)."""
        return np.shape(self.stayed_up)

    def to_dataframe(self):
        """One row per point: the parameters, then every field (per-mode fields as
        ``omega_slow_0``, ``omega_slow_1``, ... in ascending order, per-coordinate fields
        as ``amplitude_<coordinate>``)."""
        import pandas as pd
        S = self.shape
        size = int(np.prod(S, dtype=np.int64))
        data = {k: np.ravel(np.broadcast_to(np.asarray(v), S)) for k, v in self.params.items()}
        for name in _POINT_FIELDS[:3] + _MODE_FIELDS + _COORDINATE_FIELDS + _POINT_FIELDS[3:]:
            value = getattr(self, name)
            if value is None:
                continue
            value = np.asarray(value)
            if value.ndim == len(S):
                data[name] = value.reshape(size)
                continue
            labels = (range(value.shape[-1]) if name in _MODE_FIELDS else self.coordinates)
            for j, label in enumerate(labels):
                data[f"{name}_{label}"] = value[..., j].reshape(size)
        return pd.DataFrame(data)


@dataclass(frozen=True, eq=False)
class PeriodicOrbit:
    """A periodic orbit of a driven system and its Floquet stability (immutable).

    Built by :func:`kapitza.periodic_orbit` (Newton shooting on the period map; its
    docstring states the method and the accuracy).

    Attributes
    ----------
    coordinates : tuple of str
    params : dict
        The parameter values (scalars).
    period : float
        The orbit's period (s): ``periods`` × 2π/ω.
    periods : int
        Drive periods per orbit period (1: T-periodic; 2: a subharmonic orbit).
    state : ndarray (2n,)
        [q, q̇] on the orbit at t = 0 (the drive's phase zero).
    q_mean : ndarray (n,)
        Mean of q over one period (the slow state of averaging).
    amplitude : ndarray (n,)
        Half the peak-to-peak range of q over one period (the fast motion).
    multipliers : ndarray, complex (2n,)
        Eigenvalues of the monodromy, by decreasing modulus.
    monodromy : ndarray (2n, 2n) or None
        The monodromy matrix (None for a persisting equilibrium, analysed by
        :func:`kapitza.floquet_point`).
    stable : bool
        Every |λ| ≤ 1 up to the error (see :func:`kapitza.periodic_orbit`).
    omega_slow : float or ndarray (n,)
        Slow frequency |arg λ|/T of each stable pair (rad/s, in [0, ω/2]); NaN if
        unstable; a float for one coordinate.
    residual : float
        The residual of the equations shot at the returned state: |φ_T(y0) − y0|, or for
        a symmetric orbit shot on the half period |φ_{T/2}(y0) − S y0|.
    error_estimate : float
        A bound on the error of the state and the monodromy: the larger of
        ‖J⁻¹‖ (residual + integration error) for the state (J the Newton matrix of the
        equations shot) and the monodromy's integration error plus the state's error
        carried through it.
    iterations : int
        Newton steps taken (0: a persisting equilibrium).
    method : str
        Which map was shot ("period map", "half-period map (symmetric)") and, where
        it is ill-conditioned, by how much.
    condition : float
        ‖J⁻¹‖∞ of the Newton matrix of the equations shot (NaN for a persisting
        equilibrium): how much a residual is amplified into an error of the state.
    flags : tuple of str
        Accuracy warnings (each also raised as a RuntimeWarning); empty when the
        orbit is decided to its tolerance.
    """

    coordinates: tuple
    params: dict
    period: float
    periods: int
    state: np.ndarray
    q_mean: np.ndarray
    amplitude: np.ndarray
    multipliers: np.ndarray
    monodromy: np.ndarray | None
    stable: bool
    omega_slow: float | np.ndarray
    residual: float
    error_estimate: float
    iterations: int
    method: str
    condition: float = math.nan
    flags: tuple = ()

    def to_dataframe(self):
        """One row per coordinate: state at t = 0, period mean, fast amplitude (and the
        orbit's period, stability and slow frequency repeated)."""
        import pandas as pd
        n = len(self.coordinates)
        slow = np.broadcast_to(np.asarray(self.omega_slow, dtype=float), (n,))
        return pd.DataFrame({"q0": self.state[:n], "qdot0": self.state[n:],
                             "q_mean": self.q_mean, "amplitude": self.amplitude,
                             "omega_slow": slow, "period": self.period, "stable": self.stable},
                            index=pd.Index(self.coordinates, name="coordinate"))

"""kapitza's value types: every result the analyses return, in one place.

All are frozen dataclasses with named fields and a ``to_dataframe()`` (pandas, long
format).  They hold numbers, not behaviour: the analyses that fill them live in
:mod:`kapitza.floquet`, :mod:`kapitza.mathieu`, :mod:`kapitza.averaging` and
:mod:`kapitza.pendulum_closed_forms`; the figures that draw them in :mod:`kapitza.plots`.
This module imports nothing else from kapitza, so data flows one way:
results ← analyses ← figures.

Conventions (shared/PHYSICS.md): SI units; θ from the downward vertical (θ = π upright);
pivot A cos ωt; A in m, ω in rad/s, damping γ in 1/s; T = 2π/ω.

Contents
--------
Floquet analysis
    :class:`FloquetResult` (one parameter point), :class:`MonodromyData` and
    :class:`FloquetGrid` (a broadcast grid of points), :class:`StabilityMap` (an (A, ω)
    grid), :class:`StabilityWindow` (the stabilising amplitudes per ω, exact or by
    averaging), :class:`InceStruttChart` (the Mathieu equation's stability chart),
    :class:`BoundaryCurves` (exact boundaries A_k(ω)), :class:`AdaptiveMap` (a map
    refined where the classification changes).
Averaging of any system
    :class:`SlowModes`, :class:`AveragingPrediction`, :class:`SlowModeSweep`.
The driven pendulum and Acheson's chain in closed form
    :class:`EquilibriumPrediction`, :class:`PendulumAveraging`,
    :class:`MultiplePendulumPrediction`.
Direct simulation
    :class:`Measurement` (what the full motion did, with error estimates).
Verification
    :class:`Verification` (the four methods compared point by point, disagreements
    located), :class:`OrderFit` (the measured order of averaging).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["BOUNDARIES", "scalar_or_array", "FloquetResult", "MonodromyData", "FloquetGrid",
           "StabilityMap", "StabilityWindow", "FloquetWindow", "InceStruttChart", "SlowModes",
           "AveragingPrediction", "SlowModeSweep", "EquilibriumPrediction", "PendulumAveraging",
           "MultiplePendulumPrediction", "ComputationInterrupted", "Measurement",
           "VERIFICATION_METHODS", "OrderFit", "Verification", "BoundaryCurves", "AdaptiveMap"]

#: Names of the stability labels 0, 1, 2, 3: stable; unstable in a region bounded by
#: period-T solutions (multiplier +1); by period-2T solutions (multiplier −1); complex
#: multipliers leaving the unit circle (combination resonance).
BOUNDARIES = ("stable", "T", "2T", "complex")


def scalar_or_array(x):
    """A Python scalar for a 0-d value, the array otherwise (results keep their input's shape)."""
    x = np.asarray(x)
    return x.item() if x.ndim == 0 else x


def _boundary_names(label) -> np.ndarray:
    return np.asarray(BOUNDARIES, dtype=object)[np.asarray(label)]


def _unscale(scaled, log_scale):
    """M = scaled · e^log_scale; entries ±inf (NaN for zeros) where e^log_scale overflows."""
    ls = np.asarray(log_scale, dtype=float)[..., None, None]
    with np.errstate(over="ignore", invalid="ignore"):
        return np.where(ls > 700, scaled * np.inf, scaled * np.exp(np.minimum(ls, 700)))


class ComputationInterrupted(KeyboardInterrupt):
    """Ctrl-C during a long grid computation (a Floquet grid or map, a damped Mathieu map).

    A KeyboardInterrupt, so scripts still stop; it carries what was finished.

    Attributes
    ----------
    result
        The partial result (the type the call returns): finished points filled, the
        others NaN (traces, growth), unstable, and flagged where the type has flags.
    computed : bool ndarray
        Which points were finished (the result's grid shape).
    """

    def __init__(self, result, computed):
        self.result = result
        self.computed = np.asarray(computed, dtype=bool)
        super().__init__(f"interrupted: {int(self.computed.sum())} of {self.computed.size} "
                         "grid points were computed; the partial result is in the exception's "
                         ".result (.computed marks the finished points)")


def _scalar_if_one(values):
    """One slow frequency (a one-coordinate system) as a float, several as an array."""
    values = np.asarray(values)
    return float(values.reshape(-1)[0]) if values.size == 1 else values


# ======================================================================================
# Floquet analysis
# ======================================================================================

@dataclass(frozen=True)
class FloquetResult:
    """Floquet analysis of one linear time-periodic system x′ = J(t) x.

    Built by :func:`kapitza.floquet.floquet_point` (and
    :meth:`kapitza.KapitzaPendulum.floquet`).

    Attributes
    ----------
    period : float
        Drive period T = 2π/ω (s).
    monodromy_scaled : ndarray (2n, 2n)
        M e^(−log_scale); M itself is :attr:`monodromy` (inf where it overflows).
    log_scale : float
        log of the factor divided out of M (0 unless M would exceed 1e150).
    multipliers : ndarray, complex (2n)
        Floquet multipliers λ (eigenvalues of M) by decreasing modulus; ±inf if
        |λ| overflows a float (see :attr:`log_abs_multipliers`).
    log_abs_multipliers : ndarray (2n)
        log|λ|, finite even for astronomically large growth.
    trace : float
        tr M (±inf if beyond float range).
    stable : bool
        Linear stability, decided on the best estimate of M: 2 × 2: Jury's test
        |tr M| ≤ 1 + det M with the exact det = exp(∮ tr J); undamped (4 × 4 and
        larger): every x = λ + 1/λ real in [−2, 2], the roots of the symmetrised
        (palindromic) characteristic polynomial written in x; damped: all |λ| < 1.
        How sure the decision is, is the grid's ``margin``: points whose test is
        within its uncertainty (10× the error estimate) of the threshold are
        counted as uncertified by maps.
    omega_slow : float or ndarray
        Slow angular frequencies (rad/s) of the stable solutions, arg(λ)/T ∈
        [0, ω/2], one per pair of multipliers (NaN if unstable); a float for a system
        of one coordinate.  For the
        pendulum cos(πβ) = tr M e^(γT/2)/2 and Ω = βω/2: the exact linear value
        that first-order averaging approximates.
    exponents : ndarray, complex (2n)
        Floquet exponents μ = log λ / T (1/s); the real part is the growth rate.
    boundary : str
        "stable", or the kind of instability (:data:`BOUNDARIES`): "T" (real
        multiplier > 1: the region is bounded by period-T solutions), "2T" (real
        < −1: period 2T), "complex" (a complex quadruplet leaves the unit circle).
    error_estimate : float
        Estimated error of M relative to max(1, ‖M‖).
    steps, samples : int
        Taylor steps per period; samples of J per period.
    liouville_residual : float
        |det M / exp(∮ tr J dt) − 1|.
    pairing_residual : float
        max |c_k − c_{2n−k}| of the characteristic polynomial (relative); NaN
        for damped systems (no λ, 1/λ symmetry) or huge growth.
    flags : tuple of str
        Accuracy warnings; empty when every guard passed.
    """

    period: float
    monodromy_scaled: np.ndarray
    log_scale: float
    multipliers: np.ndarray
    log_abs_multipliers: np.ndarray
    trace: float
    stable: bool
    omega_slow: np.ndarray
    exponents: np.ndarray
    boundary: str
    error_estimate: float
    steps: int
    samples: int
    liouville_residual: float
    pairing_residual: float
    flags: tuple = field(default=())

    @property
    def monodromy(self) -> np.ndarray:
        """M (entries ±inf if beyond float range; use monodromy_scaled and log_scale)."""
        return _unscale(self.monodromy_scaled, self.log_scale)

    @property
    def log_growth(self) -> float:
        """max log|λ| per period (> 0 unstable); the growth rate is log_growth / period."""
        return float(self.log_abs_multipliers[0])

    def to_dataframe(self):
        """One row per multiplier: λ, |λ|, log|λ|, exponent, stable, boundary."""
        import pandas as pd
        return pd.DataFrame({"multiplier": self.multipliers,
                             "abs": np.abs(self.multipliers),
                             "log_abs": self.log_abs_multipliers,
                             "exponent": self.exponents,
                             "stable": self.stable, "boundary": self.boundary})


@dataclass(frozen=True)
class MonodromyData:
    """Monodromy matrices over a broadcast grid of parameter sets.

    Built by :func:`kapitza.floquet.monodromy_data`; every array field has the grid's
    shape (:attr:`shape`), followed by the matrix or vector axes where stated.

    Attributes
    ----------
    params : dict of str to ndarray
        Every parameter of the system by name, broadcast to the grid's shape.
    monodromy_scaled : ndarray (..., 2n, 2n)
        M e^(−log_scale) per point; M itself is :attr:`monodromy`.
    log_scale : ndarray
        log of the factor divided out of M (0 unless M would exceed 1e150).
    error_estimate : ndarray
        Estimated error of M relative to max(1, ‖M‖) (balanced variables, see
        :mod:`kapitza.floquet`).
    steps : int ndarray
        Taylor steps per period.
    samples : int
        Samples of J per period (the same at every point).
    period : ndarray
        Drive period T = 2π/ω (s).
    liouville_exponent : ndarray
        ∮ tr J dt over one period (det M = its exponential; −γT for the damped pendulum).
    """

    params: dict
    monodromy_scaled: np.ndarray
    log_scale: np.ndarray
    error_estimate: np.ndarray
    steps: np.ndarray
    samples: int
    period: np.ndarray
    liouville_exponent: np.ndarray

    @property
    def shape(self) -> tuple:
        """The grid's shape (that of the broadcast parameters)."""
        return np.shape(self.log_scale)

    @property
    def monodromy(self) -> np.ndarray:
        """M per point (entries ±inf where beyond float range)."""
        return _unscale(self.monodromy_scaled, self.log_scale)

    def _columns(self) -> dict:
        cols = {k: np.ravel(np.broadcast_to(v, self.shape)) for k, v in self.params.items()}
        cols.update(period=np.ravel(self.period), log_scale=np.ravel(self.log_scale),
                    error_estimate=np.ravel(self.error_estimate), steps=np.ravel(self.steps))
        return cols

    def to_dataframe(self):
        """One row per grid point: the parameters, period, log_scale, error_estimate, steps."""
        import pandas as pd
        return pd.DataFrame(self._columns())


# the keys of the dict floquet_grid used to return, for code written against it

@dataclass(frozen=True)
class FloquetGrid(MonodromyData):
    """Floquet analysis at every point of a broadcast parameter grid.

    Built by :func:`kapitza.floquet.floquet_grid`.  The monodromy fields are those of
    :class:`MonodromyData`; the analysis adds, per point (grid shape, then the axes
    stated), the fields of :class:`FloquetResult` — :meth:`point` returns one of them.

    Attributes
    ----------
    multipliers, log_abs_multipliers, exponents : ndarray (..., 2n)
        λ by decreasing modulus, log|λ|, log λ / T (1/s).
    trace : ndarray
        tr M (±inf beyond float range).
    stable : bool ndarray
    label : int8 ndarray
        Index into :data:`BOUNDARIES` (0 stable, 1 T, 2 2T, 3 complex); names in
        :attr:`boundary`.
    omega_slow : ndarray (..., n)
        Slow angular frequencies of stable points (rad/s), NaN where unstable.
    liouville_residual, pairing_residual : ndarray
        The accuracy guards (see :class:`FloquetResult`).
    margin : ndarray
        Distance of the stability test from its threshold in units of its error
        bound; > 1 certifies the classification.
    flags : tuple of tuple of str
        Accuracy warnings per point, in flat (C) order of the grid.
    refined_points : int
        Points integrated again to the fine tolerance (``certify=True``).
    """

    multipliers: np.ndarray
    log_abs_multipliers: np.ndarray
    exponents: np.ndarray
    trace: np.ndarray
    stable: np.ndarray
    label: np.ndarray
    omega_slow: np.ndarray
    liouville_residual: np.ndarray
    pairing_residual: np.ndarray
    margin: np.ndarray
    flags: tuple
    refined_points: int

    @property
    def log_growth(self) -> np.ndarray:
        """max log|λ| per period and point (> 0 unstable)."""
        return self.log_abs_multipliers[..., 0]

    @property
    def boundary(self) -> np.ndarray:
        """Label names per point: "stable", "T", "2T" or "complex"."""
        return _boundary_names(self.label)

    def point(self, index=()) -> FloquetResult:
        """The :class:`FloquetResult` of one grid point (``index`` into the grid's shape)."""
        index = tuple(np.ravel(index).astype(int).tolist())
        flat = int(np.ravel_multi_index(index, self.shape)) if index else 0
        return FloquetResult(
            period=float(self.period[index]), monodromy_scaled=self.monodromy_scaled[index],
            log_scale=float(self.log_scale[index]), multipliers=self.multipliers[index],
            log_abs_multipliers=self.log_abs_multipliers[index],
            trace=float(self.trace[index]), stable=bool(self.stable[index]),
            omega_slow=_scalar_if_one(self.omega_slow[index]), exponents=self.exponents[index],
            boundary=BOUNDARIES[int(self.label[index])],
            error_estimate=float(self.error_estimate[index]), steps=int(self.steps[index]),
            samples=int(self.samples), liouville_residual=float(self.liouville_residual[index]),
            pairing_residual=float(self.pairing_residual[index]), flags=self.flags[flat])

    def to_dataframe(self):
        """One row per grid point: the parameters, stable, boundary, trace, log_growth,
        margin, error_estimate, steps, ..."""
        import pandas as pd
        cols = self._columns()
        cols.update(stable=np.ravel(self.stable), boundary=np.ravel(self.boundary),
                    trace=np.ravel(self.trace), log_growth=np.ravel(self.log_growth),
                    margin=np.ravel(self.margin))
        return pd.DataFrame(cols)


@dataclass(frozen=True)
class StabilityMap:
    """Stability of a driven equilibrium over an (A, ω) grid.

    Built by :func:`kapitza.mathieu.pendulum_stability_map` (the single pendulum;
    :meth:`kapitza.KapitzaPendulum.stability_map`) and by
    :func:`kapitza.floquet.stability_map` (any system); drawn by
    :func:`kapitza.plots.stability_map_figure`.

    Attributes
    ----------
    A, omega : ndarray
        Grid axes: drive amplitude (m) and angular frequency (rad/s).
    stable : bool ndarray (len(A), len(omega))
    label : int8 ndarray (len(A), len(omega))
        Index into :data:`BOUNDARIES`: 0 stable; 1 unstable in a region bounded by
        period-T solutions (multiplier +1); 2 bounded by period-2T solutions
        (multiplier −1); 3 complex multipliers (combination resonance).
    trace : ndarray or None
        tr M per point (None when computed from characteristic values only).
    log_growth : ndarray or None
        max log|λ| per period (None as above).
    error_estimate : float
        Largest error estimate over the grid: of M (relative) for integration,
        of the boundaries (relative, in a) for characteristic values.
    about : str
        The equilibrium: "inverted" or "hanging" for the pendulum, the coordinates
        for any other system.
    method : str
        "characteristic values", "monodromy (Mathieu, damping removed)" or "monodromy".
    l, g, damping : float or None
        The pendulum's length (m), gravity (m/s²) and damping rate γ (1/s); None for
        a map of another system (its constants are in ``params``).
    params : dict
        The fixed parameters of a general system's map (empty for the pendulum).
    seconds : float
        Wall time of the computation (s).
    refined_points, uncertified_points, flagged_points : int
        Monodromy maps: points integrated again to the fine tolerance, points whose
        stability test lies within 10× its error estimate of the threshold, points
        whose accuracy guards failed or that could not be integrated (for the
        Mathieu trace: an RK4 overflow at extreme drives; 0 for characteristic values).
    flags_example : tuple of str
        The flags of the first flagged point (empty if none).
    max_steps_per_period, samples : int
        Monodromy maps: the most Taylor steps per period over the grid, and the
        samples of J per period (0 for the other methods).
    """

    A: np.ndarray
    omega: np.ndarray
    stable: np.ndarray
    label: np.ndarray
    trace: np.ndarray | None
    log_growth: np.ndarray | None
    error_estimate: float
    about: str
    method: str
    l: float | None = None
    g: float | None = None
    damping: float | None = None
    params: dict = field(default_factory=dict)
    seconds: float = math.nan
    refined_points: int = 0
    uncertified_points: int = 0
    flagged_points: int = 0
    flags_example: tuple = ()
    max_steps_per_period: int = 0
    samples: int = 0

    @property
    def boundary(self) -> np.ndarray:
        """Label names per point: "stable", "T", "2T" or "complex"."""
        return _boundary_names(self.label)

    def to_dataframe(self):
        """Long format: one row per grid point (A, omega, stable, boundary, trace, log_growth)."""
        import pandas as pd
        AA, WW = np.meshgrid(self.A, self.omega, indexing="ij")
        data = {"A": AA.ravel(), "omega": WW.ravel(), "stable": self.stable.ravel(),
                "boundary": self.boundary.ravel()}
        if self.trace is not None:
            data["trace"] = self.trace.ravel()
        if self.log_growth is not None:
            data["log_growth"] = self.log_growth.ravel()
        return pd.DataFrame(data)


_WINDOW_METHODS = ("floquet", "averaging")


@dataclass(frozen=True)
class StabilityWindow:
    """Drive amplitudes A_min < A < A_max that stabilise the vertically driven pendulum, per ω.

    One type for the exact window (``method="floquet"``:
    :func:`kapitza.mathieu.pendulum_stability_window`) and the averaging prediction
    (``method="averaging"``: :func:`kapitza.pendulum_closed_forms.averaging_window`);
    both from :meth:`kapitza.KapitzaPendulum.stability_window`.  The averaging window
    of any system's equilibrium (order 1, ``l`` and ``g`` None, ``about`` its
    coordinates as text) is :meth:`kapitza.averaging.AveragedSystem.stability_window`.

    Attributes
    ----------
    omega : float or ndarray
        Drive angular frequencies (rad/s).
    A_min, A_max : float or ndarray
        Window edges (m).  Exact: NaN where there is no window (e.g. ω too low to
        hold the pendulum upright).  Averaging, order 1: A_min = √(2 g l)/ω and
        A_max = +inf (first order cannot see the upper limit); order 2: the next
        order, relative error O(ε⁴), with A_max from the parametric resonance
        a′ = b₁(2A/l) (→ 0.4540 l as ω → ∞); NaN where the edges cross (see
        ``exists``), and see ``valid`` before trusting an edge.
    method : {"floquet", "averaging"}
    about : str
        "inverted" (θ = π) or "hanging" (θ = 0; exact windows only, A_min = 0); for a
        general system the equilibrium's coordinates, e.g. "[3.14159..., 3.14159...]".
    order : int or None
        Averaging order (1 or 2); None for exact windows.
    accuracy : ndarray or None
        Exact windows: certified relative accuracy of the edges (the Floquet
        condition changes sign across A·(1 ± accuracy)); None for averaging.
    tol : float or None
        Exact windows: the requested relative accuracy; None for averaging.
    l, g, damping : float or None
        Length (m), gravity (m/s²), damping rate γ (1/s) of the pendulum.
    exists : bool or ndarray or None
        Averaging: the prediction has a window, A_min < A_max (False: both edges
        NaN); None for exact windows.
    frequency_ratio : float or ndarray or None
        Averaging: ω / max(ω0, γ) (at the lower edge the slow frequency is 0).
    error_estimate : float or ndarray or None
        Averaging: |A_min(order 1) − A_min(order 2)| / A_min(order 2), the size of
        the next-order correction to the lower edge (it estimates the error of
        order 1; that of order 2 is much smaller).
    fast_drive, small_amplitude, converged, valid : bool or ndarray or None
        Averaging, as for :class:`EquilibriumPrediction`: ``frequency_ratio ≥
        MIN_FREQUENCY_RATIO``, ``A_min/l ≤ MAX_AMPLITUDE_RATIO``, ``error_estimate ≤
        MAX_CORRECTION``, and all three with ``exists``.  None for exact windows.
    """

    omega: object
    A_min: object
    A_max: object
    method: str
    about: str = "inverted"
    order: int | None = None
    accuracy: np.ndarray | None = None
    tol: float | None = None
    l: float | None = None
    g: float | None = None
    damping: float | None = None
    exists: object = None
    frequency_ratio: object = None
    error_estimate: object = None
    fast_drive: object = None
    small_amplitude: object = None
    converged: object = None
    valid: object = None

    def __post_init__(self):
        if self.method not in _WINDOW_METHODS:
            raise ValueError(f"StabilityWindow: method must be one of {_WINDOW_METHODS}, got "
                             f"{self.method!r}.")

    def to_dataframe(self):
        """One row per ω: omega, A_min, A_max, then accuracy (exact) or order (averaging)."""
        import pandas as pd
        w, lo, hi = (np.ravel(x) for x in np.broadcast_arrays(self.omega, self.A_min, self.A_max))
        data = {"omega": w, "A_min": lo, "A_max": hi}
        if self.accuracy is not None:
            data["accuracy"] = np.ravel(self.accuracy)
        if self.order is not None:
            data["order"] = self.order
        return pd.DataFrame(data)


#: The exact window's old name (one type serves exact and averaging windows).
FloquetWindow = StabilityWindow


@dataclass(frozen=True)
class InceStruttChart:
    """The stability chart of the undamped Mathieu equation y″ + (a − 2q cos 2τ) y = 0.

    Built by :func:`kapitza.mathieu.ince_strutt_chart`; drawn by
    :func:`kapitza.plots.ince_strutt_figure`.

    Attributes
    ----------
    q, a : ndarray
        Grid axes.
    stable : bool ndarray (len(q), len(a))
        Stability at every grid point (from characteristic values, exact to rounding).
    curves : dict of str to ndarray (len(q),)
        The characteristic curves "a0", "b1", "a1", ... on the q axis (the
        boundaries: stable between a_r and b_(r+1)).
    """

    q: np.ndarray
    a: np.ndarray
    stable: np.ndarray
    curves: dict

    def to_dataframe(self):
        """One row per q: q and every characteristic curve."""
        import pandas as pd
        return pd.DataFrame({"q": self.q, **self.curves})


# ======================================================================================
# Averaging of any system (kapitza.averaging)
# ======================================================================================

@dataclass(frozen=True)
class SlowModes:
    """Small slow oscillations about one equilibrium of the averaged motion.

    Built by :meth:`kapitza.averaging.AveragedSystem.slow_modes`.  The averaged
    linearisation is M δQ̈ + C δQ̇ + H δQ = 0 with H the Hessian of U_eff, M the
    (time-independent) mass matrix, C the averaged damping matrix.

    Attributes
    ----------
    about : ndarray (n,)
        The equilibrium (coordinates in SI units; angles wrapped into (−π, π]).
    omega_squared : ndarray (n,)
        Generalized eigenvalues Ω² of (H, M), ascending (rad²/s²); negative is unstable.
    frequencies : ndarray (n,)
        √Ω² (rad/s); NaN for an unstable mode.
    stable : bool
        All Ω² > 0 (linear stability of the averaged motion; with damping the
        equilibrium is then asymptotically stable).
    eigenvalues : ndarray (2n,), complex
        Roots λ of det(λ² M + λ C + H) = 0 (1/s), sorted by imaginary part
        (the damped slow dynamics; ±iΩ without damping).
    damped_frequencies : ndarray (n,)
        The non-negative imaginary parts of ``eigenvalues`` (rad/s), one per mode.
    decay_rate : float
        −max Re λ (1/s): the slowest decay rate (negative: growth).
    frequency_ratio : float
        ω / max(√|Ω²|): how much faster the drive is than the slow motion.
    amplitude_ratio : float
        Largest singular value of ∂ξ/∂q, the fast displacement amplitude per
        unit slow displacement (A/l for the pendulum).
    valid : bool
        ``frequency_ratio ≥ MIN_FREQUENCY_RATIO`` and ``amplitude_ratio ≤
        MAX_AMPLITUDE_RATIO`` (:mod:`kapitza.averaging`).
    reasons : tuple of str
        Why a prediction is not valid (empty if it is).
    """

    about: np.ndarray
    omega_squared: np.ndarray
    frequencies: np.ndarray
    stable: bool
    eigenvalues: np.ndarray
    damped_frequencies: np.ndarray
    decay_rate: float
    frequency_ratio: float
    amplitude_ratio: float
    valid: bool
    reasons: tuple = ()

    def to_dataframe(self):
        """One row per mode."""
        import pandas as pd
        n = len(self.omega_squared)
        return pd.DataFrame({
            "about": [tuple(self.about.tolist())] * n, "mode": np.arange(n),
            "omega_squared": self.omega_squared, "frequency": self.frequencies,
            "damped_frequency": self.damped_frequencies, "stable": [self.stable] * n,
            "decay_rate": [self.decay_rate] * n, "frequency_ratio": [self.frequency_ratio] * n,
            "amplitude_ratio": [self.amplitude_ratio] * n, "valid": [self.valid] * n,
            "reasons": ["; ".join(self.reasons)] * n})


@dataclass(frozen=True)
class AveragingPrediction:
    """Equilibria of the averaged motion with their slow modes.

    Built by :meth:`kapitza.averaging.AveragedSystem.predict`.

    Attributes
    ----------
    params : dict
        The parameter values used.
    equilibria : tuple of SlowModes
        One entry per distinct equilibrium found.
    """

    params: dict
    equilibria: tuple

    @property
    def stable(self) -> tuple:
        """The stable equilibria (SlowModes)."""
        return tuple(e for e in self.equilibria if e.stable)

    def to_dataframe(self):
        """One row per equilibrium and mode (column ``equilibrium`` numbers them)."""
        import pandas as pd
        frames = [e.to_dataframe().assign(equilibrium=i) for i, e in enumerate(self.equilibria)]
        return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


@dataclass(frozen=True)
class SlowModeSweep:
    """Slow modes about one equilibrium over a grid of parameter values.

    Built by :meth:`kapitza.averaging.AveragedSystem.sweep`.

    Attributes
    ----------
    params : dict of ndarray
        The broadcast parameter arrays.
    about : ndarray (n,)
    omega_squared : ndarray (..., n)
        Ω² of the averaged linearisation, ascending per point (rad²/s²).
    stable, valid : bool ndarray (...)
        See :class:`SlowModes`.
    """

    params: dict
    about: np.ndarray
    omega_squared: np.ndarray
    stable: np.ndarray
    valid: np.ndarray

    def to_dataframe(self):
        """One row per grid point: the parameters, omega_squared_<k> per mode, stable, valid."""
        import pandas as pd
        cols = {k: np.ravel(v) for k, v in self.params.items()}
        for j in range(self.omega_squared.shape[-1]):
            cols[f"omega_squared_{j}"] = self.omega_squared[..., j].ravel()
        cols["stable"] = self.stable.ravel()
        cols["valid"] = self.valid.ravel()
        return pd.DataFrame(cols)


# ======================================================================================
# The driven pendulum and Acheson's chain in closed form (kapitza.pendulum_closed_forms)
# ======================================================================================

_EQUILIBRIUM_COLUMNS = ("theta", "exists", "stable", "omega_squared", "omega_slow",
                        "damped_frequency", "decay_rate", "overdamped", "error_estimate",
                        "frequency_ratio", "fast_drive", "small_amplitude", "converged", "valid")


@dataclass(frozen=True)
class EquilibriumPrediction:
    """The averaged prediction for one equilibrium of the driven pendulum.

    Array fields have the broadcast shape of (A, ω) (Python scalars for scalar input).

    Attributes
    ----------
    name : str
        "hanging", "inverted", "tilted+" or "tilted-".  The tilted pair is, for the
        vertical drive, the unstable maxima of U_eff at cos θ = −2 g l/(A² ω²)
        (present when the upright is stable; first order at any ``order``); for
        the horizontal drive, the stable tilted minima at cos θ* = 2 g l/(A² ω²).
    theta : array
        Angle from the downward vertical (rad); NaN where it does not exist.
    exists : bool array
    stable : bool array
        Linear stability of the averaged motion (order 2 also checks the
        parametric-resonance limit a′ < b₁(q)).
    omega_squared : array
        Ω² of the undamped averaged motion (rad²/s²); negative: unstable.
    omega_slow : array
        Ω = √Ω² (rad/s), NaN where Ω² < 0.
    damped_frequency : array
        √(Ω² − γ²/4) at order 1, (ω/2) ν(a − γ²/ω², q) at order 2 (rad/s);
        0 when overdamped, NaN when unstable.
    decay_rate : array
        The slowest decay rate of small oscillations (1/s): γ/2 when
        underdamped, γ/2 − √(γ²/4 − Ω²) when overdamped; negative: growth rate.
    overdamped : bool array
    error_estimate : array
        Vertical drive, hanging and upright: |√|Ω₂²| − √|Ω₁²|| / √|Ω₁²|, the relative
        size of the next-order correction to the slow frequency (or growth rate);
        +inf when the correction flips the stability.  It estimates the error of
        order 1 (within a factor ≈ 2, tests/test_averaging.py); the error of
        order 2 is much smaller (see ``MAX_CORRECTION`` in
        :mod:`kapitza.pendulum_closed_forms`).  NaN for the tilted equilibria and
        the horizontal drive (no next order implemented).
    frequency_ratio : array
        ω / max(ω0, √|Ω²|, γ).
    fast_drive, small_amplitude, converged, valid : bool arrays
        ``frequency_ratio ≥ MIN_FREQUENCY_RATIO``, ``A/l ≤ MAX_AMPLITUDE_RATIO``,
        ``error_estimate ≤ MAX_CORRECTION`` (True where no estimate exists), and
        all three (False where the equilibrium does not exist).
    """

    name: str
    theta: object
    exists: object
    stable: object
    omega_squared: object
    omega_slow: object
    damped_frequency: object
    decay_rate: object
    overdamped: object
    error_estimate: object
    frequency_ratio: object
    fast_drive: object
    small_amplitude: object
    converged: object
    valid: object


@dataclass(frozen=True)
class PendulumAveraging:
    """Averaged (Kapitza) predictions for the driven pendulum over arrays of A and ω.

    Built by :func:`kapitza.pendulum_closed_forms.pendulum_averaged` (and
    :meth:`kapitza.KapitzaPendulum.averaged`).

    Attributes
    ----------
    A, omega : array
        Drive amplitude (m) and angular frequency (rad/s), broadcast.
    l, g, damping : float
        Length (m), gravity (m/s²), damping rate γ (1/s).
    drive : str
        "vertical" or "horizontal".
    order : int
        1 (Kapitza/Landau averaging) or 2 (next order, vertical drive).
    equilibria : tuple of EquilibriumPrediction
    """

    A: object
    omega: object
    l: float
    g: float
    damping: float
    drive: str
    order: int
    equilibria: tuple

    def __getitem__(self, name) -> EquilibriumPrediction:
        for e in self.equilibria:
            if e.name == name:
                return e
        raise KeyError(f"no equilibrium {name!r}; have {[e.name for e in self.equilibria]}.")

    @property
    def hanging(self) -> EquilibriumPrediction:
        """The hanging state θ = 0."""
        return self["hanging"]

    @property
    def inverted(self) -> EquilibriumPrediction:
        """The upright state θ = π."""
        return self["inverted"]

    @property
    def tilted(self) -> EquilibriumPrediction:
        """The tilted equilibrium θ* > 0 (−θ* is its mirror; see EquilibriumPrediction.name)."""
        return self["tilted+"]

    @property
    def valid(self):
        """The predictions for every existing equilibrium are valid (per point)."""
        return scalar_or_array(np.logical_and.reduce(
            [np.asarray(e.valid) | ~np.asarray(e.exists) for e in self.equilibria]))

    def to_dataframe(self):
        """One row per (A, ω) point and equilibrium."""
        import pandas as pd
        A, w = (np.ravel(x) for x in np.broadcast_arrays(self.A, self.omega))
        rows = []
        for e in self.equilibria:
            cols = {f: np.ravel(np.broadcast_to(np.asarray(getattr(e, f)), np.shape(self.A)))
                    for f in _EQUILIBRIUM_COLUMNS}
            rows.append(pd.DataFrame({"A": A, "omega": w, "equilibrium": e.name, **cols}))
        return pd.concat(rows, ignore_index=True).assign(order=self.order, drive=self.drive)


@dataclass(frozen=True)
class MultiplePendulumPrediction:
    """Upright N-link pendulum on a pivot shaken vertically as A cos ωt (Acheson).

    Built by :func:`kapitza.pendulum_closed_forms.multiple_pendulum_upright`, which
    states the theory and its accuracy.

    Attributes
    ----------
    masses, lengths : ndarray (N,)
        Bob masses (kg) and rod lengths (m), from the pivot outwards.
    g : float
        Gravity (m/s²).
    hanging_frequencies : ndarray (N,)
        ω_k of the undriven hanging chain (rad/s), ascending.
    effective_lengths : ndarray (N,)
        λ_k = g/ω_k² (m), descending.
    minimum_drive : float
        (A ω)_min = √2 g / ω_1 (m/s), first order.
    A, omega : array or None
        The drive, if given; then the fields below have its broadcast shape (+ (N,)).
    omega_squared : ndarray (..., N) or None
        Slow Ω_k² about the upright, in the order of ``hanging_frequencies``.
    stable, valid : bool array or None
        Every mode stable; every mode's prediction inside the averaging regime.
    mode_predictions : tuple of PendulumAveraging or None
        The single-pendulum prediction of each mode (``inverted`` holds the
        upright result); carries the validity flags.
    order : int
        1 or 2, as in :func:`kapitza.pendulum_closed_forms.pendulum_averaged`.
    """

    masses: np.ndarray
    lengths: np.ndarray
    g: float
    hanging_frequencies: np.ndarray
    effective_lengths: np.ndarray
    minimum_drive: float
    A: object = None
    omega: object = None
    omega_squared: object = None
    stable: object = None
    valid: object = None
    mode_predictions: tuple = None
    order: int = 1

    def to_dataframe(self):
        """One row per mode (and drive point, if given)."""
        import pandas as pd
        if self.mode_predictions is None:
            return pd.DataFrame({"mode": np.arange(len(self.masses)),
                                 "hanging_frequency": self.hanging_frequencies,
                                 "effective_length": self.effective_lengths})
        frames = []
        for k, pred in enumerate(self.mode_predictions):
            df = pred.to_dataframe()
            df = df[df.equilibrium == "inverted"].drop(columns="equilibrium")
            frames.append(df.assign(mode=k, hanging_frequency=self.hanging_frequencies[k],
                                    effective_length=self.effective_lengths[k]))
        return pd.concat(frames, ignore_index=True)


# ======================================================================================
# Measurements from direct simulation (kapitza.measurement)
# ======================================================================================

#: Measurement fields with one entry per slow mode (ascending frequency) or per coordinate.
_MODE_FIELDS = ("omega_slow", "omega_slow_error", "refined", "growth_rate")
_COORDINATE_FIELDS = ("about", "amplitude", "mean_angle", "max_deviation")
_POINT_FIELDS = ("period", "stayed_up", "fall_time", "fit_residual", "samples",
                 "energy_drift", "status")


@dataclass(frozen=True)
class Measurement:
    """What direct integration of the full nonlinear motion measured, point by point.

    Built by :func:`kapitza.measurement.measure_grid` (a broadcast grid: every field an array
    of the grid's shape S, followed by the axis stated), :func:`kapitza.measurement.measure`
    (one point: 0-d fields are Python scalars, and a one-coordinate system's per-mode and
    per-coordinate fields are floats) and :meth:`kapitza.KapitzaPendulum.measure` /
    ``measure_grid`` (one coordinate θ: those fields have the grid's shape).  How each
    number is measured, and what its error estimate covers, is in :mod:`kapitza.measurement`.

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
        integration error, not the amplitude dependence (see :mod:`kapitza.measurement`).
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
    about: object
    period: object
    periods: int
    stayed_up: object
    fall_time: object
    omega_slow: object
    omega_slow_error: object
    refined: object
    growth_rate: object
    fit_residual: object
    amplitude: object
    mean_angle: object
    max_deviation: object
    energy_drift: object
    samples: object
    status: object
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

    Built by :func:`kapitza.periodic_orbit.periodic_orbit` (Newton shooting on the period
    map; its docstring states the method and the accuracy).

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
        Every |λ| ≤ 1 up to the error (see the module docstring).
    omega_slow : float or ndarray (n,)
        Slow frequency |arg λ|/T of each stable pair (rad/s, in [0, ω/2]); NaN if
        unstable; a float for one coordinate.
    residual : float
        |φ_T(y0) − y0| at the returned state.
    error_estimate : float
        Error estimate of the monodromy (the flow's step-doubling difference).
    iterations : int
        Newton iterations (0: a persisting equilibrium).
    method : str
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


# ======================================================================================
# Verification: the predictions against each other and against simulation (kapitza.verify)
# ======================================================================================

#: The methods a :class:`Verification` compares: first-order averaging, next-order
#: averaging, Floquet analysis (exact, linear) and direct simulation (full, nonlinear).
VERIFICATION_METHODS = ("averaging", "averaging_2", "floquet", "simulation")
_METHOD_NAMES = {"averaging": "averaging (order 1)", "averaging_2": "averaging (next order)",
                 "floquet": "Floquet", "simulation": "simulation"}
#: Simulation statuses that classify a point (the others are failed integrations).
_CLASSIFIED = ("finished", "left_band")


@dataclass(frozen=True)
class OrderFit:
    """The order of an averaging approximation, measured: its relative error in Ω
    against Floquet's exact Ω along a line of drives, fitted as c ε^p.

    Built by :mod:`kapitza.verify`; the line and the small parameter ε are stated in
    ``small_parameter`` (the default line keeps the drive's velocity A ω fixed, so that
    the first-order prediction is fixed and ω0/ω and A/l shrink together; see
    :mod:`kapitza.verify`).

    Attributes
    ----------
    order : int
        1 (first-order averaging) or 2 (next order).
    small_parameter : str
        What ε is and along which line, e.g. "ε = ω0/ω along A ω = 2 √(g l)".
    epsilon, omega, A : ndarray (k,)
        ε, the drive frequency (rad/s) and amplitude (m) of each point of the line.
    error : ndarray (k,)
        |Ω_averaging − Ω_Floquet| / Ω_Floquet (largest over the slow modes).
    floor : ndarray (k,)
        Floquet's own relative error bound on Ω (the fit leaves out points whose
        error is not above ``RESOLVED`` × floor, :mod:`kapitza.verify`).
    used : bool ndarray (k,)
        The points fitted.
    exponent, exponent_error : float
        p of the least-squares line log error = log c + p log ε, and its standard
        error (from the residuals); NaN with fewer than 3 points used.
    prefactor : float
        c.
    theory : float
        The exponent theory predicts (2 for order 1, 4 for order 2; NaN if unknown).
    """

    order: int
    small_parameter: str
    epsilon: np.ndarray
    omega: np.ndarray
    A: np.ndarray
    error: np.ndarray
    floor: np.ndarray
    used: np.ndarray
    exponent: float
    exponent_error: float
    prefactor: float
    theory: float

    def to_dataframe(self):
        """One row per point of the line: epsilon, omega, A, error, floor, used (and order)."""
        import pandas as pd
        return pd.DataFrame({"epsilon": self.epsilon, "omega": self.omega, "A": self.A,
                             "error": self.error, "floor": self.floor, "used": self.used,
                             "order": self.order})


@dataclass(frozen=True)
class Verification:
    """Averaging, Floquet analysis and direct simulation of one driven equilibrium,
    compared point by point over a broadcast (A, ω) grid.

    Built by :func:`kapitza.verify.verify` (any driven system) and
    :meth:`kapitza.KapitzaPendulum.verify`; how each number is obtained, and the
    tolerances, are in :mod:`kapitza.verify`.  Method names:
    :data:`VERIFICATION_METHODS` ("averaging" is first order, "averaging_2" the next
    order, absent (None fields) where there is none).

    Per-point fields have the grid's shape S; the slow frequencies and their
    tolerances have shape S for a system of one coordinate and S + (n,) otherwise
    (modes in ascending order of Ω).

    Attributes
    ----------
    A, omega : ndarray (S)
        Drive amplitude (units of the amplitude parameter; m for a pivot) and angular
        frequency (rad/s) of every point.
    about : str
        The equilibrium verified ("inverted", or the coordinates as text).
    length, omega0 : float or None
        The length and frequency that make A/l and ω/ω0 (the pendulum's l and √(g/l));
        None where not given.
    stable_averaging, stable_averaging_2, stable_floquet, stable_simulation : bool ndarray (S)
        The classification by each method: linear stability of the averaged motion
        (first and next order), of the exact linearisation (Floquet), and "stayed
        near the equilibrium" in the full simulation (the band of
        :func:`kapitza.measure_grid`; for the pendulum |θ − π| < π/2 throughout).
    omega_slow_averaging, omega_slow_averaging_2, omega_slow_floquet, omega_slow_simulation
        Ω (rad/s) by each method, NaN where that method finds no stable oscillation
        (the simulation's Ω is measured up to a fall; it is compared only where the
        run stayed up).  With damping, the damped slow frequency.
    tolerance_averaging, tolerance_averaging_2, tolerance_floquet, tolerance_simulation
        Each method's stated error of its Ω (rad/s; inf: no claim).  Two methods
        agree on Ω when |Ω_a − Ω_b| ≤ tolerance_a + tolerance_b for every mode.
    averaging_valid : bool ndarray (S)
        First-order averaging's own validity flag (``valid`` of its prediction).
    floquet_margin : ndarray (S)
        Distance of the Floquet stability test from its threshold in units of its
        error bound (> 1: certified).
    simulation_status : str ndarray (S)
        How each run ended ("finished", "left_band", or a failure, which leaves the
        point unclassified by simulation).
    fall_time : ndarray (S)
        Time to leaving the band (s), NaN where the run stayed.
    amplitude : ndarray (S)
        The simulated slow amplitude (largest over the coordinates).
    boundary_distance : ndarray (S)
        |A − A_b| / A to the nearest Floquet stability boundary A_b at the point's ω
        (along A); inf where none was found (see :mod:`kapitza.verify` for where each
        builder looks), NaN where not located.
    nearest_boundary : ndarray (S)
        That A_b (NaN where none).
    boundary_A, boundary_omega : ndarray (m,)
        Every boundary located at the grid's frequencies (for the figure).
    window : StabilityWindow or None
        The exact window on a fine ω grid over the grid's range (the pendulum), drawn
        as the boundary lines; None for a general system.
    fits : tuple of OrderFit
        The order of averaging, measured (order 1, and 2 where there is a next order);
        empty if not computed.
    periods : int
        Drive periods simulated per point.
    tol, rtol : float
        Floquet's tolerance and the simulation's relative tolerance.
    notes : tuple of str
        What was not available or not located, said once.
    figure_function : callable or None
        What :meth:`figure` draws with (:func:`kapitza.plots.verification_figure`, set
        by the builder: this module imports no figure code).
    """

    A: np.ndarray
    omega: np.ndarray
    about: str
    length: float | None
    omega0: float | None
    stable_averaging: np.ndarray
    stable_averaging_2: np.ndarray | None
    stable_floquet: np.ndarray
    stable_simulation: np.ndarray
    omega_slow_averaging: np.ndarray
    omega_slow_averaging_2: np.ndarray | None
    omega_slow_floquet: np.ndarray
    omega_slow_simulation: np.ndarray
    tolerance_averaging: np.ndarray
    tolerance_averaging_2: np.ndarray | None
    tolerance_floquet: np.ndarray
    tolerance_simulation: np.ndarray
    averaging_valid: np.ndarray
    floquet_margin: np.ndarray
    simulation_status: np.ndarray
    fall_time: np.ndarray
    amplitude: np.ndarray
    boundary_distance: np.ndarray
    nearest_boundary: np.ndarray
    boundary_A: np.ndarray
    boundary_omega: np.ndarray
    window: StabilityWindow | None
    fits: tuple
    periods: int
    tol: float
    rtol: float
    notes: tuple = ()
    figure_function: object = field(default=None, repr=False, compare=False)

    @property
    def shape(self) -> tuple:
        """The grid's shape S."""
        return np.shape(self.stable_floquet)

    @property
    def methods(self) -> tuple:
        """The methods present (next-order averaging only where there is one)."""
        return tuple(m for m in VERIFICATION_METHODS if getattr(self, f"stable_{m}") is not None)

    @property
    def exponent(self) -> float:
        """The fitted order of first-order averaging's relative error in Ω (NaN if not fitted)."""
        return self._fit(1, "exponent")

    @property
    def exponent_error(self) -> float:
        """Standard error of :attr:`exponent`."""
        return self._fit(1, "exponent_error")

    @property
    def exponent_theory(self) -> float:
        """The exponent theory gives for first-order averaging (2)."""
        return self._fit(1, "theory")

    def _fit(self, order, name):
        for f in self.fits:
            if f.order == order:
                return getattr(f, name)
        return math.nan

    def _modes(self, name):
        """A slow-frequency field with a mode axis: S + (n,)."""
        x = np.asarray(getattr(self, name), dtype=float)
        return x[..., None] if x.ndim == len(self.shape) else x

    def compare(self, first: str, second: str, quantity: str = "stability"):
        """Which points two methods were compared on, and which of them agree.

        Parameters
        ----------
        first, second : str
            Method names (:data:`VERIFICATION_METHODS`).
        quantity : {"stability", "omega_slow"}
            The classification (compared wherever both methods classified the point;
            simulation failures are not), or Ω (compared where both call the point
            stable and give a finite Ω for some mode; agree when |Ω_a − Ω_b| ≤
            tolerance_a + tolerance_b for every such mode).

        Returns
        -------
        compared, agree : bool ndarray (S)
        """
        for m in (first, second):
            if m not in self.methods:
                raise ValueError(f"no method {m!r} in this verification; it has "
                                 f"{list(self.methods)}.")
        if quantity not in ("stability", "omega_slow"):
            raise ValueError(f"quantity must be 'stability' or 'omega_slow', got {quantity!r}.")
        sa, sb = (np.asarray(getattr(self, f"stable_{m}"), bool) for m in (first, second))
        compared = np.ones(self.shape, bool)
        if "simulation" in (first, second):
            compared &= np.isin(self.simulation_status, _CLASSIFIED)
        if quantity == "stability":
            return compared, ~compared | (sa == sb)
        wa, wb = (self._modes(f"omega_slow_{m}") for m in (first, second))
        ta, tb = (self._modes(f"tolerance_{m}") for m in (first, second))
        both = np.isfinite(wa) & np.isfinite(wb)
        with np.errstate(invalid="ignore"):
            close = ~both | (np.abs(wa - wb) <= ta + tb)
        compared &= sa & sb & both.any(axis=-1)
        return compared, ~compared | close.all(axis=-1)

    def _pairs(self):
        ms = self.methods
        return [(a, b) for i, a in enumerate(ms) for b in ms[i + 1:]]

    @property
    def agreement(self):
        """Agreement statistics: one row per pair of methods and quantity ("stability",
        "omega_slow") with the points compared, agreeing, disagreeing and the fraction
        agreeing (NaN where none was compared)."""
        import pandas as pd
        rows = []
        for a, b in self._pairs():
            for quantity in ("stability", "omega_slow"):
                compared, agree = self.compare(a, b, quantity)
                n, k = int(compared.sum()), int((compared & agree).sum())
                rows.append({"first": a, "second": b, "quantity": quantity, "compared": n,
                             "agreeing": k, "disagreeing": n - k,
                             "fraction": k / n if n else math.nan})
        return pd.DataFrame(rows)

    def _location(self) -> dict:
        """Per-point columns that locate a point (flat, C order)."""
        cols = {"A": np.ravel(self.A), "omega": np.ravel(self.omega)}
        if self.length is not None:
            cols["A_over_l"] = np.ravel(self.A) / self.length
        if self.omega0 is not None:
            cols["omega_over_omega0"] = np.ravel(self.omega) / self.omega0
        cols.update(boundary_distance=np.ravel(self.boundary_distance),
                    nearest_boundary=np.ravel(self.nearest_boundary))
        return cols

    @property
    def disagreements(self):
        """Every disagreement, located: one row per point, pair of methods and quantity
        that disagree, with the point's A, ω (A/l, ω/ω0), distance to the nearest Floquet
        boundary, both methods' classifications and Ω (the mode that differs most,
        relative to the tolerance), the tolerance, first-order averaging's validity and
        the simulation's status."""
        import pandas as pd
        where = self._location()
        frames = []
        for a, b in self._pairs():
            for quantity in ("stability", "omega_slow"):
                compared, agree = self.compare(a, b, quantity)
                bad = np.flatnonzero(np.ravel(compared & ~agree))
                if not bad.size:
                    continue
                wa, wb = (self._modes(f"omega_slow_{m}").reshape(-1, self._modes(
                    f"omega_slow_{m}").shape[-1])[bad] for m in (a, b))
                tt = (self._modes(f"tolerance_{a}") + self._modes(f"tolerance_{b}"))
                tt = tt.reshape(-1, tt.shape[-1])[bad]
                with np.errstate(invalid="ignore", divide="ignore"):
                    score = np.where(np.isfinite(wa) & np.isfinite(wb),
                                     np.abs(wa - wb) / tt, -np.inf)
                j = np.argmax(score, axis=1)[:, None]
                take = (lambda x: np.take_along_axis(x, j, axis=1)[:, 0])   # noqa: E731
                frame = {"point": bad, **{k: v[bad] for k, v in where.items()},
                         "quantity": quantity, "first": a, "second": b,
                         "first_stable": np.ravel(getattr(self, f"stable_{a}"))[bad],
                         "second_stable": np.ravel(getattr(self, f"stable_{b}"))[bad],
                         "first_omega_slow": take(wa), "second_omega_slow": take(wb),
                         "tolerance": take(tt) if quantity == "omega_slow" else math.nan,
                         "averaging_valid": np.ravel(self.averaging_valid)[bad],
                         "simulation_status": np.ravel(self.simulation_status)[bad]}
                frames.append(pd.DataFrame(frame))
        if not frames:
            return pd.DataFrame(columns=["point", *where, "quantity", "first", "second",
                                         "first_stable", "second_stable", "first_omega_slow",
                                         "second_omega_slow", "tolerance", "averaging_valid",
                                         "simulation_status"])
        return pd.concat(frames, ignore_index=True)

    def to_dataframe(self):
        """One row per point: A, omega (A_over_l, omega_over_omega0), boundary_distance,
        nearest_boundary, then per method stable_<method>, omega_slow_<method> and
        tolerance_<method> (``_0``, ``_1``, ... per mode for several coordinates), then
        averaging_valid, floquet_margin, simulation_status, fall_time, amplitude and
        disagreements (the pairs of methods that disagree at the point, "; "-joined)."""
        import pandas as pd
        data = self._location()
        for m in self.methods:
            data[f"stable_{m}"] = np.ravel(getattr(self, f"stable_{m}"))
            for name in (f"omega_slow_{m}", f"tolerance_{m}"):
                x = np.asarray(getattr(self, name), dtype=float)
                if x.ndim == len(self.shape):
                    data[name] = np.ravel(x)
                else:
                    for k in range(x.shape[-1]):
                        data[f"{name}_{k}"] = x[..., k].ravel()
        data.update(averaging_valid=np.ravel(self.averaging_valid),
                    floquet_margin=np.ravel(self.floquet_margin),
                    simulation_status=np.ravel(self.simulation_status),
                    fall_time=np.ravel(self.fall_time), amplitude=np.ravel(self.amplitude))
        labels = [[] for _ in range(int(np.prod(self.shape, dtype=np.int64)))]
        for a, b in self._pairs():
            for quantity in ("stability", "omega_slow"):
                compared, agree = self.compare(a, b, quantity)
                for i in np.flatnonzero(np.ravel(compared & ~agree)):
                    labels[i].append(f"{a}≠{b} ({quantity})")
        data["disagreements"] = ["; ".join(x) for x in labels]
        return pd.DataFrame(data)

    def figure(self, **options):
        """The verification map with every disagreement marked, and the measured order
        of averaging: :func:`kapitza.plots.verification_figure` (``options`` go to it).
        Returns a :class:`matplotlib.figure.Figure`."""
        if self.figure_function is None:
            raise TypeError("this Verification carries no figure function; draw it with "
                            "kapitza.plots.verification_figure(verification).")
        return self.figure_function(self, **options)


# ======================================================================================
# Exact stability boundaries (kapitza.floquet.boundaries, kapitza.floquet.adaptive_map)
# ======================================================================================

@dataclass(frozen=True)
class BoundaryCurves:
    """The stability boundaries A_k(ω) of a driven equilibrium over a frequency grid.

    Built by :func:`kapitza.floquet.boundaries` (continuation in ω of the roots of smooth
    margins, see :mod:`kapitza.floquet_boundaries`); drawn over a map by
    :func:`kapitza.plots.stability_map_figure` (``overlays=[curves]``).

    Attributes
    ----------
    omega : ndarray (m,)
        Drive angular frequencies (rad/s).
    A : ndarray (k, m)
        Curve k's amplitude at each ω; NaN where it does not bound the stable region
        there (it does not exist, or both of its sides are unstable).
    accuracy : ndarray (k, m)
        Certified relative accuracy of each point (the curve's margin changes sign
        across A·(1 ± accuracy)).
    kind : tuple of str
        Per curve: "T" (a multiplier reaches +1), "2T" (−1) or "complex" (a complex
        pair leaves the unit circle), as in :data:`BOUNDARIES`.
    stable_below : bool ndarray (k,)
        Whether the stable side of curve k is below it (smaller A).
    about : str
        The equilibrium's coordinates.
    params : dict
        The fixed parameters.
    A_range : tuple of float
        The amplitudes searched (m).
    tol : float
        The requested relative accuracy.
    seconds : float
        Wall time (s).
    monodromies : int
        Monodromies computed (seeding scans, continuation and the side checks).
    """

    omega: np.ndarray
    A: np.ndarray
    accuracy: np.ndarray
    kind: tuple
    stable_below: np.ndarray
    about: str
    params: dict = field(default_factory=dict)
    A_range: tuple = (math.nan, math.nan)
    tol: float = math.nan
    seconds: float = math.nan
    monodromies: int = 0

    def __post_init__(self):
        bad = [k for k in self.kind if k not in BOUNDARIES[1:]]
        if bad:
            raise ValueError(f"BoundaryCurves: kinds must be among {BOUNDARIES[1:]}, got {bad}.")

    def to_dataframe(self):
        """Long format: one row per curve point (curve, kind, stable_side, omega, A,
        accuracy); points where a curve is not a boundary are left out."""
        import pandas as pd
        k, i = np.nonzero(np.isfinite(self.A))
        return pd.DataFrame({
            "curve": k, "kind": np.asarray(self.kind, dtype=object)[k] if k.size else [],
            "stable_side": np.where(np.asarray(self.stable_below)[k], "below", "above"),
            "omega": np.asarray(self.omega)[i], "A": self.A[k, i],
            "accuracy": self.accuracy[k, i]})


@dataclass(frozen=True)
class AdaptiveMap(StabilityMap):
    """A stability map computed only where the classification changes.

    Built by :func:`kapitza.floquet.adaptive_map`; a :class:`StabilityMap` on the full
    grid (labels of cells that were not refined are their corners' label), plus:

    Attributes
    ----------
    margin : ndarray (len(A), len(omega))
        A continuous stability margin (> 0 stable, < 0 unstable; see
        :func:`kapitza.floquet_boundaries.signed_margin`), computed at the refined points
        and interpolated bilinearly inside the cells that were not: its zero contour is
        the boundary, smooth at the grid's full resolution.
    computed : bool ndarray (len(A), len(omega))
        The points whose monodromy was computed.
    monodromies : int
        Their number (a uniform map computes len(A) × len(omega)).
    levels : int
        Refinement levels after the coarse grid.
    coarse_step : int
        The coarse grid's step in grid points.
    """

    margin: np.ndarray | None = None
    computed: np.ndarray | None = None
    monodromies: int = 0
    levels: int = 0
    coarse_step: int = 0

    def to_dataframe(self):
        """As :meth:`StabilityMap.to_dataframe`, with the margin and the computed flag."""
        df = super().to_dataframe()
        df["margin"] = np.ravel(self.margin)
        df["computed"] = np.ravel(self.computed)
        return df

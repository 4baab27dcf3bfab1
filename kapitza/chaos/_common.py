"""The chaos room's argument checks: parameters, the drive's period, states, counts.

Every function of :mod:`kapitza.chaos` reads its inputs through these, so a bad one is
refused the same way everywhere: a ``ValueError`` (or ``TypeError``) naming the argument,
the value and the fix.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from lagrange_core.checks import real_array, real_number

__all__ = ["parameters", "drive_frequency", "state", "tolerances", "angle_names",
           "unconstrained", "generic_basis"]


def parameters(system, params, where, *, scalar):
    """``params`` as a dict name -> float array, every parameter of ``system`` present;
    with ``scalar`` each must be one number."""
    if not isinstance(params, Mapping):
        raise TypeError(f"{where}: params must be a dict parameter name -> value of "
                        f"{list(system.parameters)}, got {type(params).__name__}.")
    out = {str(k): v for k, v in params.items()}
    unknown = sorted(set(out) - set(system.parameters))
    missing = [p for p in system.parameters if p not in out]
    if unknown or missing:
        raise ValueError(f"{where}: params must give every parameter of the system "
                         f"{list(system.parameters)} and no other; unknown {unknown}, "
                         f"missing {missing}.")
    out = {k: real_array(v, f"parameter {k!r}") for k, v in out.items()}
    if scalar:
        for k, v in out.items():
            if v.ndim:
                raise ValueError(f"{where} takes one parameter set; {k!r} is an array of shape "
                                 f"{v.shape}. Use lyapunov_grid (or a loop) for grids.")
    return out


def drive_frequency(system, params, frequency, where):
    """ω (rad/s, an array): the parameter named ``frequency``, or ``frequency`` itself."""
    if isinstance(frequency, str):
        if frequency not in system.parameters:
            raise ValueError(f"{where}: the drive's frequency parameter {frequency!r} is not a "
                             f"parameter of the system ({list(system.parameters)}); pass "
                             "frequency=<its name>, or the drive's angular frequency (rad/s) "
                             "as a number.")
        omega = np.asarray(params[frequency], dtype=float)
    else:
        omega = real_array(frequency, "frequency", unit="rad/s")
    if not np.all(omega > 0):
        raise ValueError(f"{where}: the drive's angular frequency {frequency!r} must be > 0 "
                         f"(rad/s), got {omega if omega.ndim == 0 else omega.min()}; the "
                         "strobe and the record are counted in its periods T = 2π/ω.")
    return omega


def state(system, values, what, *, single=False, starts=False):
    """A per-coordinate input as a float array (..., n): a scalar (every coordinate), a
    dict coordinate -> value(s) (a coordinate left out is 0), an array whose last axis
    has n entries — or, for a system of one coordinate, any array: the coordinate's value
    at each point of a grid (``theta[:, None]`` and ``rate[None, :]`` make one).
    ``single``: exactly one state, shape (n,).  ``starts``: a list of states, (S, n), or
    for one coordinate also (S,)."""
    n, names = system.n_dof, list(system.coordinates)
    if isinstance(values, Mapping):
        unknown = sorted(set(map(str, values)) - set(names))
        if unknown:
            raise ValueError(f"{what}: unknown coordinate(s) {unknown}; the coordinates are "
                             f"{names}.")
        cols = [real_array(values.get(c, 0.0), f"{what}[{c!r}]") for c in names]
        arr = np.stack(np.broadcast_arrays(*cols), axis=-1)
    else:
        arr = real_array(values, what)
        if arr.ndim == 0:
            arr = np.full(n, float(arr))
        elif n == 1 and not single and not (starts and arr.ndim == 2 and arr.shape[1] == 1):
            arr = arr[..., None]
        elif arr.shape[-1] != n:
            raise ValueError(f"{what} must have a last axis of {n} entries (one per coordinate "
                             f"{names}), got shape {arr.shape}; or pass a dict coordinate -> "
                             "value(s).")
    if single and arr.shape != (n,):
        raise ValueError(f"{what} must be one state of the {n} coordinate(s) {names}, got "
                         f"shape {arr.shape}.")
    return arr


def tolerances(rtol, atol):
    rtol = real_number(rtol, "rtol")
    if not 1e-14 <= rtol < 1:
        raise ValueError(f"rtol must lie in [1e-14, 1), got {rtol!r}.")
    atol = rtol if atol is None else real_number(atol, "atol")
    if not atol > 0:
        raise ValueError(f"atol must be > 0, got {atol!r}.")
    return rtol, atol


def angle_names(system, angles):
    """``angles`` as a tuple of coordinate names (one name, several, or True: all)."""
    if angles is True:
        return tuple(system.coordinates)
    if angles is None or angles is False:
        return ()
    if isinstance(angles, str):
        angles = (angles,)
    out = tuple(str(a) for a in angles)
    bad = [a for a in out if a not in system.coordinates]
    if bad:
        raise ValueError(f"angles: {bad} are not coordinates of the system "
                         f"{list(system.coordinates)}; name the coordinates that are angles "
                         "(drawn modulo 2π).")
    return out


def unconstrained(system, where):
    if system.n_constraints:
        raise ValueError(f"{where}: the system has constraints; the tangent flow is computed for "
                         "unconstrained systems (state it in independent coordinates).")


def generic_basis(d, k):
    """k orthonormal vectors in R^d (d × k) in general position, the same every call: a
    tangent basis with no component missing (the identity's columns may miss the
    expanding direction of a system with a symmetry)."""
    rng = np.random.default_rng(20240521)
    Q, R = np.linalg.qr(rng.standard_normal((d, d)))
    return np.ascontiguousarray(Q[:, :k] * np.sign(np.diag(R))[:k])


def record_stops(transient, periods, intervals):
    """The interval ends (in drive periods from t0): the transient as one interval (when
    > 0), then the record cut into ``intervals`` nearly equal ones."""
    ends = transient + np.round(np.linspace(0, periods, intervals + 1)[1:]).astype(np.int64)
    return np.asarray(([transient] if transient else []) + ends.tolist(), dtype=float)


def block_error(logs, lengths, blocks, safety=2.5):
    """Exponents, their error and the blocks' exponents from per-interval log growths.

    ``logs`` (m, k): Σ log R over each of m record intervals of ``lengths`` (m,) seconds.
    The record is cut into ``blocks`` contiguous groups of intervals; each gives an
    estimate; the error is ``safety`` × their standard deviation / √B (B ≥ 2).  Returns
    (exponents (k,), error (k,), block exponents (B, k), sum's error)."""
    m = logs.shape[0]
    total = lengths.sum()
    lam = logs.sum(axis=0) / total
    groups = np.array_split(np.arange(m), min(blocks, m))
    per_block = np.array([logs[g].sum(axis=0) / lengths[g].sum() for g in groups])
    B = per_block.shape[0]
    if B < 2:
        return lam, np.full(lam.shape, math.inf), per_block, math.inf
    err = safety * per_block.std(axis=0, ddof=1) / math.sqrt(B)
    sums = per_block.sum(axis=1)
    return lam, err, per_block, float(safety * sums.std(ddof=1) / math.sqrt(B))

"""The symbols every statement shares: time ``t``, coordinates and their velocities.

A module of its own so that everything below :class:`lagrange_core.System` (derivation,
code generation, integration) can name them without importing the statement.
"""
from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

__all__ = ["t", "coordinates", "velocity_symbol"]

#: The time symbol shared by every system.
t = sp.Symbol("t", real=True)


def coordinates(names: str | Sequence[str]) -> tuple[tuple[sp.Symbol, ...], tuple[sp.Symbol, ...]]:
    """Make generalized coordinates and their velocity symbols.

    Parameters
    ----------
    names : str or sequence of str
        Space- or comma-separated names, e.g. ``"theta phi"``.

    Returns
    -------
    q, qdot : tuple of sympy.Symbol
        The coordinates and the matching velocities (``theta_dot``, ...),
        needed only when a Lagrangian or force is written by hand.

    Examples
    --------
    >>> (r, phi), (r_dot, phi_dot) = coordinates("r phi")
    >>> r_dot
    r_dot
    """
    if isinstance(names, str):
        names = names.replace(",", " ").split()
    q = tuple(sp.Symbol(n, real=True) for n in names)
    return q, tuple(velocity_symbol(s) for s in q)


def velocity_symbol(coordinate: sp.Symbol) -> sp.Symbol:
    """The velocity symbol ``<name>_dot`` that belongs to ``coordinate``."""
    return sp.Symbol(f"{coordinate.name}_dot", real=True)

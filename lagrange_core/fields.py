"""One-dimensional fields: a Lagrangian density and its Euler–Lagrange field equation.

A field u(x, t) with Lagrangian density ℒ(u, u_t, u_x, x, t) (J/m) has the
action S = ∫∫ ℒ dx dt; making it stationary gives the field equation

    ∂_t (∂ℒ/∂u_t) + ∂_x (∂ℒ/∂u_x) − ∂ℒ/∂u = 0,

where ∂_t, ∂_x are *total* derivatives along u(x, t).  The density is written
with plain symbols ``u``, ``u_t``, ``u_x`` (see :func:`field_symbols`); the
equation is returned in terms of the function u(x, t) and its derivatives, so
it reads as in a textbook and can be compared with sympy directly.

A discretised field (the string as a chain of beads) is an ordinary
:class:`~lagrange_core.System`; see :func:`lagrange_core.problems.bead_string`.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import sympy as sp

__all__ = ["Field1D", "field_symbols", "x"]

#: The position symbol along the field (m).
x = sp.Symbol("x", real=True)


def field_symbols(name: str = "u") -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """The symbols ``u``, ``u_t``, ``u_x`` in which a density is written.

    Examples
    --------
    >>> y, y_t, y_x = field_symbols("y")
    """
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"field_symbols: the field's name must be an identifier, got {name!r}.")
    return (sp.Symbol(name, real=True), sp.Symbol(f"{name}_t", real=True),
            sp.Symbol(f"{name}_x", real=True))


@dataclass(frozen=True)
class Field1D:
    """A scalar field u(x, t) on a line, stated by its Lagrangian density.

    Parameters
    ----------
    density : sympy expression
        ℒ(u, u_t, u_x, x, t) in the symbols of :func:`field_symbols` (J/m).
        Every other free symbol is a parameter.
    name : str
        The field's name (``"u"`` by default); fixes the symbol names.
    label : str, optional
        A description for messages.

    Raises
    ------
    ValueError
        If the density contains no time derivative u_t (no kinetic term: the
        field equation would not be an evolution equation).
    """

    density: sp.Expr
    name: str = "u"
    label: str = ""

    def __post_init__(self):
        u, u_t, u_x = field_symbols(self.name)
        density = sp.sympify(self.density)
        # accept symbols of the right names with other assumptions
        by_name = {s.name: s for s in (u, u_t, u_x, x)}
        density = density.xreplace({s: by_name[s.name] for s in density.free_symbols
                                    if s.name in by_name})
        if not density.has(u_t):
            raise ValueError(f"Field1D: the density {density} has no {u_t} term, so it has no "
                             "kinetic energy; write it with the symbols of "
                             f"field_symbols({self.name!r}).")
        object.__setattr__(self, "density", density)

    # -- symbols ---------------------------------------------------------------------------
    @property
    def symbols(self) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
        """(u, u_t, u_x)."""
        return field_symbols(self.name)

    @property
    def function(self) -> sp.Expr:
        """The field as a function u(x, t)."""
        from .symbols import t
        return sp.Function(self.name, real=True)(x, t)

    @property
    def parameters(self) -> tuple[str, ...]:
        """Names of the density's parameters, sorted."""
        from .symbols import t
        known = set(self.symbols) | {x, t}
        return tuple(sorted(s.name for s in self.density.free_symbols - known))

    # -- the field equation ----------------------------------------------------------------
    def _on_function(self, expr):
        from .symbols import t
        u, u_t, u_x = self.symbols
        U = self.function
        return expr.xreplace({u_t: U.diff(t), u_x: U.diff(x)}).xreplace({u: U})

    @functools.cached_property
    def field_equation(self) -> sp.Expr:
        """The left side E of the field equation E = 0 (sympy, in u(x, t)).

        E = ∂_t (∂ℒ/∂u_t) + ∂_x (∂ℒ/∂u_x) − ∂ℒ/∂u, with total derivatives.
        """
        from .symbols import t
        u, u_t, u_x = self.symbols
        L = self.density
        E = (sp.diff(self._on_function(sp.diff(L, u_t)), t)
             + sp.diff(self._on_function(sp.diff(L, u_x)), x)
             - self._on_function(sp.diff(L, u)))
        # simplify with the derivatives as plain symbols (sympy simplifies those better)
        derivs = sorted(E.atoms(sp.Derivative), key=sp.default_sort_key)
        plain = {d: sp.Dummy(f"d{i}", real=True) for i, d in enumerate(derivs)}
        second = [v for d, v in plain.items() if sum(c for _, c in d.variable_count) == 2]
        E = sp.collect(sp.expand(E.xreplace(plain)), second, evaluate=False)
        E = sp.Add(*[sp.simplify(coeff) * (1 if k == 1 else k) for k, coeff in E.items()])
        return E.xreplace({v: d for d, v in plain.items()})

    # -- limits ---------------------------------------------------------------------------
    def small_amplitude(self, order: int = 2) -> Field1D:
        """The density truncated at total degree ``order`` in (u, u_t, u_x).

        ``order=2`` (the default) keeps the quadratic part, whose field equation
        is linear: the small-amplitude (for a string: small-slope) limit.  The
        neglected terms are O(|u, u_t, u_x|^(order+1)) relative to ℒ's scale;
        terms of degree 0 (constants) are dropped, they do not change the
        equation.
        """
        if int(order) != order or order < 1:
            raise ValueError(f"small_amplitude: order must be a whole number ≥ 1, got {order!r}.")
        eps = sp.Dummy("epsilon", positive=True)
        u, u_t, u_x = self.symbols
        scaled = self.density.xreplace({u: eps * u, u_t: eps * u_t, u_x: eps * u_x})
        series = sp.series(scaled, eps, 0, int(order) + 1).removeO()
        truncated = sp.expand(series).subs(eps, 1)
        truncated = truncated - truncated.subs({u: 0, u_t: 0, u_x: 0})
        return Field1D(sp.simplify(truncated), self.name,
                       f"{self.label or 'field'}, small-amplitude limit (order {order})")

    def wave_speed(self) -> sp.Expr:
        """c of the linear wave equation u_tt = c² u_xx of a quadratic density.

        Requires ℒ = ½ a u_t² − ½ b u_x² (a, b > 0 constants, e.g. the
        :meth:`small_amplitude` limit of a string); then c = √(b/a) (m/s).

        Raises
        ------
        ValueError
            If the density has any other term (it is not the plain wave equation).
        """
        u, u_t, u_x = self.symbols
        L = sp.expand(self.density)
        a = sp.diff(L, u_t, 2)
        b = -sp.diff(L, u_x, 2)
        rest = sp.simplify(L - (a * u_t**2 - b * u_x**2) / 2)
        if rest != 0 or a.free_symbols & set(self.symbols) or b.free_symbols & set(self.symbols):
            raise ValueError(f"wave_speed: the density {self.density} is not of the form "
                             "a u_t²/2 − b u_x²/2 (take .small_amplitude() first).")
        return sp.sqrt(sp.simplify(b / a))

    def fixed_end_frequencies(self, length, n) -> sp.Expr:
        """Frequencies f_n = n c / (2 length) (Hz) of a wave-equation field fixed at both
        ends of a segment of ``length`` (m); ``n`` = 1, 2, … (number or sympy symbol)."""
        return n * self.wave_speed() / (2 * sp.sympify(length))

    def __repr__(self):
        return f"Field1D({self.label or self.name}: ℒ = {self.density})"

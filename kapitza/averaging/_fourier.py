"""The harmonic split of a drive periodic in ωt: the first step of averaging.

:func:`fourier_split` writes any expression whose time dependence is a finite sum of
harmonics of ωt (``cos(omega*t)``, ``sin(2*omega*t + phi)``, products of those …) as
c_0 + Σ_k (c_k cos kωt + s_k sin kωt), exactly (sympy), so that
:class:`~kapitza.averaging.AveragedSystem` can average the forces and the potential.
"""
from __future__ import annotations

import sympy as sp

from lagrange_core.systems import t as t_symbol

__all__ = ["fourier_split"]


def fourier_split(expr, omega, time=t_symbol) -> dict[int, tuple[sp.Expr, sp.Expr]]:
    """Split an expression periodic in ``omega*time`` into its harmonics.

    Parameters
    ----------
    expr : sympy expression
        A finite trigonometric polynomial in ωt (coefficients may depend on
        anything else).
    omega : sympy.Symbol
        The drive's angular frequency.
    time : sympy.Symbol
        The time symbol (default :data:`lagrange_core.t`).

    Returns
    -------
    dict
        ``{k: (c_k, s_k)}`` with expr = c_0 + Σ_k (c_k cos kωt + s_k sin kωt);
        ``s_0`` is 0.  Only non-zero harmonics are listed (k = 0 always is).

    Raises
    ------
    ValueError
        If the time dependence is not a finite sum of integer harmonics of ωt.
    """
    phase = sp.Dummy("phase", real=True)
    e = sp.sympify(expr).xreplace({time: phase / omega})
    if e.has(time):
        raise ValueError(f"{expr} depends on t other than through {omega}*t; averaging needs a "
                         f"drive periodic in {omega}*t.")
    trig = (sp.sin, sp.cos, sp.tan, sp.cot, sp.sec, sp.csc)
    e = e.replace(lambda x: isinstance(x, trig) and x.has(phase), lambda x: x.rewrite(sp.exp))
    e = sp.expand(e, power_exp=True, mul=True, multinomial=True, power_base=False, log=False)
    coeffs: dict[int, sp.Expr] = {}
    for term in sp.Add.make_args(e):
        if term == 0:
            continue
        coef, dep = term.as_independent(phase, as_Add=False)
        exponent = sp.S.Zero
        for factor in sp.Mul.make_args(dep):
            base, power = factor.as_base_exp()
            if factor == 1:
                continue
            if base is not sp.E:
                raise ValueError(
                    f"the time dependence of {expr} is not periodic in {omega}*t (found the factor "
                    f"{factor.xreplace({phase: omega * time})}); averaging needs a drive that is a "
                    "finite sum of harmonics cos(k*omega*t), sin(k*omega*t).")
            exponent += power
        exponent = sp.expand(exponent)
        slope = sp.diff(exponent, phase)
        k = sp.nsimplify(slope / sp.I)
        if slope.has(phase) or not k.is_Integer:
            raise ValueError(
                f"the time dependence of {expr} contains the frequency {slope / sp.I}*{omega}, "
                f"not a whole multiple of {omega}; write the drive in harmonics of the fundamental "
                "frequency and name that one as omega.")
        rest = sp.expand(exponent - slope * phase)
        coeffs[int(k)] = coeffs.get(int(k), sp.S.Zero) + coef * sp.exp(rest)

    def real(x):
        x = sp.expand(x)
        if not x.has(sp.I):
            return x
        # phases such as exp(I*phi): every symbol is a real quantity, so say so to sympy
        to_real = {s: sp.Dummy(s.name, real=True) for s in x.free_symbols if not s.is_real}
        back = {d: s for s, d in to_real.items()}
        x = sp.expand(sp.expand_complex(x.xreplace(to_real)))
        if x.has(sp.I):
            x = sp.simplify(x)
        return x.xreplace(back)

    out = {0: (real(coeffs.get(0, sp.S.Zero)), sp.S.Zero)}
    for k in sorted({abs(k) for k in coeffs if k != 0}):
        cp, cm = coeffs.get(k, sp.S.Zero), coeffs.get(-k, sp.S.Zero)
        c, s = real(cp + cm), real(sp.I * (cp - cm))
        if c != 0 or s != 0:
            out[k] = (c, s)
    return out

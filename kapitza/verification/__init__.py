"""Averaging, Floquet analysis and direct simulation side by side over a grid: agreement,
every disagreement located, the measured order of averaging.

Public: :func:`verify` (any driven system; :meth:`kapitza.KapitzaPendulum.verify` for the
pendulum) and :func:`fit_order`; both fill the results :class:`~kapitza.results.Verification`
and :class:`~kapitza.results.OrderFit`, which compare and draw themselves.  For sibling
rooms (not in ``__all__``): ``pendulum_verification`` (the work behind
``KapitzaPendulum.verify``) and ``line_argument`` (its ``line=`` checked).
"""
from ._verify import fit_order, verify
from ._verify import line_argument as line_argument
from ._verify import pendulum_verification as pendulum_verification

__all__ = ["verify", "fit_order"]

"""Multiple-scale averaging of any driven system: the effective potential U_eff, its
equilibria and slow modes, the averaging window, and where averaging holds.

Public: :func:`average`, :class:`AveragedSystem`, :class:`AveragingValidityWarning`,
:func:`fourier_split`, and the validity limits ``MIN_FREQUENCY_RATIO`` and
``MAX_AMPLITUDE_RATIO``.

Modules: ``_average`` (the method and :class:`AveragedSystem`), ``_fourier`` (the
harmonic split), ``_codegen`` (each system's compiled terms), ``_kernels`` (U_eff and its
derivatives from the terms, shared by every system), ``_window`` (the averaging window per
ω), ``_validity`` (the thresholds), ``_legacy`` (the old ``(q, params)`` order).
"""
from ._average import AveragedSystem, average
from ._fourier import fourier_split
from ._validity import MAX_AMPLITUDE_RATIO, MIN_FREQUENCY_RATIO, AveragingValidityWarning

__all__ = ["average", "AveragedSystem", "AveragingValidityWarning", "fourier_split",
           "MIN_FREQUENCY_RATIO", "MAX_AMPLITUDE_RATIO"]

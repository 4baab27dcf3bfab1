"""Multiple-scale averaging of any driven system: the effective potential U_eff, its
equilibria and slow modes, the averaging window, and where averaging holds.

Public: :func:`average`, :class:`AveragedSystem`, :class:`AveragingValidityWarning`.
For sibling subpackages: the validity limits ``MIN_FREQUENCY_RATIO`` and
``MAX_AMPLITUDE_RATIO``.
"""
from ._average import (MAX_AMPLITUDE_RATIO, MIN_FREQUENCY_RATIO, AveragedSystem,
                       AveragingValidityWarning, average, fourier_split)

__all__ = ["average", "AveragedSystem", "AveragingValidityWarning", "fourier_split",
           "MIN_FREQUENCY_RATIO", "MAX_AMPLITUDE_RATIO"]

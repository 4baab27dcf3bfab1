"""Continuation: branches of periodic orbits followed in one parameter through folds, with
their Floquet multipliers, their bifurcations (fold, pitchfork, transcritical, period
doubling, Neimark–Sacker) and the branches that emanate from them.
"""
from ._continuation import continuation

__all__ = ["continuation"]

"""kapitza: fast periodic driving on top of lagrange_core.

Public API
----------
(filled by the averaging and Floquet modules)
"""
__all__: list[str] = []
__version__ = "0.1.0"

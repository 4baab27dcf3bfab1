"""Scenes: a set-up in a TOML file (schema and validation), the analyses it asks for, and
sweeps of it in resumable Parquet tiles (serial, numba threads or a Dask cluster).
The shipped scene files sit beside this module (``example_scenes()``).
"""
from ._file import SceneError
from ._scene import Scene, SceneResults, code_fingerprint, example_scenes
from ._sweep import SweepResult

__all__ = ["Scene", "SceneResults", "SceneError", "SweepResult", "example_scenes",
           "code_fingerprint"]

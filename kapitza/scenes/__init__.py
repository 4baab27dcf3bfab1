"""Scenes: a set-up in a TOML file (schema and validation), the analyses it asks for, and
sweeps of it in resumable Parquet tiles (serial, numba threads or a Dask cluster).
The shipped scene files sit beside this module (``example_scenes()``).

Public: :class:`Scene`, :class:`SceneResults`, :class:`SceneError`, :class:`SweepResult`,
:func:`example_scenes`, :func:`code_fingerprint`.  Also here, not in ``__all__``: the
types a scene's attributes hold — :class:`SceneSpec` (``Scene.spec``), :class:`Axis` (an
axis of its analyses and sweep), :class:`SceneProblem` (``SceneError.problems``) — and
:func:`fingerprinted_modules` (the code :func:`code_fingerprint` covers).

Modules: ``_schema`` (the file's tables, keys and units), ``_checker`` (problems collected
and raised together), ``_file`` (reading and checking; Hz → rad/s happens here and nowhere
further in), ``_scene`` (:class:`Scene`, :class:`SceneResults`, the code fingerprint),
``_analyses`` (how each analysis is computed), ``_sweep`` and ``_sweep_dask`` (the tile
store and its executors).
"""
from ._checker import SceneError
from ._checker import SceneProblem as SceneProblem
from ._file import Axis as Axis
from ._file import SceneSpec as SceneSpec
from ._scene import Scene, SceneResults, code_fingerprint, example_scenes
from ._scene import fingerprinted_modules as fingerprinted_modules
from ._sweep import SweepResult

__all__ = ["Scene", "SceneResults", "SceneError", "SweepResult", "example_scenes",
           "code_fingerprint"]

"""Scenes: a set-up in a TOML file (schema and validation), the analyses it asks for, and
sweeps of it in resumable Parquet tiles (serial, numba threads or a Dask cluster).
The shipped scene files sit beside this module (``example_scenes()``).

Public: :class:`Scene`, :class:`SceneResults`, :class:`SceneError`, :class:`SweepResult`,
:func:`example_scenes`, :func:`code_fingerprint`, :func:`open_sweep` (a sweep's directory as
one :class:`xarray.Dataset`).  Also here, not in ``__all__``: the
types a scene's attributes hold — :class:`SceneSpec` (``Scene.spec``), :class:`Axis` (an
axis of its analyses and sweep), :class:`SceneProblem` (``SceneError.problems``),
:class:`Branches` (a scene's ``continuation`` result) — :func:`fingerprinted_modules` (the
code :func:`code_fingerprint` covers) and :func:`run_analysis` (one analysis at the
scene's point with given settings: the report's quick mode), :func:`read_scene_data` (a
scene checked from its parsed tables: the command line's scenes from options) and
:func:`storable` (a table with its complex columns split for Parquet),
:func:`table_metadata` and :func:`write_frame` (the record a written table carries, and
the writing of a table with it: the report's tables), :class:`SweepLockedError` (another
sweep writes the dataset) and :class:`DamagedPartWarning` (a damaged part moved aside and
computed again).

Modules: ``_schema`` (the file's tables, keys and units), ``_checker`` (problems collected
and raised together), ``_file`` (reading and checking; Hz → rad/s happens here and nowhere
further in; the analyses' settings in ``_settings``), ``_scene`` (:class:`Scene`,
:class:`SceneResults`, the code fingerprint), ``_analyses`` (how each analysis is
computed, and the method it names), ``_rigs`` (a rig's declaration: the units of its
coordinates and its named states), ``_states`` (what ``about`` means), ``_frontier``
(continuation, bifurcation diagram, Lyapunov exponents), ``_outputs`` (what a run writes,
all or nothing, and the record every table carries), ``_sweep``, ``_sweep_store`` and
``_sweep_dask`` (the tile store, its integrity and lock, and its executors),
``_sweep_xarray`` (a sweep as one labelled grid: ``open_sweep``,
``SweepResult.to_xarray``).
"""
from ._analyses import run_analysis as run_analysis
from ._checker import SceneError
from ._checker import SceneProblem as SceneProblem
from ._file import SceneSpec as SceneSpec
from ._file import read_scene_data as read_scene_data
from ._frontier import Branches as Branches
from ._outputs import table_metadata as table_metadata
from ._outputs import write_frame as write_frame
from ._rigs import default_band as default_band
from ._scene import Scene, SceneResults, code_fingerprint, example_scenes
from ._scene import fingerprinted_modules as fingerprinted_modules
from ._settings import Axis as Axis
from ._states import about_state as about_state
from ._states import persists as persists
from ._sweep import SweepResult
from ._sweep import storable as storable
from ._sweep_store import DamagedPartWarning as DamagedPartWarning
from ._sweep_store import SweepLockedError as SweepLockedError
from ._sweep_xarray import open_sweep

__all__ = ["Scene", "SceneResults", "SceneError", "SweepResult", "example_scenes",
           "code_fingerprint", "open_sweep"]

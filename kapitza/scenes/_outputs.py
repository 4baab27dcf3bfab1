"""What a scene writes, and what every written table says about itself.

Three rules, for :meth:`kapitza.Scene.run`, the report's tables and the sweeps:

1. **Every table says what it is** (:func:`table_metadata`): the scene (its name, the
   SHA-256 of its text, the text itself, its file), the parameters and the initial
   state with their units, the analysis, its method, tolerances and integrator, the
   code's fingerprint and the package versions.  A Parquet file carries the record as
   JSON under the schema key ``kapitza``; a CSV file has a sidecar
   ``<name>.csv-metadata.json`` (the W3C "CSV on the Web" convention: its columns and
   their types, and the record under ``kapitza``).  Axes are stored compactly — a
   range as its start, stop, number and scale, only a list as its values — since a
   table holds its own axis columns.
2. **A scene's outputs are written all or nothing** (:func:`write_outputs`): every file
   goes first to a staging folder inside the output directory; only when all are
   written are they moved into place (renames, which need no space), the previous
   manifest removed first and the new one, ``_run.json``, written last.  A failure
   before that (a full disk, an error, a killed process) leaves the previous complete
   output as it was; a staging folder left by a killed process is removed by the next
   run.  The manifest lists each file with its rows and SHA-256.
3. **A grid that cannot fit is refused before any work** (:func:`check_scene_grids`):
   every analysis over axes is estimated (its computation and its table) against
   :func:`lagrange_core.memory.memory_limit`, naming the scene key.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import time
from pathlib import Path

import numpy as np

from lagrange_core.progress import defer_ctrl_c, interrupt_requested

from .. import _arguments as arguments
from ._analyses import method_of
from ._fingerprint import code_fingerprint
from ._settings import Axis, axis_range
from ._sweep import axis_record, package_versions, storable, write_table, write_text
from ._sweep_store import sha256_file

__all__ = ["RUN_MANIFEST", "table_metadata", "sweep_metadata", "compact", "write_frame",
           "write_outputs", "check_scene_grids", "CSV_SIDECAR"]

#: The manifest of a scene run's output directory, written last.
RUN_MANIFEST = "_run.json"
#: The suffix of a CSV file's metadata sidecar (``floquet.csv`` → ``floquet.csv-metadata.json``).
CSV_SIDECAR = "-metadata.json"

#: Tolerances of the analyses where the scene gives none — the defaults of
#: :mod:`kapitza.scenes._analyses` (the stability map's: the Mathieu map's, then the
#: monodromy map's), recorded so that a table says what it was computed to.
_DEFAULT_TOLERANCES = {
    "floquet": {"tol": 1e-10}, "window": {"tol": 1e-10}, "measure": {"rtol": 1e-9},
    "simulate": {"rtol": 1e-9}, "verify": {"tol": 1e-10, "rtol": 1e-9},
}
_TOLERANCE_KEYS = ("tol", "rtol", "atol", "guard_tol", "coarse_tol")


# -- the record -------------------------------------------------------------------------------

def compact(x):
    """``x`` in JSON's terms, an axis compactly: a range as {name, kind, start, stop, num}
    (its values are ``numpy.linspace``/``geomspace(start, stop, num)``), a list as its
    values; tuples as lists, paths as text."""
    if isinstance(x, Axis):
        return {"name": x.name, **axis_record(x)}
    if isinstance(x, dict):
        return {str(k): compact(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [compact(v) for v in x]
    if isinstance(x, Path):
        return str(x)
    if isinstance(x, np.generic):
        return x.item()
    return x


def _units(scene) -> tuple[dict, dict]:
    """(unit of each parameter, unit of each initial value): "" where dimensionless."""
    spec = scene.spec
    declaration = getattr(spec, "declaration", None)
    params = {k: axis_range(k, spec.rig, declaration)[3] or "" for k in spec.params}
    initial = {k: axis_range(f"initial.{k}", spec.rig, declaration)[3] or ""
               for k in scene.system.coordinates}
    initial.update({f"{k}_dot": axis_range(f"initial.{k}_dot", spec.rig, declaration)[3] or ""
                    for k in scene.system.coordinates})
    return params, initial


def _scene_record(scene) -> dict:
    spec = scene.spec
    param_units, initial_units = _units(scene)
    name = spec.title or (Path(spec.source).stem if spec.source != "<text>" else "<text>")
    return {"scene": spec.text, "scene_name": name,
            "scene_sha256": hashlib.sha256(spec.text.encode()).hexdigest(),
            "source": spec.source, "system": scene.system.name,
            "parameters": dict(spec.params), "units": param_units,
            "initial": dict(spec.initial), "initial_units": initial_units,
            "fingerprint": code_fingerprint(scene._user_module),
            "versions": package_versions()}


def _tolerances(analysis, settings, result) -> dict:
    """The tolerances a result was computed to: the scene's settings, else the result's
    own fields, else :data:`_DEFAULT_TOLERANCES`."""
    out = dict(_DEFAULT_TOLERANCES.get(analysis, {}))
    if analysis == "stability_map":
        exact = getattr(result, "l", None) is not None      # the Mathieu map
        out["tol"] = 1e-10 if exact else 1e-8
    for key in _TOLERANCE_KEYS:
        value = getattr(result, key, None)
        if isinstance(value, (int, float, np.number)) and not isinstance(value, bool) \
                and np.isfinite(value):
            out[key] = float(value)
    out.update({k: settings[k] for k in _TOLERANCE_KEYS if settings.get(k) is not None})
    return out


def _integrator(scene, analysis, settings, result=None):
    """The integration method of an analysis that simulates (None for the others): the
    result's own ``method`` where it says, else ``[analyses]``'s ``method``, else the rule
    of :func:`lagrange_core.batch.simulate_grid` (RKN 12 for q̈ = f(q, t), else DOP853)."""
    if analysis not in ("measure", "simulate", "bifurcation_diagram", "lyapunov"):
        return None
    method = getattr(result, "method", None)
    if isinstance(method, str) and method:
        return method
    if settings.get("method"):
        return settings["method"]
    return "rkn12" if scene.system.kernels.rkn_form else "dop853"


def table_metadata(scene, analysis: str | None = None, *, method: str | None = None,
                   result=None, settings: dict | None = None, **extra) -> dict:
    """The record a table of ``scene`` carries (module docstring, rule 1).

    Parameters
    ----------
    scene : kapitza.Scene
    analysis : str, optional
        The analysis the table is of (its settings come from the scene unless given).
    method : str, optional
        How it was computed, "<family>: <detail>" (the table's ``method`` column).
    result : optional
        The analysis's result, whose fields (``rtol``, ``tol``, ``method``) fill in the
        tolerances and the integrator.
    settings : dict, optional
        The settings used, where they differ from the scene's (the report's quick mode).
    **extra
        More keys of the record (e.g. the report's section).

    Returns
    -------
    dict
        JSON-able: ``scene`` (text), ``scene_name``, ``scene_sha256``, ``source``,
        ``system``, ``parameters`` and ``units`` (parameter → unit), ``initial`` and
        ``initial_units``, ``analysis``, ``method``, ``settings`` (axes compact),
        ``tolerances``, ``integrator``, ``scene_key``, ``fingerprint``, ``versions``,
        ``written`` (UTC time).
    """
    if settings is None:
        settings = scene.spec.analyses.get(analysis, {}) if analysis is not None else {}
    meta = _scene_record(scene)
    meta.update(analysis=analysis, method=method, settings=compact(settings),
                tolerances=_tolerances(analysis, settings, result),
                integrator=_integrator(scene, analysis, settings, result),
                scene_key=scene.key(analysis) if analysis in scene.spec.analyses
                else scene.key(),
                written=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()))
    meta.update(compact(extra))
    return meta


def sweep_metadata(scene, analysis: str, key: str) -> dict:
    """The record of a sweep of ``analysis`` (every part and ``_common_metadata`` carry it,
    with the axes, tile and plan that :func:`kapitza.scenes._sweep.run_sweep` adds): as
    :func:`table_metadata`, plus the sweep's axes (compact), targets and their units."""
    s = scene.spec.sweep
    settings = scene.spec.analyses.get(analysis, {})
    meta = table_metadata(scene, analysis, method=method_of(analysis, scene, settings))
    param_units, initial_units = meta["units"], meta["initial_units"]
    meta.update(scene_key=key, targets=dict(s["targets"]),
                axis_units={a.name: (initial_units.get(s["targets"][a.name][len("initial."):], "")
                                     if s["targets"][a.name].startswith("initial.")
                                     else param_units.get(s["targets"][a.name], ""))
                            for a in s["axes"]})
    meta.pop("written")
    return meta


# -- writing --------------------------------------------------------------------------------

def _csvw_type(dtype) -> str:
    """A column's CSVW datatype."""
    from pandas.api import types
    for test, name in ((types.is_bool_dtype, "boolean"), (types.is_integer_dtype, "integer"),
                       (types.is_float_dtype, "double"), (types.is_datetime64_any_dtype,
                                                         "datetime")):
        if test(dtype):
            return name
    return "string"


def write_frame(frame, directory, name: str, formats, metadata: dict) -> list:
    """Write ``frame`` as ``<name>.parquet`` (``metadata`` under the schema key
    ``kapitza``) and/or ``<name>.csv`` with its sidecar ``<name>.csv-metadata.json``, each
    file atomically (a temporary file, then a rename); the paths written."""
    directory = Path(directory)
    written = []
    if "parquet" in formats:
        written.append(write_table(frame, directory / f"{name}.parquet", metadata))
    if "csv" in formats:
        path = directory / f"{name}.csv"
        plain = storable(frame)
        write_text(path, plain.to_csv(index=False))
        sidecar = {"@context": "http://www.w3.org/ns/csvw", "url": path.name,
                   "tableSchema": {"columns": [{"name": str(c), "datatype": _csvw_type(t)}
                                               for c, t in plain.dtypes.items()]},
                   "kapitza": metadata}
        side = directory / f"{path.name}{CSV_SIDECAR}"
        write_text(side, json.dumps(sidecar, indent=1, sort_keys=True, default=str))
        written += [path, side]
    return written


def _remove_stray_staging(directory: Path):
    """Staging folders of runs that no longer run (killed while writing)."""
    for p in directory.glob(".staging-*"):
        try:
            os.kill(int(p.name.split("-")[1]), 0)
        except ProcessLookupError:
            shutil.rmtree(p, ignore_errors=True)
        except (ValueError, IndexError, OSError):
            pass


def write_outputs(scene, tables: dict, directory, formats) -> list:
    """Write a scene run's tables into ``directory`` all or nothing (module docstring,
    rule 2).

    Parameters
    ----------
    scene : kapitza.Scene
    tables : dict
        Table name → (DataFrame, metadata dict).
    directory : path
    formats : sequence of "parquet", "csv"

    Returns
    -------
    list of Path
        The files written (in ``directory``), the manifest last.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    _remove_stray_staging(directory)
    staging = directory / f".staging-{os.getpid()}-{os.urandom(4).hex()}"
    staging.mkdir()
    try:
        # a Ctrl-C waits for the files to be complete: what was computed is kept
        with defer_ctrl_c():
            staged, entries = [], {}
            for name, (frame, meta) in tables.items():
                files = write_frame(frame, staging, name, formats, meta)
                staged += files
                entries[name] = {"rows": len(frame), "analysis": meta.get("analysis"),
                                 "method": meta.get("method"),
                                 "files": {p.name: sha256_file(p) for p in files}}
            record = _scene_record(scene)
            manifest = {"scene_name": record["scene_name"],
                        "scene_sha256": record["scene_sha256"], "source": record["source"],
                        "scene_key": scene.key(), "fingerprint": record["fingerprint"],
                        "versions": record["versions"],
                        "written": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                        "tables": entries}
            text = json.dumps(manifest, indent=1, sort_keys=True, default=str)
            # every file is whole: the old manifest goes first, the new one comes last
            (directory / RUN_MANIFEST).unlink(missing_ok=True)
            for p in staged:
                os.replace(p, directory / p.name)
            write_text(directory / RUN_MANIFEST, text)
            if interrupt_requested():       # Ctrl-C while writing: stop now, all is kept
                raise KeyboardInterrupt
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return [directory / p.name for p in staged] + [directory / RUN_MANIFEST]


# -- grids that cannot fit ----------------------------------------------------------------------

#: Memory of a written table per row and column (bytes): the DataFrame, its storable copy,
#: the Arrow table and the Parquet and CSV buffers (measured with tracemalloc: 39 for the
#: Mathieu map's five columns of floats, booleans and text, Parquet and CSV written).
_TABLE_BYTES_PER_CELL = 48


def check_scene_grids(scene):
    """Refuse, before any analysis runs, one whose grid would not fit in memory: its
    computation's peak and its table's (:func:`kapitza._arguments.check_grid_memory`),
    naming the scene key."""
    n = scene.system.n_dof
    for name, s in scene.spec.analyses.items():
        shape, cells, per_point = None, 6, 0.0
        if name in ("stability_map", "verify"):
            shape = (len(s["A"]), len(s["omega"]))
            axes = "A × omega"
            pend = scene.pendulum
            mathieu = pend is not None and s.get("about", "auto") in (
                "inverted", "hanging", "auto") and not any(
                k in s for k in ("guard_tol", "taylor_order", "coarse_tol"))
            if name == "stability_map" and mathieu:
                per_point = (arguments.MATHIEU_MAP_BYTES if scene.spec.params.get("gamma", 0) == 0
                             else arguments.MATHIEU_TRACE_MAP_BYTES)
            else:
                per_point = arguments.monodromy_bytes_per_point(n)
            if name == "verify":
                per_point += arguments.measure_bytes_per_point(n, s.get("periods", 1000))
                cells = 40
        elif name == "simulate":
            shape, axes = (s.get("samples", 1001),), "samples"
            per_point, cells = 8.0 * (2 * n + 1) * 4, 2 * n + 2    # t, q, q̇ and copies
        elif name == "bifurcation_diagram":
            starts = s.get("starts")
            shape = (len(s["values"]), max(1, len(starts)) if starts is not None else 1)
            axes = "values × starts"
            periods = s.get("periods", 200)
            per_point = arguments.measure_bytes_per_point(n, periods)
            cells = 6 * (periods if isinstance(periods, int) else 1)
        if shape is None:
            continue
        fix = (f"give analyses.{name} fewer samples (or a trajectory in pieces: "
               "`kapitza sweep` over initial states)" if name == "simulate" else
               f"give analyses.{name} coarser axes (fewer points), or sweep floquet or "
               "measure over these axes in the scene's [sweep] with `kapitza sweep`, which "
               "computes them in tiles written to disk")
        arguments.check_grid_memory(
            f"[analyses] {name}: {axes}", shape, per_point + _TABLE_BYTES_PER_CELL * cells,
            where=f"{scene.spec.source}: ", fix=fix)

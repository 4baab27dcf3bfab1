"""Scenes: a set-up stated in a file, built into a System, analysed as the file asks.

:class:`Scene` is a checked scene file (the schema: :mod:`._schema`; the checks:
:mod:`._file`): ``Scene.from_toml(path)``, then ``scene.system`` is the
:class:`lagrange_core.System` with only the effects the file names
(:func:`lagrange_core.effects.build`), and ``scene.run()`` computes the analyses of
``[analyses]`` — only those — at the scene's point, and ``scene.sweep()`` a sweepable one
over the ``[sweep]`` grid (:mod:`._sweep`).  How each analysis is computed:
:meth:`Scene.run`; the functions: :mod:`._analyses`; what is written and the record each
table carries: :mod:`._outputs`.

Examples
--------
>>> import kapitza
>>> scene = kapitza.Scene.example("kapitza_pendulum")
>>> scene.system.parameters                  # damping named: gamma is a parameter
('A', 'g', 'gamma', 'l', 'm', 'omega')
>>> sorted(scene.analyses)
['averaging', 'floquet']
>>> scene.drive.path, scene.drive.keeps_vertical_equilibria
('vertical', True)
"""
from __future__ import annotations

import functools
import hashlib
import json
import threading
import time
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from lagrange_core import effects as fx
from lagrange_core.module_store import content_key

from ..pendulum import KapitzaPendulum
from . import _sweep as sweeps
from ._analyses import GRID, POINT, method_of, tile_inputs
from ._file import SceneSpec, read_scene, read_scene_text
from ._fingerprint import _package_fingerprint as _package_fingerprint
from ._fingerprint import code_fingerprint, fingerprinted_modules
from ._outputs import check_scene_grids, sweep_metadata, table_metadata, write_outputs
from ._schema import SWEEPABLE
from ._settings import Axis

__all__ = ["Scene", "SceneResults", "code_fingerprint", "example_scenes",
           "fingerprinted_modules"]

def example_scenes() -> dict:
    """The scene files that ship with kapitza: name → path."""
    folder = resources.files("kapitza") / "scenes"
    return {Path(p.name).stem: Path(str(p)) for p in sorted(folder.iterdir(),
                                                             key=lambda p: p.name)
            if p.name.endswith(".toml")}


# -- the scene ----------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Scene:
    """A checked scene file and what it builds.

    Build it with :meth:`from_toml`, :meth:`from_text` or :meth:`example`.  The file's
    schema (tables, keys, units) is stated in ``kapitza/scenes/_schema.py``; every value is
    in SI units once read (a ``frequency_hz`` is the drive's ``omega`` in rad/s).

    Attributes
    ----------
    spec : kapitza.scenes.SceneSpec
        Everything the file says, checked, with defaults filled in (``source``,
        ``title``, ``rig_name``, ``params``, ``initial``, ``analyses``, ``sweep``, ...).
    """

    spec: SceneSpec

    @classmethod
    def from_toml(cls, path) -> Scene:
        """Read and check the scene file at ``path``; raises
        :class:`~kapitza.SceneError` with every problem found."""
        return cls(read_scene(path))

    @classmethod
    def from_text(cls, text: str, source: str = "<text>") -> Scene:
        """A scene from TOML text (``source`` names it in messages)."""
        return cls(read_scene_text(text, source))

    @classmethod
    def example(cls, name: str) -> Scene:
        """One of the scenes that ship with kapitza (:func:`example_scenes`)."""
        found = example_scenes()
        if name not in found:
            raise ValueError(f"no example scene {name!r}; the examples are {sorted(found)}.")
        return cls.from_toml(found[name])

    # -- what it says --------------------------------------------------------------------
    @property
    def path(self) -> Path | None:
        """The scene file (None for a scene from text)."""
        return None if self.spec.source == "<text>" else Path(self.spec.source)

    @property
    def params(self) -> dict:
        """Every parameter of :attr:`system` by name (SI units)."""
        return dict(self.spec.params)

    @property
    def effects(self) -> tuple:
        """The effect objects the scene names (:mod:`lagrange_core.effects`), in the file's
        order."""
        return self.spec.effects

    @property
    def drive(self) -> fx.PivotDrive | None:
        """The pivot's drive, or None where the scene has no ``[effects.drive]``.

        A :class:`lagrange_core.effects.PivotDrive`: ``.path`` is "vertical",
        "horizontal", "elliptic" or a direction vector ``(dx, dy)``; ``.harmonics`` the
        terms ``(k, a_k, phase)``; ``.keeps_vertical_equilibria`` is True when the pivot
        stays on the vertical (θ = 0 and π persist, so an analysis can be about them).
        Its amplitude and frequency are the parameters ``A`` (m) and ``omega`` (rad/s)
        of :attr:`params`.
        """
        return next((e for e in self.effects if isinstance(e, fx.PivotDrive)), None)

    @property
    def analyses(self) -> dict:
        """The analyses asked for, name → settings, in the file's order.  A setting that
        is an axis is a ``Axis`` (``kapitza.scenes._settings``) in SI units (the drive frequencies
        always ``omega``, rad/s, also where the file gave ``frequency_hz``)."""
        return dict(self.spec.analyses)

    @functools.cached_property
    def system(self):
        """The lagrange_core.System with exactly the effects the scene names."""
        return fx.build(self.spec.rig, self.spec.effects)

    @functools.cached_property
    def capabilities(self) -> dict:
        """What the effects allow (:func:`lagrange_core.effects.capabilities`)."""
        return fx.capabilities(self.spec.effects)

    @property
    def q0(self) -> np.ndarray:
        """Initial coordinates (rad), in the system's order."""
        return np.array([self.spec.initial.get(c, 0.0) for c in self.system.coordinates])

    @property
    def qdot0(self) -> np.ndarray:
        """Initial velocities (rad/s)."""
        return np.array([self.spec.initial.get(f"{c}_dot", 0.0)
                         for c in self.system.coordinates])

    @functools.cached_property
    def pendulum(self) -> KapitzaPendulum | None:
        """The plain pendulum as a :class:`KapitzaPendulum`, or None (:meth:`run` says
        which scenes are the plain pendulum)."""
        kinds = {type(e) for e in self.effects}
        drive = self.drive
        if (self.spec.rig_name != "pendulum" or not kinds <= {fx.Gravity, fx.PivotDrive,
                                                              fx.Damping}
                or fx.Gravity not in kinds or drive is None
                or drive.path not in ("vertical", "horizontal")
                or drive.harmonics != ((1, 1.0, 0.0),)):
            return None
        p = self.spec.params
        return KapitzaPendulum(l=p["l"], g=p["g"], damping=p.get("gamma", 0.0),
                               drive=drive.path)

    @property
    def _user_module(self):
        name = self.spec.rig_name
        return name.partition(":")[0] if ":" in name else None

    def key(self, analysis: str | None = None) -> str:
        """Hash of what the scene's numbers depend on (the statement, the parameters, the
        initial state, and the settings and sweep of ``analysis``, or of every analysis);
        the output place and the title are not part of it."""
        parts = {"statement": self.system.statement_key(), "params": self.spec.params,
                 "initial": self.spec.initial, **self.spec.declared_key()}
        if analysis is None:
            parts["analyses"] = self.spec.analyses
            parts["sweep"] = self._sweep_record()
        else:
            parts["analysis"] = [analysis, self.spec.analyses.get(analysis, {})]
            if self.spec.sweep and analysis in self.spec.sweep["analyses"]:
                parts["sweep"] = self._sweep_record()
        return content_key(json.dumps(_plain(parts), sort_keys=True))

    def _sweep_record(self):
        s = self.spec.sweep
        if not s:
            return None
        return {"axes": [_plain(a) for a in s["axes"]],
                "targets": s["targets"], "tile_points": s["tile_points"]}

    def __repr__(self):
        return (f"<Scene {self.spec.source}: {self.system.name}; analyses "
                f"{list(self.spec.analyses)}>")

    # -- running -------------------------------------------------------------------------
    def run(self, *, progress=None, executor=None, worker_threads: int = 1,
            write: bool = True) -> SceneResults:
        """Compute the analyses of ``[analyses]``, each once at the scene's point.

        A ``[sweep]`` is not run here (its grid is :meth:`sweep`'s, ``kapitza sweep``): an
        analysis it names runs at the scene's point like the others.  Before any work,
        every grid of ``[analyses]`` (a map's, a verification's, a diagram's) is checked
        against the memory it needs (``kapitza.scenes._outputs.check_scene_grids``).
        With ``[output] directory`` (and ``write``) every table is written there,
        ``<table>.parquet`` and/or ``<table>.csv`` (with its ``.csv-metadata.json``
        sidecar), each carrying the record of ``kapitza.scenes._outputs.table_metadata``
        (the scene, parameters with units, method, tolerances, integrator, versions) — all
        or nothing, the manifest ``_run.json`` last (:mod:`kapitza.scenes._outputs`).

        Parameters
        ----------
        progress : None or bool
            Progress lines of long grids (None: when stderr is a terminal).
        executor, worker_threads
            Not used since the sweep runs only through :meth:`sweep` (kept so that old
            calls still work).
        write : bool
            Write the output tables (False: nothing is written anywhere).

        Returns
        -------
        SceneResults

        Raises
        ------
        kapitza.GridTooLargeError
            A grid of ``[analyses]`` that would not fit in memory, before any work (a
            ValueError naming the scene key, the estimate and the limit).

        Notes
        -----
        Each analysis uses the best method the effects allow
        (:func:`lagrange_core.effects.capabilities`).  "The plain pendulum" is the
        catalogue's pendulum with gravity, a drive along the vertical or the horizontal
        (one harmonic) and at most damping, which has closed forms and exact maps
        (:attr:`pendulum`).

        ``averaging``
            Plain pendulum: the closed forms, order 1 or 2 (:meth:`KapitzaPendulum.averaged`,
            :class:`~kapitza.PendulumAveraging`).  Otherwise the general first-order
            averaging (:func:`kapitza.average` ``.predict``,
            :class:`~kapitza.AveragingPrediction`).
        ``floquet``
            A drive along the vertical keeps θ = 0, π: :func:`kapitza.floquet_point` about
            ``about`` (:class:`~kapitza.FloquetResult`).  A drive off the vertical leaves
            no equilibrium: the periodic orbit by Newton shooting
            (:func:`kapitza.periodic_orbit`, :class:`~kapitza.PeriodicOrbit`).
        ``stability_map``
            Plain pendulum: the exact Mathieu map (:meth:`KapitzaPendulum.stability_map`).
            Otherwise the monodromy map (:func:`kapitza.stability_map`).
        ``window``
            Exact for every system where Floquet applies: the plain pendulum's Mathieu
            window (:meth:`KapitzaPendulum.window`), any other system's certified
            monodromy window (:func:`kapitza.window`).  The averaging window only when
            asked for by name, ``method = "averaging"`` (the closed form of order 1 or 2
            for the plain pendulum, :meth:`kapitza.AveragedSystem.window` otherwise);
            either way a :class:`~kapitza.StabilityWindow` whose ``method`` says which.
        ``measure``
            Direct simulation measured from strobe samples (:func:`kapitza.measure`,
            :class:`~kapitza.Measurement`), integrated by the method the effects allow
            (RKN 12 without velocity forces, DOP853 with them).
        ``simulate``
            One trajectory (:meth:`lagrange_core.System.simulate`), ``samples`` equally
            spaced output times.
        ``verify``
            Averaging, Floquet analysis and direct simulation compared over an (A, ω) grid
            (:func:`kapitza.verify`; the upright plain pendulum:
            :meth:`KapitzaPendulum.verify`, which adds the next order),
            :class:`~kapitza.Verification`.  ``fit_order = true`` also fits the order of
            averaging along its default line.
        ``continuation``
            The branch of periodic orbits through ``about`` followed in ``parameter``
            (:func:`kapitza.continuation`; a drive that leaves no equilibrium starts on
            the periodic orbit found by :func:`kapitza.periodic_orbit`), with
            ``switch = true`` the branches born at its period doublings, pitchforks and
            transcritical points (:meth:`kapitza.results.Branch.switch`):
            ``Branches``; tables ``continuation`` and
            ``continuation_bifurcations``.
        ``bifurcation_diagram``
            Strobe samples after a transient over the parameter's values × the starts
            (:func:`kapitza.chaos.bifurcation_diagram`, ``BifurcationDiagram``).
        ``lyapunov``
            The Lyapunov exponents of the trajectory from the initial state, with their
            error (:func:`kapitza.chaos.lyapunov`, ``LyapunovSpectrum``).

        Every table carries a ``method`` column naming how it was computed
        (:attr:`SceneResults.methods`; exact and averaging never stand in for each
        other).

        ``about`` (Floquet, maps, windows, measurements): "inverted" (every coordinate π),
        "hanging" (0), a list of coordinate values, or "auto" (the default): the
        persisting state nearest the initial state (each coordinate's nearest multiple of
        π) — or, for a drive that leaves no equilibrium, the stable state of averaging
        nearest it.
        """
        t0 = time.perf_counter()
        check_scene_grids(self)
        results, methods = {}, {}
        for name, settings in self.spec.analyses.items():
            try:
                results[name] = POINT[name](self, settings, progress)
            except ValueError as e:
                if type(e) is not ValueError:
                    raise
                raise ValueError(f"{self.spec.source}: analysis {name!r}: {e}") from e
            methods[name] = method_of(name, self, settings, results[name])
        written = []
        out = self.spec.output
        if write and out["directory"] is not None and results:
            written = write_outputs(self, _tables_with_metadata(self, results, methods),
                                    out["directory"], out["formats"])
        return SceneResults(scene=self, results=results, sweeps={},
                            written=tuple(written), seconds=time.perf_counter() - t0,
                            methods=methods)

    def sweep(self, analysis: str | None = None, *, directory=None, executor=None,
              worker_threads: int = 1, tile_points: int | None = None,
              tile_seconds: float = 0.5, progress=None, csv: bool | None = None,
              wait=False):
        """Run ``analysis`` over the scene's ``[sweep]`` grid, tile by tile, resumable.

        Parameters
        ----------
        analysis : str, optional
            One of the scene's swept analyses (default: the only one).
        directory : path, optional
            Where the dataset's directory goes (default ``[output] directory``, else
            ``<scene file's stem>_output`` beside the file).  The dataset is the
            subdirectory ``<analysis>-<key>``, ``key`` a hash of the scene, the analysis
            and the code: a changed scene or code starts a new dataset.
        executor, worker_threads, tile_points, tile_seconds, progress
            See ``kapitza.scenes._sweep.run_sweep`` (``tile_points`` default: the scene's
            ``[sweep] tile_points``, else calibrated).
        csv : bool, optional
            Also write ``<dataset>.csv`` (default: "csv" in ``[output] formats``).
        wait : bool or float
            Another sweep writing the same dataset: refuse naming it (False), wait for it
            (True) or at most this many seconds.

        Returns
        -------
        kapitza.SweepResult
        """
        s = self.spec.sweep
        if not s:
            raise ValueError(f"{self.spec.source} has no [sweep] table.")
        if analysis is None:
            if len(s["analyses"]) != 1:
                raise ValueError(f"the scene sweeps {list(s['analyses'])}; name one: "
                                 "scene.sweep('measure').")
            analysis = s["analyses"][0]
        if analysis not in s["analyses"]:
            raise ValueError(f"the scene sweeps {list(s['analyses'])}, not {analysis!r} (the "
                             f"sweepable analyses are {list(SWEEPABLE)}; name it in [analyses] "
                             "and in [sweep] analyses).")
        base = Path(directory) if directory is not None else self._output_directory()
        fingerprint = code_fingerprint(self._user_module)
        key = self.key(analysis)
        path = base / f"{analysis}-{content_key(key, fingerprint)[:12]}"
        meta = sweep_metadata(self, analysis, key)
        return sweeps.run_sweep(
            _SweepWork(self.spec.text, self.spec.source, analysis), s["axes"], path, key=key,
            fingerprint=fingerprint, metadata=meta,
            tile_points=tile_points if tile_points is not None else s["tile_points"],
            tile_seconds=tile_seconds, executor=executor, worker_threads=worker_threads,
            progress=progress, csv=("csv" in self.spec.output["formats"]) if csv is None else csv,
            label=f"{analysis} sweep", wait=wait)

    def _output_directory(self) -> Path:
        if self.spec.output["directory"] is not None:
            return self.spec.output["directory"]
        if self.path is None:
            return Path.cwd() / "scene_output"
        return self.path.parent / f"{self.path.stem}_output"


@dataclass(frozen=True, eq=False)
class SceneResults:
    """What :meth:`Scene.run` computed.

    Attributes
    ----------
    scene : Scene
    results : dict
        Analysis name → its result at the scene's point (the types named in the
        :meth:`Scene.run` notes), in the file's order.
    sweeps : dict
        Analysis name → :class:`kapitza.SweepResult` (empty from :meth:`Scene.run`, which
        does not run the ``[sweep]``: :meth:`Scene.sweep` does).
    written : tuple of Path
        Files written, the manifest ``_run.json`` last (empty with ``write=False``).
    seconds : float
    methods : dict
        Analysis name → how it was computed, "<family>: <detail>" (e.g. "floquet:
        Mathieu characteristic values", "averaging: order 1, closed form"); every table
        carries it as its ``method`` column.
    """

    scene: Scene
    results: dict
    sweeps: dict
    written: tuple = ()
    seconds: float = field(default=0.0)
    methods: dict = field(default_factory=dict)

    def __getitem__(self, name):
        if name in self.results:
            return self.results[name]
        if name in self.sweeps:
            return self.sweeps[name]
        raise KeyError(f"no result {name!r}; computed: {list(self.results) + list(self.sweeps)}.")

    def tables(self) -> dict:
        """Every result as a DataFrame: analysis name → table (a sweep's is tidy, one or
        more rows per point), each with its ``method`` column; a continuation adds
        ``continuation_bifurcations``."""
        out = {}
        for name, r in self.results.items():
            out.update(_result_tables(name, r, self.methods.get(name)))
        out.update({name: r.to_dataframe() for name, r in self.sweeps.items()})
        return out

    def to_dataframe(self, name: str | None = None):
        """The table of analysis ``name`` (default: the only one computed)."""
        tables = self.tables()
        if name is None:
            if len(tables) != 1:
                raise ValueError(f"name one of {list(tables)}.")
            name = next(iter(tables))
        return tables[name]

    def to_xarray(self, name: str):
        """The :class:`xarray.Dataset` of analysis ``name``: a sweep's
        (:meth:`SweepResult.to_xarray`) or a gridded result's (a map, a window, a
        verification, …: its ``to_xarray()``).  Needs ``pip install "kapitza[xarray]"``.

        Raises
        ------
        KeyError
            No analysis ``name`` was computed.
        ValueError
            Its result is not a grid (it has no ``to_xarray``).
        """
        result = self[name]
        if not hasattr(result, "to_xarray"):
            gridded = [k for k, r in {**self.results, **self.sweeps}.items()
                       if hasattr(r, "to_xarray")]
            raise ValueError(f"the result of {name!r} ({type(result).__name__}) is not a grid "
                             f"and has no Dataset; these have: {gridded}.")
        return result.to_xarray()

    def _repr_html_(self) -> str:
        from ..results import html_card
        rows = [(name, f"{type(r).__name__} — {self.methods.get(name, '')}")
                for name, r in self.results.items()]
        rows += [(f"{name} (sweep)", f"{r.size} points, {r.path}")
                 for name, r in self.sweeps.items()]
        rows.append(("time", f"{self.seconds:.3g} s; {len(self.written)} files written"))
        return html_card("SceneResults", self.scene.spec.title or "", rows=rows,
                         notes=["results[name] displays one result"])


def _table(result, method=None):
    import pandas as pd
    frame = result.to_dataframe()
    if not isinstance(frame.index, pd.RangeIndex) or frame.index.name is not None:
        frame = frame.reset_index()        # e.g. a trajectory's t, a periodic orbit's coordinate
    if method is not None:
        frame["method"] = method
    return frame


def _result_tables(name, result, method=None) -> dict:
    """The tables of one analysis's result: ``name`` → its table, and for a continuation
    ``<name>_bifurcations`` too; each with the ``method`` column."""
    out = {name: _table(result, method)}
    if hasattr(result, "bifurcation_table"):
        extra = result.bifurcation_table()
        if method is not None:
            extra["method"] = method
        out[f"{name}_bifurcations"] = extra
    return out


def _tables_with_metadata(scene, results, methods) -> dict:
    """Every table of the results with the record it carries: name → (frame, metadata)."""
    out = {}
    for analysis, r in results.items():
        method = methods.get(analysis)
        meta = table_metadata(scene, analysis, method=method, result=r)
        for name, frame in _result_tables(analysis, r, method).items():
            out[name] = (frame, meta)
    return out


def _plain(x):
    """``x`` in JSON's terms for the key (axes as {name, kind, number of values and the
    SHA-256 of their float64 bytes}, tuples as lists)."""
    if isinstance(x, Axis):
        # a digest, not the values as JSON text: an axis of 10⁸ values (allowed by the
        # memory check of its reading) took ~20 bytes a value of text and minutes
        values = np.asarray(x.values, dtype=float)
        return {"name": x.name, "kind": x.kind, "num": int(values.size),
                "values_sha256": hashlib.sha256(values.tobytes()).hexdigest()}
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, Path):
        return str(x)
    return x



# -- the analyses over a sweep's tile -----------------------------------------------------------

_BUILD_LOCK = threading.Lock()


@functools.lru_cache(maxsize=8)
def _cached_scene(text, source):
    return Scene(read_scene_text(text, source))


@dataclass(frozen=True)
class _SweepWork:
    """One analysis over a tile of a scene's sweep (picklable: a cluster's workers rebuild
    the scene from its text, once per process)."""

    text: str
    source: str
    analysis: str

    def __call__(self, columns, points):
        with _BUILD_LOCK:           # a worker's threads build the scene and load its kernels once
            scene = _cached_scene(self.text, self.source)
            _ = scene.system.kernels
        params, q0, qdot0 = tile_inputs(scene, columns, len(points))
        settings = scene.spec.analyses.get(self.analysis, {})
        frame = GRID[self.analysis](scene, settings, params, q0, qdot0)
        if "point" in frame:            # several rows per point, numbered in the tile
            local = frame.pop("point").to_numpy(dtype=np.int64)
        elif len(frame) == len(points):
            local = np.arange(len(points))
        else:
            raise RuntimeError(f"{self.analysis}: {len(frame)} rows for {len(points)} points "
                               "and no 'point' column")
        frame.insert(0, "point", points[local])
        frame["method"] = method_of(self.analysis, scene, settings)
        return frame


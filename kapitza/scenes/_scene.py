"""Scenes: a set-up stated in a file, built into a System, analysed as the file asks.

:class:`Scene` is a checked scene file (:mod:`kapitza.scene_file` states the schema and
the checks): ``Scene.from_toml(path)``, then ``scene.system`` is the
:class:`lagrange_core.System` with only the effects the file names
(:func:`lagrange_core.effects.build`), and ``scene.run()`` computes the analyses of
``[analyses]`` — only those — at the scene's point, and each sweepable one that
``[sweep]`` names over the sweep's grid (:mod:`kapitza.sweep`).

Which method each analysis uses
-------------------------------
The best the effects allow (:func:`lagrange_core.effects.capabilities`); "the plain
pendulum" is the catalogue's pendulum with gravity, a drive along the vertical or the
horizontal (one harmonic) and at most damping, which has closed forms and exact maps.

``averaging``
    Plain pendulum: the closed forms, order 1 or 2 (:meth:`KapitzaPendulum.averaged`,
    :class:`~kapitza.results.PendulumAveraging`).  Otherwise the general first-order
    averaging (:func:`kapitza.average` ``.predict``, :class:`~kapitza.results.AveragingPrediction`).
``floquet``
    A drive along the vertical keeps θ = 0, π: :func:`kapitza.floquet_point` about
    ``about`` (:class:`~kapitza.results.FloquetResult`).  A drive off the vertical leaves
    no equilibrium: the periodic orbit by Newton shooting (:func:`kapitza.periodic_orbit`,
    :class:`~kapitza.results.PeriodicOrbit`).
``stability_map``, ``window``
    Plain pendulum: the exact Mathieu map and window
    (:func:`kapitza.mathieu.pendulum_stability_map`, ``pendulum_stability_window``).
    Otherwise the monodromy map (:func:`kapitza.stability_map`) and the averaging window
    (:meth:`kapitza.AveragedSystem.stability_window`).
``measure``
    Direct simulation measured from strobe samples (:func:`kapitza.measure`,
    :class:`~kapitza.results.Measurement`), integrated by the method the effects allow
    (RKN 12 without velocity forces, DOP853 with them).
``simulate``
    One trajectory (:meth:`lagrange_core.System.simulate`), ``samples`` equally spaced
    output times.
``verify``
    Averaging, Floquet analysis and direct simulation compared over an (A, ω) grid
    (:func:`kapitza.verify`; the upright plain pendulum: :meth:`KapitzaPendulum.verify`,
    which adds the next order), :class:`~kapitza.results.Verification`.  ``fit_order =
    true`` also fits the order of averaging along its default line.

``about`` (Floquet, maps, windows, measurements): "inverted" (every coordinate π),
"hanging" (0), a list of coordinate values, or "auto" (the default): the persisting
state nearest the initial state (each coordinate's nearest multiple of π) — or, for
a drive that leaves no equilibrium, the stable state of averaging nearest it.

Examples
--------
>>> import kapitza
>>> scene = kapitza.Scene.example("kapitza_pendulum")
>>> scene.system.parameters                  # damping named: gamma is a parameter
('A', 'g', 'gamma', 'l', 'm', 'omega')
>>> sorted(scene.analyses)
['averaging', 'floquet']
"""
from __future__ import annotations

import functools
import importlib
import json
import math
import pkgutil
import threading
import time
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from lagrange_core import effects as fx
from lagrange_core.module_store import content_key, source_fingerprint
from lagrange_core.progress import interrupt_requested

from . import _sweep as sweeps
from ..averaging import average
from ..floquet import floquet_grid, floquet_point, stability_map
from ..pendulum import KapitzaPendulum
from ..simulation import periodic_orbit
from ._file import SWEEPABLE, Axis, SceneSpec, read_scene, read_scene_text

__all__ = ["Scene", "SceneResults", "code_fingerprint", "example_scenes"]

#: Modules and subpackages whose code does not change what a scene computes (figures, the
#: command line, installation, the cluster executor); everything else, at any depth, counts.
_NOT_FINGERPRINTED = ("kapitza.figures", "kapitza.cli", "kapitza.warmup", "kapitza.__main__",
                      "kapitza.scenes._sweep_dask", "lagrange_core.warmup")


def _excluded(name: str) -> bool:
    return any(name == x or name.startswith(x + ".") for x in _NOT_FINGERPRINTED)


def fingerprinted_modules() -> list:
    """Every module of lagrange_core and kapitza whose code can change a number: the
    packages walked recursively (subpackages and their private modules included), less
    ``_NOT_FINGERPRINTED``."""
    mods, todo = [], ["lagrange_core", "kapitza"]
    while todo:
        package = importlib.import_module(todo.pop(0))
        mods.append(package)
        for info in pkgutil.iter_modules(package.__path__, prefix=f"{package.__name__}."):
            if _excluded(info.name):
                continue
            if info.ispkg:
                todo.append(info.name)
            else:
                mods.append(importlib.import_module(info.name))
    return mods


@functools.lru_cache(maxsize=None)
def _package_fingerprint() -> str:
    mods = fingerprinted_modules()
    return source_fingerprint(*mods)


def code_fingerprint(user_module: str | None = None) -> str:
    """The fingerprint of the code that computes a scene's results: every module of
    lagrange_core and kapitza that can change a number (docstrings and comments
    excluded, :func:`lagrange_core.module_store.source_fingerprint`), and a user rig's
    module."""
    base = _package_fingerprint()
    if user_module is None:
        return base
    return content_key(base, source_fingerprint(importlib.import_module(user_module)))


def example_scenes() -> dict:
    """The scene files that ship with kapitza: name → path."""
    folder = resources.files("kapitza") / "scenes"
    return {Path(p.name).stem: Path(str(p)) for p in sorted(folder.iterdir(),
                                                             key=lambda p: p.name)
            if p.name.endswith(".toml")}


# -- the scene ----------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Scene:
    """A checked scene file (:mod:`kapitza.scene_file`) and what it builds.

    Build it with :meth:`from_toml`, :meth:`from_text` or :meth:`example`.

    Attributes
    ----------
    spec : kapitza.scene_file.SceneSpec
        Everything the file says, checked, with defaults filled in.
    """

    spec: SceneSpec

    @classmethod
    def from_toml(cls, path) -> "Scene":
        """Read and check the scene file at ``path``; raises
        :class:`~kapitza.scene_file.SceneError` with every problem found."""
        return cls(read_scene(path))

    @classmethod
    def from_text(cls, text: str, source: str = "<text>") -> "Scene":
        """A scene from TOML text (``source`` names it in messages)."""
        return cls(read_scene_text(text, source))

    @classmethod
    def example(cls, name: str) -> "Scene":
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
        return self.spec.effects

    @property
    def analyses(self) -> dict:
        """The analyses asked for and their settings."""
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
        """The plain pendulum as a :class:`KapitzaPendulum`, or None (module docstring)."""
        kinds = {type(e) for e in self.effects}
        drive = self._drive
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
    def _drive(self):
        return next((e for e in self.effects if isinstance(e, fx.PivotDrive)), None)

    @property
    def _user_module(self):
        name = self.spec.rig_name
        return name.partition(":")[0] if ":" in name else None

    def key(self, analysis: str | None = None) -> str:
        """Hash of what the scene's numbers depend on (the statement, the parameters, the
        initial state, and the settings and sweep of ``analysis``, or of every analysis);
        the output place and the title are not part of it."""
        parts = {"statement": self.system.statement_key(), "params": self.spec.params,
                 "initial": self.spec.initial}
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
        return {"axes": [[a.name, a.kind, list(a.values)] for a in s["axes"]],
                "targets": s["targets"], "tile_points": s["tile_points"]}

    def __repr__(self):
        return (f"<Scene {self.spec.source}: {self.system.name}; analyses "
                f"{list(self.spec.analyses)}>")

    # -- running -------------------------------------------------------------------------
    def run(self, *, progress=None, executor=None, worker_threads: int = 1,
            write: bool = True) -> "SceneResults":
        """Compute the analyses the scene asks for.

        Those named in ``[sweep] analyses`` run over the sweep's grid (:meth:`sweep`), the
        others once at the scene's point.  With ``[output] directory`` (and ``write``)
        every table is written there: ``<analysis>.parquet`` (and ``.csv``) for the
        point analyses, a Parquet dataset per sweep.

        Parameters
        ----------
        progress : None or bool
            Progress bars of sweeps and long grids (None: when stderr is a terminal).
        executor, worker_threads
            Where sweeps run (:func:`kapitza.sweep.run_sweep`).
        write : bool
            Write the output tables.

        Returns
        -------
        SceneResults
        """
        t0 = time.perf_counter()
        swept = self.spec.sweep["analyses"] if self.spec.sweep else ()
        results, sweep_results = {}, {}
        for name, settings in self.spec.analyses.items():
            if name in swept:
                continue
            try:
                results[name] = _POINT[name](self, settings, progress)
            except ValueError as e:
                if type(e) is not ValueError:
                    raise
                raise ValueError(f"{self.spec.source}: analysis {name!r}: {e}") from e
        written = []
        out = self.spec.output
        if write and out["directory"] is not None and results:
            written = _write_tables(self, results, out["directory"], out["formats"])
        for name in swept:
            sweep_results[name] = self.sweep(name, executor=executor,
                                             worker_threads=worker_threads, progress=progress)
            written.append(sweep_results[name].path)
        return SceneResults(scene=self, results=results, sweeps=sweep_results,
                            written=tuple(written), seconds=time.perf_counter() - t0)

    def sweep(self, analysis: str | None = None, *, directory=None, executor=None,
              worker_threads: int = 1, tile_points: int | None = None,
              tile_seconds: float = 0.5, progress=None, csv: bool | None = None):
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
            See :func:`kapitza.sweep.run_sweep` (``tile_points`` default: the scene's
            ``[sweep] tile_points``, else calibrated).
        csv : bool, optional
            Also write ``<dataset>.csv`` (default: "csv" in ``[output] formats``).

        Returns
        -------
        kapitza.sweep.SweepResult
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
        meta = {"scene": self.spec.text, "source": self.spec.source, "analysis": analysis,
                "settings": _plain(self.spec.analyses.get(analysis, {})),
                "system": self.system.name,
                "parameters": self.spec.params, "initial": self.spec.initial,
                "targets": s["targets"], "scene_key": key}
        return sweeps.run_sweep(
            _SweepWork(self.spec.text, self.spec.source, analysis), s["axes"], path, key=key,
            fingerprint=fingerprint, metadata=meta,
            tile_points=tile_points if tile_points is not None else s["tile_points"],
            tile_seconds=tile_seconds, executor=executor, worker_threads=worker_threads,
            progress=progress, csv=("csv" in self.spec.output["formats"]) if csv is None else csv,
            label=f"{analysis} sweep")

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
        :mod:`kapitza.scene` docstring), in the file's order.
    sweeps : dict
        Analysis name → :class:`kapitza.sweep.SweepResult`.
    written : tuple of Path
        Files and datasets written.
    seconds : float
    """

    scene: Scene
    results: dict
    sweeps: dict
    written: tuple = ()
    seconds: float = field(default=0.0)

    def __getitem__(self, name):
        if name in self.results:
            return self.results[name]
        if name in self.sweeps:
            return self.sweeps[name]
        raise KeyError(f"no result {name!r}; computed: {list(self.results) + list(self.sweeps)}.")

    def tables(self) -> dict:
        """Every result as a DataFrame: analysis name → table (a sweep's is tidy, one or
        more rows per point)."""
        out = {name: _table(r) for name, r in self.results.items()}
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


def _table(result):
    import pandas as pd
    frame = result.to_dataframe()
    if not isinstance(frame.index, pd.RangeIndex) or frame.index.name is not None:
        frame = frame.reset_index()        # e.g. a trajectory's t, a periodic orbit's coordinate
    return frame


def _write_tables(scene, results, directory, formats):
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    meta = {"scene": scene.spec.text, "source": scene.spec.source,
            "settings": _plain(scene.spec.analyses), "system": scene.system.name, "parameters": scene.spec.params,
            "initial": scene.spec.initial, "scene_key": scene.key(),
            "fingerprint": code_fingerprint(scene._user_module),
            "versions": sweeps.package_versions()}
    written = []
    for name, r in results.items():
        frame = _table(r)
        if "parquet" in formats:
            written.append(sweeps.write_table(frame, directory / f"{name}.parquet",
                                              dict(meta, analysis=name)))
        if "csv" in formats:
            path = directory / f"{name}.csv"
            sweeps.write_text(path, frame.to_csv(index=False))
            written.append(path)
    return written


def _plain(x):
    """``x`` in JSON's terms (axes as {name, kind, values}, tuples as lists)."""
    if isinstance(x, Axis):
        return {"name": x.name, "kind": x.kind, "values": list(x.values)}
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, Path):
        return str(x)
    return x


# -- where the analyses start ---------------------------------------------------------------

def _about(scene, setting, q0=None):
    """The state an analysis is about, (n,) or (points, n) coordinates."""
    n = scene.system.n_dof
    q0 = scene.q0 if q0 is None else np.asarray(q0, dtype=float)
    if setting == "inverted":
        return np.full(n, math.pi)
    if setting == "hanging":
        return np.zeros(n)
    if setting not in (None, "auto"):
        about = np.asarray(setting, dtype=float)
        if about.shape != (n,):
            raise ValueError(f"about needs {n} coordinate values "
                             f"({list(scene.system.coordinates)}), got {list(setting)}.")
        return about
    if scene.capabilities["floquet"] == "equilibrium":
        return math.pi * np.round(q0 / math.pi)
    return _averaged_state(scene, scene.spec.params, q0)


def _averaged_state(scene, params, q0):
    """The stable state of averaging nearest ``q0`` (mod 2π) at scalar ``params``; the
    nearest multiple of π where averaging finds none."""
    stable = [e.about for e in average(scene.system).predict(params, warn=False).equilibria
              if e.stable]
    if not stable:
        return math.pi * np.round(q0 / math.pi)
    turns = [s + 2 * math.pi * np.round((q0 - s) / (2 * math.pi)) for s in stable]
    return min(turns, key=lambda s: float(np.max(np.abs(s - q0))))


def _pendulum_state(scene, about):
    """"inverted" or "hanging": the pendulum's persisting state ``about`` names or is nearest."""
    if about in ("inverted", "hanging"):
        return about
    theta = float(_about(scene, about)[0])
    return "inverted" if abs(math.cos(theta) + 1) < 1e-9 else "hanging"


def _frequency_axis(settings):
    if "frequency_hz" in settings:
        return 2 * math.pi * np.asarray(settings["frequency_hz"].values)
    return np.asarray(settings["omega"].values)


# -- the analyses at the scene's point ---------------------------------------------------------

def _averaging(scene, s, progress):
    p = scene.spec.params
    pend = scene.pendulum
    if pend is not None:
        return pend.averaged(p["A"], p["omega"], order=s.get("order", 1), warn=False)
    if s.get("order", 1) != 1:
        raise ValueError("order 2 is the plain pendulum's closed form; general averaging is "
                         "first order.")
    return average(scene.system).predict(p, warn=False)


def _floquet(scene, s, progress):
    p = scene.spec.params
    tol = s.get("tol", 1e-10)
    if scene.capabilities["floquet"] == "equilibrium":
        return floquet_point(scene.system, p, _about(scene, s.get("about")), tol=tol)
    return periodic_orbit(scene.system, p, _about(scene, s.get("about")), tol=tol)


def _stability_map(scene, s, progress):
    A = np.asarray(s["A"].values)
    omega = _frequency_axis(s)
    about = s.get("about", "auto")
    pend = scene.pendulum
    if pend is not None and about in ("inverted", "hanging", "auto"):
        return pend.stability_map(A, omega, about=_pendulum_state(scene, about),
                                  tol=s.get("tol", 1e-10), progress=progress)
    return stability_map(scene.system, A, omega, scene.spec.params, _about(scene, about),
                         tol=s.get("tol", 1e-8), progress=progress)


def _window(scene, s, progress):
    omega = _frequency_axis(s)
    about = s.get("about", "auto")
    pend = scene.pendulum
    if pend is not None and about in ("inverted", "hanging", "auto"):
        return pend.stability_window(omega, about=_pendulum_state(scene, about))
    return average(scene.system).stability_window(omega, _about(scene, about),
                                                  params=scene.spec.params)


def _measure(scene, s, progress):
    from ..simulation import measure
    return measure(scene.system, scene.spec.params, _about(scene, s.get("about")), scene.q0,
                   scene.qdot0, periods=s.get("periods", 1000), band=s.get("band", math.pi / 2),
                   rtol=s.get("rtol", 1e-9), progress=progress)


def _span(scene, s, omega):
    if "duration" in s:
        return s["duration"]
    if "omega" in scene.spec.params:
        return s.get("periods", 100) * 2 * math.pi / omega
    return 10.0


def _simulate(scene, s, progress):
    t1 = _span(scene, s, scene.spec.params.get("omega"))
    t_eval = np.linspace(0.0, t1, s.get("samples", 1001))
    return scene.system.simulate(scene.q0, scene.qdot0, (0.0, t1), scene.spec.params,
                                 method=s.get("method"), rtol=s.get("rtol", 1e-9), t_eval=t_eval)


def _verify(scene, s, progress):
    from ..verification import verify
    A = np.asarray(s["A"].values)[:, None]
    omega = _frequency_axis(s)[None, :]
    common = dict(periods=s.get("periods", 1000), tol=s.get("tol", 1e-10),
                  rtol=s.get("rtol", 1e-9), line=None if s.get("fit_order") else False,
                  progress=progress)
    about = s.get("about", "auto")
    pend = scene.pendulum
    if pend is not None and _pendulum_state(scene, about) == "inverted" \
            and "offset" not in s and "band" not in s:
        near = 0 < abs(scene.q0[0] - math.pi) < math.pi / 2     # released near the upright
        return pend.verify(A, omega, theta0=scene.q0[0] if near else math.pi - 0.01,
                           theta_dot0=scene.qdot0[0] if near else 0.0, **common)
    return verify(scene.system, scene.spec.params, _about(scene, about), A=A, omega=omega,
                  offset=s.get("offset", 0.01), band=s.get("band", math.pi / 2), **common)


_POINT = {"averaging": _averaging, "floquet": _floquet, "stability_map": _stability_map,
          "window": _window, "measure": _measure, "simulate": _simulate, "verify": _verify}


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
            scene.system.kernels
        params, q0, qdot0 = _tile_inputs(scene, columns, len(points))
        settings = scene.spec.analyses.get(self.analysis, {})
        frame = _GRID[self.analysis](scene, settings, params, q0, qdot0)
        if "point" in frame:            # several rows per point, numbered in the tile
            local = frame.pop("point").to_numpy(dtype=np.int64)
        elif len(frame) == len(points):
            local = np.arange(len(points))
        else:
            raise RuntimeError(f"{self.analysis}: {len(frame)} rows for {len(points)} points "
                               "and no 'point' column")
        frame.insert(0, "point", points[local])
        return frame


def _tile_inputs(scene, columns, size):
    params = dict(scene.spec.params)
    q0 = np.tile(scene.q0, (size, 1))
    qdot0 = np.tile(scene.qdot0, (size, 1))
    coords = list(scene.system.coordinates)
    for name, values in columns.items():
        target = scene.spec.sweep["targets"][name]
        if target == "frequency_hz":
            params["omega"] = 2 * math.pi * values
        elif target.startswith("initial."):
            state = target[len("initial."):]
            if state in coords:
                q0[:, coords.index(state)] = values
            else:
                qdot0[:, coords.index(state[:-len("_dot")])] = values
        else:
            params[target] = values
    return params, q0, qdot0


def _point_params(params, i):
    return {k: float(v[i]) if np.ndim(v) else v for k, v in params.items()}


def _drop_params(frame, scene):
    return frame.drop(columns=[c for c in scene.system.parameters if c in frame])


def _grid_simulate(scene, s, params, q0, qdot0):
    t1 = _span(scene, s, params.get("omega"))
    system = scene.system
    grid = system.simulate_grid(q0, qdot0, (0.0, t1), params, method=s.get("method"),
                                rtol=s.get("rtol", 1e-9), energy=bool(
                                    system.kernels.energy_conserved), progress=False)
    return _drop_params(grid.to_dataframe(), scene)


def _grid_measure(scene, s, params, q0, qdot0):
    from ..simulation import measure_grid
    about = s.get("about")
    if about in (None, "auto") and scene.capabilities["floquet"] != "equilibrium":
        about = np.array([_averaged_state(scene, _point_params(params, i), q0[i])
                          for i in range(len(q0))])
    else:
        about = _about(scene, about, q0)
    m = measure_grid(scene.system, params, about, q0, qdot0, periods=s.get("periods", 1000),
                     band=s.get("band", math.pi / 2), rtol=s.get("rtol", 1e-9), progress=False)
    return _drop_params(m.to_dataframe(), scene)


def _grid_floquet(scene, s, params, q0, qdot0):
    import pandas as pd
    size = len(q0)
    if scene.capabilities["floquet"] == "equilibrium":
        g = floquet_grid(scene.system, params, _about(scene, s.get("about")),
                         tol=s.get("tol", 1e-10), progress=False)
        frame = _drop_params(g.to_dataframe(), scene)
        slow = np.asarray(g.omega_slow).reshape(size, -1)
        for k in range(slow.shape[1]):
            frame[f"omega_slow_{k}"] = slow[:, k]
        frame["flags"] = ["; ".join(f) for f in g.flags]
        return frame
    about = s.get("about", "auto")
    rows = []
    n = scene.system.n_dof
    for i in range(size):
        if interrupt_requested():
            raise KeyboardInterrupt
        p = _point_params(params, i)
        row = {}
        try:
            guess = _averaged_state(scene, p, q0[i]) if about == "auto" \
                else _about(scene, about)
            o = periodic_orbit(scene.system, p, guess, tol=s.get("tol", 1e-10))
            slow = np.atleast_1d(o.omega_slow)
            row.update(stable=o.stable, max_abs_multiplier=float(np.max(np.abs(o.multipliers))),
                       residual=o.residual, iterations=o.iterations, error="")
            row.update({f"q_mean_{c}": o.q_mean[j] for j, c in enumerate(scene.system.coordinates)})
            row.update({f"amplitude_{c}": o.amplitude[j]
                        for j, c in enumerate(scene.system.coordinates)})
            row.update({f"omega_slow_{k}": slow[k] for k in range(n)})
        except ValueError as e:
            row.update(stable=False, max_abs_multiplier=math.nan, residual=math.nan,
                       iterations=-1, error=str(e))
            row.update({f"q_mean_{c}": math.nan for c in scene.system.coordinates})
            row.update({f"amplitude_{c}": math.nan for c in scene.system.coordinates})
            row.update({f"omega_slow_{k}": math.nan for k in range(n)})
        rows.append(row)
    return pd.DataFrame(rows)


def _grid_averaging(scene, s, params, q0, qdot0):
    import pandas as pd
    size = len(q0)
    pend = scene.pendulum
    if pend is not None and all(np.ndim(params[k]) == 0 for k in ("l", "g")) \
            and np.ndim(params.get("gamma", 0.0)) == 0:
        A, w = np.broadcast_arrays(np.asarray(params["A"], float),
                                   np.asarray(params["omega"], float) + np.zeros(size))
        res = pend.averaged(A, w, order=s.get("order", 1), warn=False)
        frame = res.to_dataframe().drop(columns=["A", "omega"])
        frame.insert(0, "point", np.tile(np.arange(size), len(res.equilibria)))
        return frame.sort_values("point", kind="stable").reset_index(drop=True)
    if s.get("order", 1) != 1:
        raise ValueError("order 2 is the plain pendulum's closed form (with l, g and gamma not "
                         "swept); general averaging is first order.")
    avg = average(scene.system)
    coords = scene.system.coordinates
    rows = []
    for i in range(size):
        if interrupt_requested():
            raise KeyboardInterrupt
        for k, e in enumerate(avg.predict(_point_params(params, i), warn=False).equilibria):
            for j in range(len(coords)):
                row = {"point": i, "equilibrium": k}
                row.update({f"about_{c}": float(e.about[a]) for a, c in enumerate(coords)})
                row.update(mode=j, omega_squared=float(e.omega_squared[j]),
                           frequency=float(e.frequencies[j]),
                           damped_frequency=float(e.damped_frequencies[j]), stable=e.stable,
                           decay_rate=e.decay_rate, valid=e.valid)
                rows.append(row)
    return pd.DataFrame(rows) if rows else pd.DataFrame({"point": np.zeros(0, np.int64)})


_GRID = {"simulate": _grid_simulate, "measure": _grid_measure, "floquet": _grid_floquet,
         "averaging": _grid_averaging}

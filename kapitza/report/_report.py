"""``kapitza report``: one self-contained folder that shows what the toolkit computes.

:func:`build_report` runs a scene (by default the embedded ``scenes/report.toml``: a
1 m pendulum shaken vertically) through every analysis and writes

``DIR/index.html``
    One page, no JavaScript, no external resource (inline CSS, relative links): a
    header saying what was computed (scene, parameters, versions, date, wall time per
    section), one section per analysis with its figure and a caption stating the
    finding in numbers, and a table of the data files.
``DIR/figures/*.png`` (and the animation ``*.gif``)
``DIR/data/*.parquet`` and ``*.csv``
    Every table shown or drawn, in both formats.

The sections, in order (each says on the page why it is skipped where it does not apply):

``potential``
    The effective potential U_eff(θ)/m at the scene's drive (the pendulum's closed form,
    first-order averaging) with its equilibria, and the upright state's slow frequency
    by averaging and by Floquet analysis.
``map``
    The exact stability map over (A, ω) with the exact boundaries and the averaging
    prediction drawn over it: the pendulum's Mathieu map and exact window
    (:meth:`KapitzaPendulum.stability_map`, ``stability_window``); any other system's
    monodromy map and boundary curves (:func:`kapitza.floquet.stability_map`,
    :func:`kapitza.floquet.boundaries`) with its averaging window.
``spots``
    Direct simulations at a handful of (A, ω) points marked on the map: stayed up or
    fell, and whether that agrees with Floquet analysis (:meth:`KapitzaPendulum.measure_grid`,
    :func:`kapitza.measure_grid`).
``slow``
    The slow frequency Ω along A at the scene's ω: averaging (first and, for the
    pendulum, next order), Floquet and the measured Ω (a verification along a line).
``verification``
    :meth:`KapitzaPendulum.verify` / :func:`kapitza.verify` over a small (A, ω) grid:
    agreement counts, every disagreement with its distance to the nearest boundary, the
    measured order of averaging.
``work_precision``
    What accuracy costs in time (:func:`lagrange_core.accuracy_cost.work_precision`).
``animation``
    A GIF of the stabilised inverted pendulum beside one that falls
    (:func:`kapitza.animation.pendulum_animation`); for another planar chain, the
    scene's own system under its drive (:func:`kapitza.animation.system_animation`).

Progress goes to stderr, one line per section with its elapsed time.  Ctrl-C stops the
running section (within a compiled chunk, ≈ 0.25 s), writes the page with the finished
sections and names the missing ones, and raises :class:`ReportInterrupted` (the CLI
exits with 130).  A section that fails is shown on the page with its error and the
others still run (:attr:`Report.failed`).

Time (2 shared cores, measured 2026-11-23): the full default report takes 93 s on a cold
cache, compilation included (124 s under a load average of 4), and 22 s once compiled,
most of it writing the GIF; ``quick=True`` ≈ 15 s compiled.
"""
from __future__ import annotations

import contextlib
import datetime as _dt
import html
import math
import platform
import sys
import signal
import threading
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["build_report", "Report", "ReportSection", "ReportInterrupted", "SECTIONS"]

#: The report's sections, in order: name → heading.
SECTIONS = {
    "potential": "Effective potential",
    "map": "Stability map: exact boundaries and the averaging prediction",
    "spots": "Direct-simulation spot checks on the map",
    "slow": "Slow frequency: predicted against measured",
    "verification": "Verification summary",
    "work_precision": "What accuracy costs in time",
    "animation": "Animation: stabilised and falling",
}


@dataclass(frozen=True)
class ReportSection:
    """One section of a report.

    Attributes
    ----------
    name, title : str
        Key (:data:`SECTIONS`) and heading.
    status : {"done", "skipped", "failed", "interrupted", "not run"}
        "skipped": does not apply to the scene (``reason`` says why); "not run": an
        interruption came first.
    seconds : float
        Wall time (s; NaN if not run).
    figure : Path or None
        The PNG (or GIF), relative to the report folder.
    caption : str
        The finding in numbers.
    reason : str
        Why it was skipped, the error, or what interrupted it.
    tables : tuple of str
        Names of its data tables (``data/<name>.parquet`` and ``.csv``).
    notes : tuple of str
        The warnings its computations gave (shown on the page under the caption).
    """

    name: str
    title: str
    status: str
    seconds: float = math.nan
    figure: Path | None = None
    caption: str = ""
    reason: str = ""
    tables: tuple = ()
    notes: tuple = ()


@dataclass(frozen=True)
class Report:
    """What :func:`build_report` wrote.

    Attributes
    ----------
    out : Path
        The report folder.
    index : Path
        Its ``index.html``.
    scene : str
        The scene's source (file path, or "kapitza/scenes/report.toml").
    sections : tuple of ReportSection
        In page order.
    tables : dict name → (Path, Path)
        Every data table: its Parquet and CSV file.
    numbers : dict
        The headline numbers (verification counts, fitted orders, window edges, ...).
    seconds : float
        Total wall time (s).
    quick : bool
        Small grids (tests).
    """

    out: Path
    index: Path
    scene: str
    sections: tuple
    tables: dict
    numbers: dict
    seconds: float
    quick: bool = False

    @property
    def figures(self) -> dict:
        """Section name → figure path (absolute) for every section with one."""
        return {s.name: self.out / s.figure for s in self.sections if s.figure is not None}

    @property
    def failed(self) -> tuple:
        """Names of the sections that raised an error."""
        return tuple(s.name for s in self.sections if s.status == "failed")

    @property
    def missing(self) -> tuple:
        """Names of the sections an interruption left out."""
        return tuple(s.name for s in self.sections if s.status in ("interrupted", "not run"))

    def section(self, name: str) -> ReportSection:
        for s in self.sections:
            if s.name == name:
                return s
        raise KeyError(f"no section {name!r}; the sections are {list(SECTIONS)}.")

    def to_dataframe(self):
        """One row per section: name, title, status, seconds, figure, tables, caption, reason,
        notes."""
        import pandas as pd
        return pd.DataFrame([{"section": s.name, "title": s.title, "status": s.status,
                              "seconds": s.seconds,
                              "figure": None if s.figure is None else str(s.figure),
                              "tables": ", ".join(s.tables), "caption": s.caption,
                              "reason": s.reason, "notes": " | ".join(s.notes)}
                             for s in self.sections])


class ReportInterrupted(KeyboardInterrupt):
    """Ctrl-C during :func:`build_report`: ``.report`` is what was written (the page names
    the missing sections)."""

    def __init__(self, report: Report):
        super().__init__(f"report interrupted; missing sections: {', '.join(report.missing)}")
        self.report = report


#: The integrator of every simulated grid (spot checks, slow frequencies, verification):
#: DOP853 at rtol 1e-9 gives the same classifications and Ω (to 1e-9 relative here) as
#: the default RKN 12 on lanes, and its grid kernel compiles in ≈ 13 s on a cold cache
#: against ≈ 90 s for the lanes kernel: the report's 3-minute budget includes compiling.
_GRID_METHOD = "dop853"


class _Skip(Exception):
    """A section that does not apply: its message is the reason shown on the page."""


# -- the run --------------------------------------------------------------------------------

def _default_scene_path() -> Path:
    from importlib import resources
    return Path(str(resources.files("kapitza") / "scenes" / "report.toml"))


def build_report(scene=None, out="kapitza-report", *, quick: bool = False,
                 progress=None) -> Report:
    """Run a scene through every analysis and write the report folder ``out``.

    Parameters
    ----------
    scene : None, str, Path or kapitza.Scene
        None: the embedded default (``kapitza/scenes/report.toml``); a TOML file; or a
        scene.  Pendulum scenes (vertical or horizontal drive, damping) get every
        section; other systems get the general Floquet map and boundaries, measurements
        and verification (the page says which sections do not apply, and why).  The
        scene's ``[analyses]`` set the grids where given (``stability_map`` the map's
        axes, ``verify`` the verification grid and its periods, ``measure`` the spot
        checks' periods); otherwise ranges around the scene's drive are used.
    out : str or Path
        The folder (created; files of an earlier report there are overwritten).
    quick : bool
        Small grids and short runs (the tests): a few seconds once compiled.
    progress : None, bool or callable
        None or True: one line per section on stderr (and the grids' own progress lines
        when stderr is a terminal); False: quiet; a callable ``progress(message)`` gets
        the lines instead.

    Returns
    -------
    Report

    Raises
    ------
    ReportInterrupted
        On Ctrl-C, after writing the page with the finished sections.
    kapitza.SceneError, ValueError
        A bad scene file, or a scene without a drive.
    """
    from ..scenes import Scene
    t_start = time.perf_counter()
    if scene is None:
        scene = Scene.from_toml(_default_scene_path())
    elif not isinstance(scene, Scene):
        scene = Scene.from_toml(scene)
    drive = scene._drive
    if drive is None or "A" not in scene.params or "omega" not in scene.params:
        raise ValueError(f"{scene.spec.source}: the report is about a driven system; add "
                         "[effects.drive] with an amplitude and a frequency.")
    out = Path(out)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    (out / "data").mkdir(parents=True, exist_ok=True)
    say = _speaker(progress)
    job = _Job(scene=scene, out=out, quick=quick,
               grid_progress=False if progress is False else None)
    say(f"kapitza report: {scene.spec.title or scene.spec.source} -> {out}/"
        + (" (quick)" if quick else ""))
    with _ctrl_c() as ctrl_c:
        done, interrupted = _run_sections(job, say, ctrl_c, t_start)
        report = Report(out=out, index=out / "index.html",
                        scene=str(scene.spec.source), sections=tuple(done.values()),
                        tables=dict(job.tables), numbers=dict(job.numbers),
                        seconds=time.perf_counter() - t_start, quick=quick)
        _write_page(job, done, report.seconds)
    if interrupted:
        say(f"kapitza report: interrupted; kept {out / 'index.html'} with the finished "
            f"sections (missing: {', '.join(report.missing)})")
        raise ReportInterrupted(report)
    say(f"kapitza report: done in {report.seconds:.1f} s: {report.index}")
    return report


@contextlib.contextmanager
def _ctrl_c():
    """Ctrl-C while the report runs: raised at once inside a section ("armed"), only noted
    between sections (the page is never cut in the middle), and always noted in
    ``state["hit"]`` — a computation that catches the KeyboardInterrupt to return its
    finished part (e.g. work_precision) still stops the report after its section.  Our
    own handler also keeps lagrange_core's ``defer_ctrl_c`` from holding the interrupt
    back where no chunk loop would see it."""
    state = {"armed": False, "hit": False}
    if threading.current_thread() is not threading.main_thread():
        yield state
        return

    def handler(signum, frame):
        state["hit"] = True
        if state["armed"]:
            raise KeyboardInterrupt

    old = signal.signal(signal.SIGINT, handler)
    try:
        yield state
    finally:
        signal.signal(signal.SIGINT, old)


def _run_sections(job, say, ctrl_c, t_start):
    """Every section in order; (sections by name, interrupted)."""
    done = {}
    interrupted = False
    for k, (name, title) in enumerate(SECTIONS.items()):
        if interrupted:
            done[name] = ReportSection(name, title, "not run",
                                       reason="the run was interrupted before this section")
            continue
        t0 = time.perf_counter()
        say(f"[{k + 1}/{len(SECTIONS)}] {title} ...")
        caught = []
        try:
            ctrl_c["armed"] = True
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                result = _BUILDERS[name](job)
            status, reason = "done", ""
        except _Skip as e:
            result, status, reason = None, "skipped", str(e)
        except KeyboardInterrupt:
            result, status, reason = None, "interrupted", "interrupted by Ctrl-C"
            interrupted = True
        except Exception as e:          # shown on the page; the other sections still run
            result, status, reason = None, "failed", f"{type(e).__name__}: {e}"
        finally:
            ctrl_c["armed"] = False
        interrupted = interrupted or ctrl_c["hit"]     # held back or caught inside: stop
        dt = time.perf_counter() - t0
        notes = tuple(dict.fromkeys(f"{w.category.__name__}: {w.message}" for w in caught))
        section = ReportSection(name, title, status, seconds=dt, reason=reason, notes=notes)
        if result is not None:
            section = ReportSection(name, title, status, seconds=dt, figure=result.figure,
                                    caption=result.caption, tables=tuple(result.tables),
                                    notes=notes)
        done[name] = section
        say(f"[{k + 1}/{len(SECTIONS)}] {title}: {status}"
            + (f" ({reason})" if status != "done" else "")
            + f", {dt:.1f} s (elapsed {time.perf_counter() - t_start:.1f} s)")
        _write_page(job, done, time.perf_counter() - t_start)
    return done, interrupted


def _speaker(progress):
    if progress is False:
        return lambda message: None
    if callable(progress) and not isinstance(progress, bool):
        return progress

    def say(message):
        print(message, file=sys.stderr, flush=True)
    return say


@dataclass
class _Result:
    figure: Path | None
    caption: str
    tables: list = field(default_factory=list)


@dataclass
class _Job:
    """The scene, where the files go, and what the sections hand each other."""

    scene: object
    out: Path
    quick: bool
    grid_progress: object
    tables: dict = field(default_factory=dict)      # name -> (parquet, csv)
    shown: dict = field(default_factory=dict)       # section -> list of (title, DataFrame)
    numbers: dict = field(default_factory=dict)
    state: dict = field(default_factory=dict)

    # -- the scene's facts ---------------------------------------------------------------
    @property
    def pend(self):
        return self.scene.pendulum

    @property
    def params(self) -> dict:
        return self.scene.params

    @property
    def A(self) -> float:
        return float(self.params["A"])

    @property
    def omega(self) -> float:
        return float(self.params["omega"])

    @property
    def vertical(self) -> bool:
        return bool(self.scene._drive.keeps_vertical_equilibria)

    @property
    def fixed(self) -> dict:
        """The parameters other than the drive's A and ω."""
        return {k: v for k, v in self.params.items() if k not in ("A", "omega")}

    @property
    def about(self):
        """The equilibrium every section is about: upright (every coordinate π)."""
        return np.full(self.scene.system.n_dof, math.pi)

    def setting(self, analysis, key, default):
        return self.scene.analyses.get(analysis, {}).get(key, default)

    def axis(self, analysis, key, default):
        """A grid axis from the scene's ``[analyses]`` (thinned when quick), or ``default``."""
        s = self.scene.analyses.get(analysis, {})
        if key == "omega" and "frequency_hz" in s:
            values = 2 * math.pi * np.asarray(s["frequency_hz"].values)
        elif key in s:
            values = np.asarray(s[key].values, dtype=float)
        else:
            values = np.asarray(default, dtype=float)
        return values

    # -- output --------------------------------------------------------------------------
    def figure(self, fig, name: str) -> Path:
        rel = Path("figures") / f"{name}.png"
        fig.savefig(self.out / rel, dpi=150)      # sharp on high-density screens
        return rel

    def table(self, name: str, frame, section: str, shown: str | None = None):
        """Write ``frame`` as data/<name>.parquet and .csv; ``shown``: its title on the page."""
        parquet, csv = self.out / "data" / f"{name}.parquet", self.out / "data" / f"{name}.csv"
        frame = frame.reset_index(drop=True)
        frame.to_parquet(parquet, index=False)
        frame.to_csv(csv, index=False)
        self.tables[name] = (parquet, csv)
        self.state.setdefault("table_rows", {})[name] = (len(frame), section)
        if shown is not None:
            self.shown.setdefault(section, []).append((shown, frame))
        return name


def _thin(values, n):
    """At most ``n`` values of an axis, evenly spaced in index, ends kept."""
    values = np.asarray(values)
    if values.size <= n:
        return values
    return values[np.unique(np.linspace(0, values.size - 1, n).round().astype(int))]


def _pct(x) -> str:
    return f"{100 * x:.2g} %" if np.isfinite(x) else "n/a"


# -- sections -------------------------------------------------------------------------------

def _potential(job: _Job) -> _Result:
    from ..figures import effective_potential_figure
    pend = job.pend
    if pend is None:
        raise _Skip(f"the effective potential figure draws U_eff(θ) of the single pendulum "
                    f"(closed form); this system ({job.scene.spec.rig_name}, "
                    f"{job.scene.system.n_dof} coordinates) has its averaged slow modes in "
                    "the slow-frequency and verification sections instead.")
    import pandas as pd
    A, w = job.A, job.omega
    theta = np.linspace(-0.25 * math.pi, 2.25 * math.pi, 901)
    U = pend.effective_potential(theta, A, w)
    pred = pend.averaged(A, w, warn=False)
    fig = effective_potential_figure(
        theta, U, prediction=pred,
        title=f"Effective potential, A = {A:g} m, ω = {w:g} rad/s, {pend.drive} drive\n"
              "(first-order averaging; filled: stable, open: unstable)")
    job.table("effective_potential", pd.DataFrame({"theta": theta, "U_eff_per_mass": U}),
              "potential")
    rows = []
    for eq in pred.equilibria:
        rows.append({"state": eq.name, "theta": float(eq.theta), "exists": bool(eq.exists),
                     "stable": bool(eq.stable), "omega_slow_averaging": float(eq.omega_slow),
                     "valid": bool(eq.valid)})
    eqs = pd.DataFrame(rows)
    job.table("averaged_equilibria", eqs, "potential", shown="Equilibria of the averaged "
              "motion (first-order averaging; Ω in rad/s)")
    if pend.drive == "vertical":
        inv = pred.inverted
        exact = pend.floquet(A, w, about="inverted")
        near = (theta > 0) & (theta < 2 * math.pi)
        barrier = min(U[near & (theta < math.pi)].max(), U[near & (theta > math.pi)].max())
        depth = barrier - float(pend.effective_potential(math.pi, A, w))
        job.numbers.update(omega_slow_averaging=float(inv.omega_slow),
                           omega_slow_floquet=float(exact.omega_slow))
        caption = (f"At A = {A:g} m and ω = {w:g} rad/s (A/l = {A / pend.l:.3g}, "
                   f"ω/ω0 = {w / pend.omega0:.3g}) averaging makes the upright state θ = π "
                   + (f"a minimum of U_eff, {depth:.3g} J/kg deep (per unit mass); "
                      if bool(inv.stable) else "a maximum of U_eff (not stabilised); ")
                   + f"its slow frequency is Ω = {float(inv.omega_slow):.4g} rad/s by "
                   f"first-order averaging and {float(exact.omega_slow):.4g} rad/s by "
                   f"Floquet analysis (exact, linear): "
                   f"{_pct(abs(float(inv.omega_slow) / float(exact.omega_slow) - 1))} apart.")
    else:
        tilt = pred.tilted
        caption = (f"Horizontal drive, A = {A:g} m, ω = {w:g} rad/s: "
                   + (f"the minima of U_eff are tilted to θ* = ±{float(tilt.theta):.4g} rad "
                      f"(cos θ* = 2gl/(Aω)² = {2 * pend.g * pend.l / (A * w) ** 2:.4g}), "
                      f"slow frequency {float(tilt.omega_slow):.4g} rad/s by averaging."
                      if bool(tilt.exists) else
                      "(Aω)² ≤ 2gl: no tilted minimum; the pendulum hangs."))
    return _Result(job.figure(fig, "effective_potential"), caption,
                   ["effective_potential", "averaged_equilibria"])


def _no_map_reason(job):
    return (f"the {job.scene._drive.path if isinstance(job.scene._drive.path, str) else 'oblique'}"
            " drive leaves no equilibrium (θ = 0 and π do not persist), so there is no "
            "(A, ω) stability map of one; the slow state is a periodic orbit, compared with "
            "averaging and simulation in the slow-frequency section.")


def _window_curves(window):
    """The pendulum's exact window as boundary curves: A_min (a multiplier at +1, stable
    above) and A_max (at −1, stable below), drawn solid by the map figure."""
    from ..results import BoundaryCurves
    lo, hi = (np.atleast_1d(np.asarray(x, float)) for x in (window.A_min, window.A_max))
    acc = np.broadcast_to(np.nan if window.accuracy is None else
                          np.asarray(window.accuracy, float), lo.shape)
    return BoundaryCurves(omega=np.atleast_1d(np.asarray(window.omega, float)),
                          A=np.stack([lo, hi]), accuracy=np.stack([acc, acc]),
                          kind=("T", "2T"), stable_below=np.array([False, True]),
                          about="inverted", tol=math.nan if window.tol is None else window.tol)


def _map_axes(job):
    """The map's A and ω axes: the scene's, or around its drive."""
    A0, w0 = job.A, job.omega
    if job.pend is not None:
        l = job.pend.l
        lo = 1.3 * job.pend.omega0             # where averaging and the exact edge part
        w_def = np.geomspace(lo, max(10 * w0, 100 * job.pend.omega0), 240)
        # down to half the Kapitza limit √(2gl)/ω at the fastest drive: both edges shown
        A_def = np.geomspace(min(0.003 * l, 0.5 * math.sqrt(2 * job.pend.g * l) / w_def[-1]),
                             2.0 * l, 240)
    else:
        A_def = np.linspace(0.0, 4 * A0, 48)
        w_def = np.geomspace(w0 / 6, 3 * w0, 48)
    A = job.axis("stability_map", "A", A_def)
    w = job.axis("stability_map", "omega", w_def)
    if job.quick:
        A, w = _thin(A, 60 if job.pend else 14), _thin(w, 60 if job.pend else 14)
    return A, w


def _map(job: _Job) -> _Result:
    from ..figures import _figure, legend_below, stability_map_figure, window_error_figure
    if not job.vertical:
        raise _Skip(_no_map_reason(job))
    A, w = _map_axes(job)
    log_A = bool(A.min() > 0 and A.max() / A.min() > 20)
    fine = np.geomspace(w.min(), w.max(), 120 if job.quick else 400)
    if job.pend is not None:
        pend = job.pend
        result = pend.stability_map(A, w, about="inverted", progress=job.grid_progress)
        exact = pend.stability_window(fine)
        avg1 = pend.stability_window(fine, method="averaging", order=1)
        averaging = [avg1]
        if pend.damping == 0:
            averaging.append(pend.stability_window(fine, method="averaging", order=2))
        overlays = [*averaging, _window_curves(exact)]        # the exact edges drawn on top
        job.state["overlays"] = overlays
        frame = exact.to_dataframe().rename(columns={"A_min": "A_min_exact",
                                                     "A_max": "A_max_exact"})
        frame["A_min_averaging_1"] = np.broadcast_to(avg1.A_min, fine.shape)
        if len(averaging) > 1:
            frame["A_min_averaging_2"] = np.broadcast_to(averaging[1].A_min, fine.shape)
            frame["A_max_averaging_2"] = np.broadcast_to(averaging[1].A_max, fine.shape)
        frame.insert(1, "omega_over_omega0", fine / pend.omega0)
        job.table("window", frame, "map")
        lo, hi = np.asarray(exact.A_min, float), np.asarray(exact.A_max, float)
        ok = np.isfinite(lo)
        rel = np.abs(np.asarray(avg1.A_min) / lo - 1)
        k_lo = int(np.flatnonzero(ok)[0]) if ok.any() else 0       # the lowest ω with a window
        k_hi = int(np.flatnonzero(ok)[-1]) if ok.any() else -1
        job.numbers.update(A_max_high_frequency=float(hi[k_hi]),
                           averaging_A_min_error_lowest_omega=float(rel[k_lo]),
                           averaging_A_min_error_highest_omega=float(rel[k_hi]))
        caption = (f"Exact map of the upright pendulum ({result.A.size} × {result.omega.size} "
                   f"points, {result.method}, {result.seconds:.2g} s; green: "
                   f"stable). The exact window (solid) has a lower, Kapitza edge A_min "
                   f"(a Floquet multiplier at +1) and an upper edge A_max (parametric "
                   f"resonance, multiplier −1; {hi[k_hi] / pend.l:.4f} l at ω = "
                   f"{fine[k_hi]:.3g} rad/s); at the lowest ω with a window, "
                   f"{fine[k_lo]:.3g} rad/s (ω/ω0 = {fine[k_lo] / pend.omega0:.3g}), only "
                   f"{lo[k_lo]:.3g} m < A < {hi[k_lo]:.3g} m is stable. First-order averaging "
                   f"(A ω = √(2gl)) has no upper edge, and its lower edge lies "
                   f"{_pct(rel[k_hi])} from the exact one at ω/ω0 = "
                   f"{fine[k_hi] / pend.omega0:.3g} but {_pct(rel[k_lo])} at ω/ω0 = "
                   f"{fine[k_lo] / pend.omega0:.3g}"
                   + (f"; the next order is {_pct(abs(np.asarray(averaging[1].A_min)[k_lo] / lo[k_lo] - 1))} "
                      f"off there (right: the error falls as (ω0/ω)² and (ω0/ω)⁴)."
                      if len(averaging) > 1 else "."))
    else:
        from ..averaging import average
        from ..floquet import boundaries, stability_map
        system, about, fixed = job.scene.system, job.about, job.fixed
        result = stability_map(system, A, w, fixed, about, progress=job.grid_progress)
        curves = boundaries(system, fixed, about, np.geomspace(w.min(), w.max(),
                                                               40 if job.quick else 120),
                            A_range=(float(A.min()), float(A.max())))
        avg = average(system).stability_window(fine, about, params=fixed)
        overlays = [avg, curves]                       # the exact curves drawn on top
        job.state["overlays"] = overlays
        job.state["curves"] = curves
        job.table("boundaries", curves.to_dataframe(), "map")
        job.table("window_averaging", avg.to_dataframe(), "map")
        caption = (f"Floquet map of {job.scene.spec.rig_name} about q = π ({result.A.size} × "
                   f"{result.omega.size} points by monodromy integration, "
                   f"{result.seconds:.2g} s; {int(result.stable.sum())} stable) with the exact "
                   f"boundary curves ({len(curves.kind)} curves: {', '.join(curves.kind)}; "
                   f"{curves.monodromies} monodromies) and the first-order averaging window "
                   f"(dashed).")
    job.state["map"] = result
    job.state["log_A"] = log_A
    job.table("stability_map", result.to_dataframe(), "map")
    if job.pend is not None:
        fig = _figure((12.0, 5.4))
        ax = fig.add_subplot(1, 2, 1)
        stability_map_figure(result, overlays=overlays, log_omega=True, log_A=log_A,
                             boundaries=False, ax=ax)
        window_error_figure(exact, averaging, ax=fig.add_subplot(1, 2, 2), omega0=pend.omega0)
    else:
        fig = stability_map_figure(result, overlays=overlays, log_omega=True, log_A=log_A,
                                   title=f"Floquet stability of the upright state "
                                         f"{_upright(job)}\n({result.method})")
    legend_below(fig.axes[0])
    job.numbers["map_points"] = int(result.stable.size)
    return _Result(job.figure(fig, "stability_map"), caption,
                   [n for n in ("stability_map", "window", "boundaries", "window_averaging")
                    if n in job.tables])


def _spot_points(job):
    """A handful of (A, ω) points: inside the window, below it, above it, and where
    first-order averaging and the exact map disagree."""
    result = job.state["map"]
    A_axis, w_axis = result.A, result.omega
    pts = []
    if job.pend is not None:
        pend = job.pend
        ws = np.geomspace(w_axis.min(), w_axis.max(), 7)[1:-1:]
        win = pend.stability_window(ws)
        for w, lo, hi in zip(ws, np.atleast_1d(win.A_min), np.atleast_1d(win.A_max)):
            if not np.isfinite(lo):
                continue
            for a in (0.6 * lo, math.sqrt(lo * hi), 1.25 * hi):
                if a == math.sqrt(lo * hi) and abs(w / job.omega - 1) < 0.05:
                    continue                      # the scene's own point stands there
                if A_axis.min() <= a <= A_axis.max():
                    pts.append((a, w))
        # where averaging's lower edge is furthest below the exact one: averaging says
        # stable, the exact analysis says it falls
        fine = np.geomspace(w_axis.min(), w_axis.max(), 200)
        ex = pend.stability_window(fine)
        av = pend.stability_window(fine, method="averaging", order=1)
        gap = np.where(np.isfinite(ex.A_min), np.asarray(ex.A_min) - np.asarray(av.A_min), 0)
        score = gap / np.where(np.isfinite(ex.A_min), ex.A_min, 1)
        score[:10] = score[-10:] = 0                     # not on the map's edge
        k = int(np.argmax(score))
        if gap[k] > 0.03 * ex.A_min[k]:
            pts.append((0.5 * (ex.A_min[k] + av.A_min[k]), fine[k]))
        pts.insert(0, (job.A, job.omega))                  # the scene's own drive
    else:
        stable = np.asarray(result.stable)
        for j in np.linspace(0, w_axis.size - 1, 5).round().astype(int)[1:-1]:
            col = A_axis[stable[:, j] & (A_axis > 0)]
            if not col.size:
                continue
            lo, hi = col.min(), col.max()
            for a in (0.6 * lo, math.sqrt(lo * hi), 1.25 * hi):
                if A_axis.min() <= a <= A_axis.max():
                    pts.append((a, w_axis[j]))
    if job.quick:
        pts = pts[::2] + ([pts[-1]] if len(pts) % 2 == 0 else [])
    A = np.array([p[0] for p in pts], float)
    w = np.array([p[1] for p in pts], float)
    return A, w


def _upright(job) -> str:
    n = job.scene.system.n_dof
    return "θ = π" if n == 1 else f"q = ({', '.join(['π'] * n)})"


def _curve_distance(curves, A, w):
    """|A − A_b|/A to the nearest boundary curve at each point's ω (interpolated in log ω);
    NaN without curves, inf where no curve reaches that ω."""
    if curves is None:
        return np.full(np.shape(A), np.nan)
    cw = np.log(np.asarray(curves.omega, float))
    out = np.full(np.shape(A), np.inf)
    for Ak in np.asarray(curves.A, float):
        ok = np.isfinite(Ak)
        if ok.sum() < 2:
            continue
        Ab = np.interp(np.log(w), cw[ok], Ak[ok], left=np.nan, right=np.nan)
        with np.errstate(invalid="ignore"):
            out = np.fmin(out, np.abs(A - Ab) / A)
    return out


#: The shortest spot-check run (s): a weakly unstable upright state (growth rate of
#: order 1/s) must have time to topple a 0.1 rad tilt at any ω.
_SPOT_SECONDS = 8.0


def _per_frequency(run, A, w, periods):
    """``run(A, ω, periods)`` once per distinct ω, each for ``periods`` drive periods or
    :data:`_SPOT_SECONDS`, whichever is longer; the fields the spot checks use, per point,
    and the periods each point ran."""
    out = {"stayed_up": np.zeros(A.shape, bool), "fall_time": np.full(A.shape, np.nan),
           "max_deviation": np.full(A.shape, np.nan), "status": np.full(A.shape, "", object)}
    runs = np.zeros(A.shape, int)
    for ww in np.unique(w):
        sel = w == ww
        k = max(int(periods), math.ceil(_SPOT_SECONDS * ww / (2 * math.pi)))
        m = run(A[sel], np.full(sel.sum(), ww), k)
        out["stayed_up"][sel] = np.asarray(m.stayed_up, bool)
        out["fall_time"][sel] = np.asarray(m.fall_time, float)
        out["max_deviation"][sel] = np.asarray(m.max_deviation, float).reshape(
            int(sel.sum()), -1).max(axis=1)
        out["status"][sel] = np.asarray(m.status).astype(str)
        runs[sel] = k
    out["status"] = out["status"].astype(str)
    return out, runs


def _spots(job: _Job) -> _Result:
    import pandas as pd
    from ..figures import spot_check_figure
    if not job.vertical:
        return _tilt_spots(job)
    if "map" not in job.state:
        raise _Skip("the stability map did not finish, and the spot checks are drawn on it.")
    A, w = _spot_points(job)
    periods = int(job.setting("measure", "periods", 400))
    periods = min(periods, 150) if job.quick else periods
    offset = 0.1
    if job.pend is not None:
        pend = job.pend
        m, runs = _per_frequency(
            lambda a, ww, k: pend.measure_grid(a, ww, math.pi - offset, periods=k,
                                               about="inverted", method=_GRID_METHOD,
                                               progress=job.grid_progress), A, w, periods)
        exact = pend.stability_map(np.unique(A), np.unique(w), about="inverted")
        floquet = exact.stable[np.searchsorted(exact.A, A), np.searchsorted(exact.omega, w)]
        win = pend.stability_window(w)
        lo, hi = np.asarray(win.A_min), np.asarray(win.A_max)
        with np.errstate(invalid="ignore"):
            dist = np.nanmin(np.abs(np.stack([A - lo, A - hi])) / A, axis=0)
        avg = A * w >= math.sqrt(2 * pend.g * pend.l)
        extra = {"stable_averaging_1": avg}
    else:
        from ..floquet import floquet_grid
        from ..simulation import measure_grid
        system, about = job.scene.system, job.about
        params = {**job.fixed, "A": A, "omega": w}
        q0 = about + offset * (-1.0) ** np.arange(about.size)
        m, runs = _per_frequency(
            lambda a, ww, k: measure_grid(system, {**job.fixed, "A": a, "omega": ww}, about,
                                          q0, periods=k, method=_GRID_METHOD,
                                          progress=job.grid_progress), A, w, periods)
        grid = floquet_grid(system, params, about, progress=job.grid_progress)
        floquet = np.asarray(grid.stable)
        dist = _curve_distance(job.state.get("curves"), A, w)
        # how much the linear instability can grow over the simulated run: a weakly
        # unstable point (growth near 1) need not fall within it
        extra = {"floquet_growth_over_run": np.exp(np.asarray(grid.log_growth) * runs)}
    stayed = np.asarray(m["stayed_up"], bool)
    agree = stayed == floquet
    frame = pd.DataFrame({"A": A, "omega": w, "stayed_up": stayed,
                          "fall_time": m["fall_time"], "periods": runs,
                          "stable_floquet": floquet, "agrees": agree,
                          "max_deviation": m["max_deviation"],
                          "boundary_distance": dist, **extra,
                          "status": m["status"]})
    job.table("spot_checks", frame, "spots", shown="Spot checks (released "
              f"{offset} rad from upright, for {periods} drive periods or {_SPOT_SECONDS:g} s, "
              f"whichever is longer; boundary_distance = "
              "|A − A_edge|/A to the nearest exact edge)")
    overlays = job.state.get("overlays", [])
    fig = spot_check_figure(job.state["map"], A, w, stayed, agree, overlays=overlays,
                            log_omega=True, log_A=job.state.get("log_A", False),
                            title=f"Spot checks by direct simulation on the Floquet map of "
                                  f"the upright state {_upright(job)}")
    n_bad = int((~agree).sum())
    job.numbers.update(spot_checks=int(A.size), spot_checks_agreeing=int(agree.sum()))
    caption = (f"{A.size} direct simulations of the full nonlinear equation (DOP853, rtol "
               f"1e-9), released "
               f"{offset} rad from the upright and run {periods} drive periods or "
               f"{_SPOT_SECONDS:g} s, whichever is longer: "
               f"{int(stayed.sum())} stayed up, {int((~stayed).sum())} fell; "
               f"{int(agree.sum())} of {A.size} agree with Floquet analysis"
               + ("." if not n_bad else f" ({n_bad} disagree: see the table"))
    if n_bad:
        d = dist[~agree]
        if np.isfinite(d).any():
            caption += f"; they lie within {np.nanmax(d[np.isfinite(d)]):.2g} (relative in A) of a boundary"
        held = ~agree & stayed
        if held.any():
            caption += (f"; where the simulation stayed up against an unstable Floquet "
                        f"verdict its largest deviation from upright was "
                        f"{np.max(frame.max_deviation[held]):.2g} rad (the band is π/2)")
            if "floquet_growth_over_run" in extra:
                growth = float(np.min(extra["floquet_growth_over_run"][held]))
                caption += (f", although the linearisation grows {growth:.3g}× or more over "
                            f"the run: " + ("the instability saturates nonlinearly, the motion "
                                            "stays bounded near the upright"
                                            if growth > 1e3 else
                                            "the instability is too weak for the run"))
        caption += ")."
    if "stable_averaging_1" in extra:
        fooled = extra["stable_averaging_1"] & ~floquet
        if fooled.any():
            caption += (f" At {int(fooled.sum())} of the points first-order averaging predicts "
                        f"an upright pendulum and the exact analysis does not (above A_max, "
                        f"which averaging cannot see, or between the two lower edges at low "
                        f"ω); the simulation fell at {int((fooled & ~stayed).sum())} of them.")
    return _Result(job.figure(fig, "spot_checks"), caption, ["spot_checks"])


def _tilt_spots(job: _Job) -> _Result:
    """Horizontal drive: the tilt of the slow state, by averaging, the periodic orbit and
    simulation, along A at the scene's ω (no map exists to mark points on)."""
    import pandas as pd
    from ..figures import tilt_figure
    pend, w = job.pend, job.omega
    if pend is None:
        raise _Skip(_no_map_reason(job))
    A_tilt = math.sqrt(2 * pend.g * pend.l) / w           # (Aω)² = 2gl: the tilt appears
    A = np.geomspace(1.15 * A_tilt, max(4 * A_tilt, 1.5 * job.A), 4 if job.quick else 8)
    pred = pend.averaged(A, w, warn=False).tilted
    theta_avg = np.asarray(pred.theta, float)
    orbit = np.full(A.shape, np.nan)
    orbit_stable = np.zeros(A.shape, bool)
    for i, a in enumerate(A):
        try:
            o = pend.floquet(float(a), w, about="tilted")
            orbit[i], orbit_stable[i] = float(o.q_mean[0]), bool(o.stable)
        except (ValueError, RuntimeError):
            pass
    periods = 150 if job.quick else int(job.setting("measure", "periods", 400))
    m = pend.measure_grid(A, w, theta_avg + 0.05, periods=periods, about="tilted",
                          method=_GRID_METHOD, progress=job.grid_progress)
    frame = pd.DataFrame({"A": A, "omega": w, "theta_averaging": theta_avg,
                          "theta_orbit_mean": orbit, "orbit_stable": orbit_stable,
                          "theta_measured_mean": np.asarray(m.mean_angle, float),
                          "stayed_near": np.asarray(m.stayed_up, bool)})
    job.table("tilt_checks", frame, "spots", shown="The tilted state (rad): averaging, the "
              "periodic orbit's period mean, the simulation's time mean")
    fig = tilt_figure(frame, l=pend.l, g=pend.g)
    err = np.nanmax(np.abs(frame.theta_measured_mean - frame.theta_orbit_mean))
    err_avg = np.nanmax(np.abs(frame.theta_averaging - frame.theta_orbit_mean))
    caption = (f"No equilibrium persists under the horizontal drive, so there is no map to "
               f"mark; instead {A.size} simulations along A at ω = {w:g} rad/s, released "
               f"0.05 rad beside the averaged tilt: {int(frame.stayed_near.sum())} stayed near "
               f"it; the measured mean tilt is within {err:.2g} rad of the periodic orbit's "
               f"(Newton shooting), and first-order averaging's tilt within {err_avg:.2g} rad.")
    return _Result(job.figure(fig, "tilt_checks"), caption, ["tilt_checks"])


def _line_amplitudes(job, n):
    """Amplitudes along the scene's ω that the upright state is stable at."""
    w = job.omega
    if job.pend is not None:
        win = job.pend.stability_window(w)
        lo, hi = float(win.A_min), float(win.A_max)
        if not np.isfinite(lo):
            raise _Skip(f"the upright pendulum has no window of stabilising amplitudes at the "
                        f"scene's ω = {w:g} rad/s; choose a faster drive.")
        return np.geomspace(1.03 * lo, 0.97 * hi, n)
    result = job.state.get("map")
    if result is None:
        raise _Skip("the stability map did not finish; the slow frequencies are taken "
                    "along its stable amplitudes.")
    j = int(np.argmin(np.abs(np.log(result.omega / w))))
    stable = result.A[np.asarray(result.stable)[:, j]]
    stable = stable[stable > 0]
    if stable.size < 2:
        raise _Skip(f"the map has fewer than two stable amplitudes at ω ≈ {result.omega[j]:.4g} "
                    "rad/s; there is no slow oscillation to measure.")
    return np.linspace(stable.min(), stable.max(), n)


def _slow(job: _Job) -> _Result:
    import pandas as pd
    from ..figures import slow_frequency_figure
    if not job.vertical:
        return _tilt_slow(job)
    n = 5 if job.quick else 12
    A = _line_amplitudes(job, n)
    w = job.omega
    periods = 300 if job.quick else int(job.setting("verify", "periods", 1000))
    if job.pend is not None:
        v = job.pend.verify(A, w, periods=periods, line=False, method=_GRID_METHOD,
                            progress=job.grid_progress)
    else:
        from ..verification import verify
        v = verify(job.scene.system, job.fixed, job.about, A=A, omega=w, periods=periods,
                   line=False, method=_GRID_METHOD, progress=job.grid_progress)
    frame = v.to_dataframe()
    keep = [c for c in frame.columns if c.startswith(("A", "omega", "stable_", "tolerance_"))
            or c in ("simulation_status",)]
    job.table("slow_frequency", frame[keep], "slow")
    fig = slow_frequency_figure(v)
    ref = v._modes("omega_slow_floquet")
    parts = []
    for m, name in (("averaging", "first-order averaging"), ("averaging_2", "next order"),
                    ("simulation", "measured (simulation)")):
        if m not in v.methods:
            continue
        with np.errstate(invalid="ignore", divide="ignore"):
            rel = np.abs(v._modes(f"omega_slow_{m}") / ref - 1)
        if np.isfinite(rel).any():
            parts.append(f"{name} {np.nanmedian(rel):.2g} (largest {np.nanmax(rel):.2g})")
            job.numbers[f"slow_median_error_{m}"] = float(np.nanmedian(rel))
    shown = pd.DataFrame({"A (m)": np.ravel(v.A)})
    for m in v.methods:
        x = v._modes(f"omega_slow_{m}")
        for k in range(x.shape[-1]):
            shown[f"Ω {m}" + (f" mode {k}" if x.shape[-1] > 1 else "")] = x[..., k]
    job.shown.setdefault("slow", []).append((f"Ω (rad/s) along A at ω = {w:g} rad/s", shown))
    caption = (f"Slow frequency Ω of the upright state along A at ω = {w:g} rad/s "
               f"({A.size} amplitudes across the stable range, simulations of {periods} "
               f"periods from a release 0.01 rad off upright). Relative difference from "
               f"Floquet (exact, linear), median: " + "; ".join(parts) + ".")
    with np.errstate(invalid="ignore", divide="ignore"):
        rel1 = np.abs(v._modes("omega_slow_averaging") / ref - 1).max(axis=-1)
        ratio = np.nanmax(ref, axis=-1) / w
    if np.isfinite(rel1).sum() >= 2:
        k = int(np.nanargmax(rel1))
        caption += (f" First-order averaging is furthest off ({rel1[k]:.2g}) at A = "
                    f"{np.ravel(v.A)[k]:.3g} m, where Ω/ω = {ratio[k]:.2g}: the slow motion is "
                    f"no longer slow against the drive.")
    return _Result(job.figure(fig, "slow_frequency"), caption, ["slow_frequency"])


def _tilt_slow(job: _Job) -> _Result:
    import pandas as pd
    from ..figures import slow_frequency_line_figure
    pend, w = job.pend, job.omega
    if pend is None:
        raise _Skip(_no_map_reason(job))
    A_tilt = math.sqrt(2 * pend.g * pend.l) / w
    A = np.geomspace(1.15 * A_tilt, max(4 * A_tilt, 1.5 * job.A), 4 if job.quick else 8)
    avg = np.asarray(pend.averaged(A, w, warn=False).tilted.omega_slow, float)
    orbit = np.full(A.shape, np.nan)
    for i, a in enumerate(A):
        try:
            orbit[i] = float(np.max(pend.floquet(float(a), w, about="tilted").omega_slow))
        except (ValueError, RuntimeError):
            pass
    theta = np.asarray(pend.averaged(A, w, warn=False).tilted.theta, float)
    periods = 300 if job.quick else 1000
    m = pend.measure_grid(A, w, theta + 0.01, periods=periods, about="tilted",
                          method=_GRID_METHOD, progress=job.grid_progress)
    measured = np.where(np.asarray(m.stayed_up, bool), np.asarray(m.omega_slow, float), np.nan)
    frame = pd.DataFrame({"A": A, "omega": w, "omega_slow_averaging": avg,
                          "omega_slow_orbit": orbit, "omega_slow_measured": measured,
                          "omega_slow_measured_error": np.asarray(m.omega_slow_error, float)})
    job.table("slow_frequency", frame, "slow", shown="Ω (rad/s) of the tilted state")
    fig = slow_frequency_line_figure(A, {"first-order averaging": avg,
                                         "Floquet (periodic orbit)": orbit,
                                         "measured (simulation)": measured},
                                     title=f"Slow frequency of the tilted state, ω = {w:g} rad/s")
    with np.errstate(invalid="ignore"):
        e_avg = np.nanmedian(np.abs(avg / orbit - 1))
        e_sim = np.nanmedian(np.abs(measured / orbit - 1))
    caption = (f"Ω of the tilted state along A at ω = {w:g} rad/s: first-order averaging is "
               f"{e_avg:.2g} (median, relative) from the periodic orbit's Floquet value, the "
               f"measured Ω {e_sim:.2g}.")
    return _Result(job.figure(fig, "slow_frequency"), caption, ["slow_frequency"])


def _verification(job: _Job) -> _Result:
    import pandas as pd
    from ..figures import verification_figure
    if not job.vertical:
        raise _Skip("verification compares averaging, Floquet and simulation about an "
                    "equilibrium that persists under the drive; the horizontal drive leaves "
                    "none (the slow state is a periodic orbit, compared in the "
                    "slow-frequency section).")
    if job.pend is not None:
        l, w0 = job.pend.l, job.pend.omega0
        A_def = np.geomspace(0.01 * l, 0.6 * l, 6)
        w_def = np.geomspace(2.5 * w0, 100 * w0, 6)
    else:
        A_def = np.linspace(0.25 * job.A, 3 * job.A, 5)
        w_def = np.geomspace(job.omega / 4, 2 * job.omega, 5)
    A = job.axis("verify", "A", A_def)
    w = job.axis("verify", "omega", w_def)
    periods = int(job.setting("verify", "periods", 1000))
    fit = bool(job.setting("verify", "fit_order", True))
    if job.quick:
        A, w, periods, fit = _thin(A, 3), _thin(w, 3), min(periods, 300), False
    if job.pend is not None:
        v = job.pend.verify(A[:, None], w[None, :], periods=periods,
                            line=None if fit else False, method=_GRID_METHOD,
                            progress=job.grid_progress)
    else:
        from ..verification import verify
        v = verify(job.scene.system, job.fixed, job.about, A=A[:, None], omega=w[None, :],
                   periods=periods, line=False, method=_GRID_METHOD,
                   progress=job.grid_progress)
    agreement = v.agreement
    dis = v.disagreements
    job.table("verification", v.to_dataframe(), "verification")
    job.table("verification_agreement", agreement, "verification",
              shown="Agreement, per pair of methods (stability and Ω within the stated "
                    "tolerances)")
    cols = [c for c in ("A", "omega", "A_over_l", "omega_over_omega0", "boundary_distance",
                        "quantity", "first", "second", "first_stable", "second_stable",
                        "first_omega_slow", "second_omega_slow", "tolerance") if c in dis]
    job.table("verification_disagreements", dis[cols], "verification",
              shown=f"Every disagreement ({len(dis)}), located; boundary_distance = "
                    "|A − A_b|/A to the nearest exact boundary")
    fits = pd.DataFrame([{"order": f.order, "fitted exponent": f.exponent,
                          "standard error": f.exponent_error, "theory": f.theory,
                          "points fitted": int(np.sum(f.used))} for f in v.fits])
    if len(fits):
        job.table("verification_order_fit", fits, "verification",
                  shown="The measured order of averaging (relative error of Ω ∝ ε^p)")
    fig = verification_figure(v)
    stab = agreement[agreement.quantity == "stability"]
    sim = stab[(stab["first"] == "floquet") & (stab["second"] == "simulation")]
    if sim.empty:
        sim = stab[(stab["second"] == "floquet") & (stab["first"] == "simulation")]
    n = int(np.size(v.stable_floquet))
    agree_sim = int(sim.agreeing.iloc[0]) if len(sim) else 0
    compared_sim = int(sim.compared.iloc[0]) if len(sim) else 0
    job.numbers.update(verification_points=n, verification_disagreements=int(len(dis)),
                       floquet_simulation_agreeing=agree_sim,
                       floquet_simulation_compared=compared_sim)
    for f in v.fits:
        job.numbers[f"order_{f.order}_exponent"] = float(f.exponent)
    caption = (f"{n} points (A × ω = {A.size} × {w.size}), {periods} drive periods simulated "
               f"each: Floquet and simulation agree on stability at {agree_sim} of "
               f"{compared_sim}; {len(dis)} disagreements in all between the "
               f"{len(v.methods)} methods")
    if len(dis):
        d = np.asarray(dis.boundary_distance, float)
        caption += (f", the farthest {np.nanmax(d):.2g} (relative in A) from an exact "
                    "boundary" if np.isfinite(d).any() else "")
    caption += "."
    names = {"averaging": "first-order averaging", "averaging_2": "next-order averaging",
             "simulation": "simulation"}
    against = []
    for m in v.methods:
        if m == "floquet":
            continue
        counts = []
        for quantity in ("stability", "omega_slow"):
            compared, agree = v.compare(m, "floquet", quantity)
            counts.append((int((compared & ~agree).sum()), int(compared.sum())))
        against.append(f"{names.get(m, m)} differs in stability at {counts[0][0]} of "
                       f"{counts[0][1]} points and in Ω beyond the stated tolerances at "
                       f"{counts[1][0]} of {counts[1][1]}")
    if against:
        caption += " Against Floquet: " + "; ".join(against) + "."
    for f in v.fits:
        caption += (f" Order {f.order} averaging: error of Ω ∝ ε^p with p = {f.exponent:.3f} "
                    f"± {f.exponent_error:.3f} (theory {f.theory:g}).")
    return _Result(job.figure(fig, "verification"), caption,
                   [t for t in ("verification", "verification_agreement",
                                "verification_disagreements", "verification_order_fit")
                    if t in job.tables])


def _work_precision(job: _Job) -> _Result:
    from lagrange_core.accuracy_cost import work_precision

    from ..figures import work_precision_figure
    pend = job.pend
    system = job.scene.system
    w = job.omega
    T = 2 * math.pi / w
    q0 = job.scene.q0
    t_span = (0.0, 20 * T)
    result = work_precision(system, q0, job.scene.qdot0, t_span, job.params,
                            rtols=(1e-3, 1e-6, 1e-9) if job.quick else
                            (1e-3, 1e-5, 1e-7, 1e-9, 1e-11), repeat=1 if job.quick else 3)
    if getattr(result, "interrupted", False):     # it keeps its finished runs and returns
        raise KeyboardInterrupt("work_precision was interrupted")
    job.table("work_precision", result.to_dataframe(), "work_precision")
    fig = work_precision_figure(result)
    caption = (f"Error at the final time t = {t_span[1]:.3g} s ({t_span[1] / T:.0f} drive "
               f"periods of {'the pendulum' if pend else system.name}) against wall time per "
               f"run (compile excluded), each method at each tolerance; the reference's own "
               f"error is {result.reference_error:.2g}.")
    for level in (1e-6, 1e-9):
        times = result.time_to_reach(level)
        mine = times.get(result.default_method, math.nan)
        others = {k: v for k, v in times.items() if k != result.default_method}
        if np.isfinite(mine):
            caption += (f" To reach {level:g}, {result.default_method} (the default) takes "
                        f"{1e3 * mine:.3g} ms"
                        + "".join(f", {k} {v / mine:.3g}× as long" if np.isfinite(v) else
                                  f", {k} never gets there at the tolerances tried"
                                  for k, v in others.items()) + ".")
            job.numbers[f"work_precision_seconds_{level:g}"] = mine
            break
    return _Result(job.figure(fig, "work_precision"), caption, ["work_precision"])


def _animation(job: _Job) -> _Result:
    from ..animation import pendulum_animation, system_animation
    sizes = ({"duration": 1.6, "frames_per_period": 4, "width": 480, "max_frames": 80}
             if job.quick else {})
    if not job.vertical:
        raise _Skip("the animation shows the upright state held by a vertical drive; this "
                    "scene's drive leaves no upright equilibrium.")
    if job.pend is None:
        return _chain_animation(job, system_animation, sizes)
    pend = job.pend
    rel = Path("figures") / "pendulum.gif"
    win = pend.stability_window(job.omega)
    A = job.A if float(win.A_min) < job.A < float(win.A_max) else \
        math.sqrt(float(win.A_min) * float(win.A_max))
    theta0 = float(job.scene.q0[0])
    if not 0 < abs(theta0 - math.pi) < math.pi / 2:        # not released near the upright
        theta0 = math.pi - 0.1
    result = pendulum_animation(job.out / rel, l=pend.l, g=pend.g, A=A, omega=job.omega,
                                theta0=theta0, damping=pend.damping, **sizes)
    caption = (f"Left: driven with A = {A:g} m at ω = {job.omega:g} rad/s (inside the exact "
               f"window {float(win.A_min):.3g} m < A < {float(win.A_max):.3g} m), it stays up; "
               f"right: the same release without a sufficient drive falls.")
    job.table("animation", result.to_dataframe(), "animation")
    return _Result(rel, caption, ["animation"])


def _chain_animation(job: _Job, system_animation, sizes) -> _Result:
    """A system other than the single pendulum (e.g. Acheson's chain): the scene itself,
    released from its [initial] state under its drive, in one panel."""
    rel = Path("figures") / "animation.gif"
    try:
        result = system_animation(job.out / rel, [job.scene], **sizes)
    except ValueError as e:       # not a planar chain of particles: nothing to draw
        raise _Skip(f"the animation draws planar chains of particles: {e}") from None
    stayed, stable = result.stayed_up[0], result.floquet_stable[0]
    fate = ("it stays within π/2 of the upright for the whole clip" if stayed else
            f"it leaves the upright at t = {result.fall_time[0]:.3g} s")
    caption = (f"The scene's system released from its initial state with the drive "
               f"A = {job.A:g} m, ω = {job.omega:g} rad/s: {fate}; Floquet analysis calls the "
               f"upright {'stable' if stable else 'unstable'} at this drive.")
    job.table("animation", result.to_dataframe(), "animation")
    return _Result(rel, caption, ["animation"])


_BUILDERS = {"potential": _potential, "map": _map, "spots": _spots, "slow": _slow,
             "verification": _verification, "work_precision": _work_precision,
             "animation": _animation}


# -- the page -------------------------------------------------------------------------------

_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;max-width:1100px;
margin:2em auto;padding:0 1em;color:#222;line-height:1.45}
h1{font-size:1.6em;margin-bottom:.2em}h2{font-size:1.25em;margin-top:2em;
border-bottom:1px solid #ccc;padding-bottom:.2em}
/* a table wider than the column scrolls inside itself, not the page */
table{border-collapse:collapse;font-size:.85em;margin:.6em 0;
display:block;max-width:100%;overflow-x:auto}
td,th{border:1px solid #ddd;padding:.2em .5em;text-align:right}th{background:#f4f4f4}
td.l,th.l{text-align:left}
img{max-width:100%;height:auto;border:1px solid #eee}
.caption{font-size:.95em;margin:.4em 0 1em}
.note{background:#fff7e0;border-left:4px solid #e0a800;padding:.5em .8em}
.fail{background:#fde8e8;border-left:4px solid #c0392b;padding:.5em .8em}
.meta{font-size:.9em;color:#444}
details{margin:.5em 0}
"""


def _fmt(x) -> str:
    if isinstance(x, (bool, np.bool_)):
        return "yes" if x else "no"
    if isinstance(x, (float, np.floating)):
        if not np.isfinite(x):
            return "—" if np.isnan(x) else ("∞" if x > 0 else "−∞")
        return f"{x:.5g}"
    return html.escape(str(x))


def _html_table(frame, max_rows=40) -> str:
    cols = list(frame.columns)
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in cols)
    rows = []
    for _, r in frame.head(max_rows).iterrows():
        rows.append("<tr>" + "".join(
            f"<td{' class=l' if isinstance(r[c], str) else ''}>{_fmt(r[c])}</td>"
            for c in cols) + "</tr>")
    more = (f"<p class=meta>… {len(frame) - max_rows} more rows in the data files.</p>"
            if len(frame) > max_rows else "")
    return f"<table><tr>{head}</tr>{''.join(rows)}</table>{more}"


def _versions() -> dict:
    import matplotlib
    import numba
    import scipy
    from .._version import __version__
    return {"kapitza": __version__, "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__, "numba": numba.__version__,
            "matplotlib": matplotlib.__version__}


def _write_page(job: _Job, done: dict, seconds: float) -> None:
    """Write index.html with the sections finished so far (atomic: a temp file, renamed)."""
    scene = job.scene
    esc = html.escape
    source = scene.spec.source
    if Path(str(source)).resolve() == _default_scene_path().resolve():
        source = "the built-in scene kapitza/scenes/report.toml"     # not this machine's path
    title = scene.spec.title or Path(source).stem
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    params = ", ".join(f"{k} = {v:g}" for k, v in sorted(scene.params.items()))
    effects = ", ".join(type(e).__name__ for e in scene.effects)
    parts = [f"<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
             f"<title>kapitza report: {esc(title)}</title><style>{_CSS}</style></head><body>",
             f"<h1>kapitza report: {esc(title)}</h1>",
             f"<p class=meta>Scene <code>{esc(str(source))}</code> — system "
             f"<code>{esc(scene.spec.rig_name)}</code> ({scene.system.n_dof} coordinate"
             f"{'s' if scene.system.n_dof > 1 else ''}), effects: {esc(effects)}.<br>"
             f"Parameters (SI): {esc(params)}; initial state "
             f"{esc(', '.join(f'{k} = {v:g}' for k, v in scene.spec.initial.items()))}.<br>"
             f"Written {now}; total wall time {seconds:.1f} s"
             f"{' (quick: small grids)' if job.quick else ''}. Versions: "
             + esc(", ".join(f"{k} {v}" for k, v in _versions().items())) + ".</p>"]
    missing = [s.title for s in done.values() if s.status in ("interrupted", "not run")]
    pending = [t for n, t in SECTIONS.items() if n not in done]
    if missing:
        parts.append(f"<p class=fail><b>Incomplete:</b> the run was interrupted; missing "
                     f"sections: {esc('; '.join(missing))}.</p>")
    elif pending:
        parts.append(f"<p class=note>Still running; not yet written: "
                     f"{esc('; '.join(pending))}.</p>")
    rows = "".join(f"<tr><td class=l><a href='#{n}'>{esc(s.title)}</a></td>"
                   f"<td class=l>{s.status}</td><td>{_fmt(round(s.seconds, 1))}</td></tr>"
                   for n, s in done.items())
    parts.append(f"<table><tr><th class=l>section</th><th class=l>status</th>"
                 f"<th>wall time (s)</th></tr>{rows}</table>")
    for name, heading in SECTIONS.items():
        s = done.get(name)
        parts.append(f"<h2 id={name}>{esc(heading)}</h2>")
        if s is None:
            parts.append("<p class=note>Not written yet (the report is still running).</p>")
            continue
        if s.status == "skipped":
            parts.append(f"<p class=note><b>Not applicable to this scene:</b> "
                         f"{esc(s.reason)}</p>")
            continue
        if s.status != "done":
            what = {"failed": "This section failed", "interrupted": "Interrupted",
                    "not run": "Not computed"}[s.status]
            parts.append(f"<p class=fail><b>{what}:</b> {esc(s.reason)}</p>")
            continue
        if s.figure is not None:
            parts.append(f"<img src='{s.figure.as_posix()}' alt='{esc(heading)}'>")
        parts.append(f"<p class=caption>{esc(s.caption)}</p>")
        for note in s.notes:
            parts.append(f"<p class=meta>Note from the computation: {esc(note)}</p>")
        for caption, frame in job.shown.get(name, []):
            parts.append(f"<p class=meta>{esc(caption)}</p>{_html_table(frame)}")
        if s.tables:
            links = ", ".join(f"{esc(t)} (<a href='data/{t}.parquet'>Parquet</a>, "
                              f"<a href='data/{t}.csv'>CSV</a>)" for t in s.tables)
            parts.append(f"<p class=meta>Data: {links}</p>")
    rows = []
    for name, (rows_n, section) in job.state.get("table_rows", {}).items():
        rows.append(f"<tr><td class=l>{esc(name)}</td><td class=l>{esc(SECTIONS[section])}"
                    f"</td><td>{rows_n}</td><td class=l><a href='data/{name}.parquet'>"
                    f"data/{name}.parquet</a></td><td class=l><a href='data/{name}.csv'>"
                    f"data/{name}.csv</a></td></tr>")
    parts.append("<h2 id=data>Data files</h2><table><tr><th class=l>table</th>"
                 "<th class=l>section</th><th>rows</th><th class=l>Parquet</th>"
                 f"<th class=l>CSV</th></tr>{''.join(rows)}</table>")
    parts.append("</body></html>\n")
    path = job.out / "index.html"
    tmp = path.with_suffix(".html.tmp")
    tmp.write_text("\n".join(parts), encoding="utf-8")
    tmp.replace(path)

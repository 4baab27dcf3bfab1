"""Building the report: :func:`build_report` runs the sections in order, each under a
Ctrl-C guard and with its warnings recorded, rewrites the page after each, and returns
what it wrote (:class:`Report`), or raises :class:`ReportInterrupted` carrying it."""
from __future__ import annotations

import contextlib
import math
import signal
import sys
import threading
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

from lagrange_core._compile_notice import activity

from ..warmup import wait_for
from ._html import write_page
from ._job import Job, Skip, default_scene_path
from ._sections import BUILDERS, COMPILED_IN, SECTIONS

__all__ = ["build_report", "Report", "ReportSection", "ReportInterrupted"]


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


@activity("kapitza report")     # a first compile says how long the whole report compiles
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
        scene = Scene.from_toml(default_scene_path())
    elif not isinstance(scene, Scene):
        scene = Scene.from_toml(scene)
    drive = scene.drive
    if drive is None or "A" not in scene.params or "omega" not in scene.params:
        raise ValueError(f"{scene.spec.source}: the report is about a driven system; add "
                         "[effects.drive] with an amplitude and a frequency.")
    out = Path(out)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    (out / "data").mkdir(parents=True, exist_ok=True)
    say = _speaker(progress)
    job = Job(scene=scene, out=out, quick=quick,
               grid_progress=False if progress is False else None)
    say(f"kapitza report: {scene.spec.title or scene.spec.source} -> {out}/"
        + (" (quick)" if quick else ""))
    with _ctrl_c() as ctrl_c:
        done, interrupted = _run_sections(job, say, ctrl_c, t_start)
        report = Report(out=out, index=out / "index.html",
                        scene=str(scene.spec.source), sections=tuple(done.values()),
                        tables=dict(job.tables), numbers=dict(job.numbers),
                        seconds=time.perf_counter() - t_start, quick=quick)
        write_page(job, done, report.seconds)
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
    finished part (e.g. work_precision) still stops the report after its section, and a
    section still running :data:`REPEAT_AFTER` s later gets it again (:func:`_repeat`).  Our
    own handler also keeps lagrange_core's ``defer_ctrl_c`` from holding the interrupt
    back where no chunk loop would see it.  A Ctrl-C that Python drops because it was
    raised inside a weakref callback or a ``__del__`` is not printed as "Exception
    ignored" with a traceback: it is raised again (:func:`_repeat`)."""
    state = {"armed": False, "hit": False}
    if threading.current_thread() is not threading.main_thread():
        yield state
        return

    def handler(signum, frame):
        if state["armed"] and not state["hit"]:
            threading.Thread(target=_repeat, args=(state,), daemon=True).start()
        state["hit"] = True
        if state["armed"]:
            raise KeyboardInterrupt

    previous_hook = sys.unraisablehook

    def unraisable(info):
        if state["hit"] and issubclass(info.exc_type, KeyboardInterrupt):
            return              # ours, lost where Python cannot raise it: _repeat will
        previous_hook(info)

    old = signal.signal(signal.SIGINT, handler)
    sys.unraisablehook = unraisable
    try:
        yield state
    finally:
        signal.signal(signal.SIGINT, old)
        if sys.unraisablehook is unraisable:
            sys.unraisablehook = previous_hook


#: s after a Ctrl-C within which the running section must have ended before it is raised
#: again into it
REPEAT_AFTER = 1.0


def _repeat(state):
    """Raise the Ctrl-C again every :data:`REPEAT_AFTER` s while the section it hit still
    runs.  A KeyboardInterrupt can be lost: raised while a weakref callback or a
    ``__del__`` runs, Python reports it as "Exception ignored" and goes on (seen in the
    suite: a WeakSet's callback), and a computation may catch it to return its finished
    part and then keep going.  Never while numba compiles (an exception there leaves its
    compiler broken for the process): then after it."""
    from numba.core.compiler_lock import global_compiler_lock

    def compiling():            # held by another thread (is_locked() asks for this one)
        if global_compiler_lock._lock.acquire(blocking=False):
            global_compiler_lock._lock.release()
            return False
        return True
    while True:
        time.sleep(REPEAT_AFTER)
        while state["armed"] and compiling():
            time.sleep(0.05)
        if not state["armed"]:
            return
        # a real signal, to the main thread: it also ends a blocking wait there (EINTR),
        # which _thread.interrupt_main's simulated one does not
        signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)


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
                wait_for(COMPILED_IN.get(name, ()))    # a cold cache: not compiled twice
                result = BUILDERS[name](job)
            status, reason = "done", ""
        except Skip as e:
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
        notes = tuple(dict.fromkeys(_note(w) for w in caught))
        section = ReportSection(name, title, status, seconds=dt, reason=reason, notes=notes)
        if result is not None:
            section = ReportSection(name, title, status, seconds=dt, figure=result.figure,
                                    caption=result.caption, tables=tuple(result.tables),
                                    notes=notes)
        done[name] = section
        say(f"[{k + 1}/{len(SECTIONS)}] {title}: {status}"
            + (f" ({reason})" if status != "done" else "")
            + f", {dt:.1f} s (elapsed {time.perf_counter() - t_start:.1f} s)")
        write_page(job, done, time.perf_counter() - t_start)
    return done, interrupted


def _note(w) -> str:
    """A warning as the page shows it: its message, prefixed by its category where that is
    kapitza's own (e.g. "AveragingValidityWarning: ..."), not a Python built-in one."""
    category = w.category
    if category.__module__ == "builtins":
        return str(w.message)
    return f"{category.__name__}: {w.message}"


def _speaker(progress):
    if progress is False:
        return lambda message: None
    if callable(progress) and not isinstance(progress, bool):
        return progress

    def say(message):
        print(message, file=sys.stderr, flush=True)
    return say

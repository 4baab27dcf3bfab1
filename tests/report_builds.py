"""The shipped scenes' quick reports, each built once per test process for tests/test_report.py
and tests/test_report_browser.py (tests/conftest.py puts both files in one xdist group: the
default scene's quick report, ~11 s, was built once by each file).

A build records what either file checks: the report, its progress lines, the warnings that
reached the caller of ``build_report`` (a user's terminal), what it wrote on stderr, and
every saved figure's drawn extent (``Job.figure`` wrapped: the figure is measured after it
is saved, as saved: at the PNG's resolution, on the renderer that drew it, whose text
extents that draw has cached; measured at the screen's 100 dpi, every label and formula
was laid out afresh: 2.0 CPU-s for the seven scenes, 1.2 as saved).

The scenes of :data:`VIA_CLI` are built through the command line, in this process
(``kapitza report FILE --out DIR --quick --json``): tests/test_report.py checks the
command's exit code and JSON on that build (it built the scene a second time, 1.2 CPU-s).
The command writes its progress on stderr: those lines are the build's ``progress``, and
``stderr`` is the rest (a warning that escaped a section is one line there, the
command's one-line warning, for it shows warnings so).
"""
from __future__ import annotations

import contextlib
import dataclasses
import io
import re
import warnings

import pytest


@dataclasses.dataclass(frozen=True)
class Built:
    """A scene's quick report and what its build let through."""
    report: object
    progress: list     # the lines handed to ``progress`` (VIA_CLI: its lines on stderr)
    escaped: list      # warnings that reached the caller of build_report (its terminal)
    stderr: str        # what the build wrote on stderr (progress to a callable: nothing),
                       # VIA_CLI: besides its progress lines
    figures: list      # (name, tight bbox, figure bbox) of every saved figure, in inches
    cli: tuple | None = None    # (exit code, stdout) of the command: the scenes of VIA_CLI


_BUILT: dict[str, Built] = {}
#: The scenes built by ``kapitza report FILE --quick --json`` (in process).
VIA_CLI = ("horizontal_drive",)
#: A progress line of the report on stderr (build_report's progress=None): its first line,
#: "kapitza report: <title> -> <out>/ (quick)", a section's start and end, "[k/8] ...",
#: and its last, "kapitza report: done in <t> s: <out>/index.html".
_PROGRESS = re.compile(r"\[\d+/\d+\] |kapitza report: ((?!warning: ).* -> .*/ \(quick\)"
                       r"|done in [0-9.]+ s: .*/index\.html)$")


def _build(name, out) -> Built:
    from kapitza.report import build_report
    from kapitza.report._job import Job
    from kapitza.scenes import example_scenes

    extents, lines = [], []
    save = Job.figure

    def figure(self, fig, fname):
        rel = save(self, fig, fname)
        extents.append((fname, _saved_extent(fig), fig.bbox_inches))
        return rel
    err = io.StringIO()
    cli = None
    with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings(record=True) as caught, \
            contextlib.redirect_stderr(err):
        warnings.simplefilter("always")
        mp.setattr(Job, "figure", figure)
        if name in VIA_CLI:
            report, cli = _through_cli(example_scenes()[name], out, mp)
        else:
            report = build_report(example_scenes()[name], out, quick=True,
                                  progress=lines.append)
    stderr = err.getvalue()
    if cli is not None:
        lines = [x for x in stderr.splitlines() if _PROGRESS.match(x)]
        stderr = "".join(x for x in stderr.splitlines(keepends=True) if not _PROGRESS.match(x))
    if report is None:
        raise AssertionError(f"kapitza report {name} exited {cli[0]} without a report; "
                             f"stderr:\n{err.getvalue()}")
    return Built(report, lines, list(caught), stderr, extents, cli)


def _through_cli(path, out, mp):
    """(the Report, (exit code, stdout)) of ``kapitza report path --out out --quick
    --json``, run in process: the command's own call of build_report is the build (its
    result recorded on the way out)."""
    import kapitza.report
    from kapitza.cli import main
    build, built = kapitza.report.build_report, []

    def recorded(*args, **kwargs):
        built.append(build(*args, **kwargs))
        return built[-1]
    mp.setattr(kapitza.report, "build_report", recorded)
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        code = main(["report", str(path), "--out", str(out), "--quick", "--json"])
    return (built[0] if built else None), (code, stdout.getvalue())


def _saved_extent(fig):
    """The drawn extent (inches) of ``fig`` as ``savefig`` last drew it: on the canvas's
    renderer of that draw (Agg keeps it), at its resolution; the figure's dpi restored."""
    renderer = fig.canvas.renderer
    screen = fig.dpi
    fig.set_dpi(renderer.dpi)
    try:
        return fig.get_tightbbox(renderer)
    finally:
        fig.set_dpi(screen)


def quick_report(name: str, tmp_path_factory) -> Built:
    """``name``'s quick report (a key of ``kapitza.scenes.example_scenes()``; "report" is the
    default scene, ``kapitza/scenes/report.toml``), built on first use in this process."""
    if name not in _BUILT:
        _BUILT[name] = _build(name, tmp_path_factory.mktemp(f"scene-{name}"))
    return _BUILT[name]

"""The shipped scenes' quick reports, each built once per test process for tests/test_report.py
and tests/test_report_browser.py (tests/conftest.py puts both files in one xdist group: the
default scene's quick report, ~11 s, was built once by each file).

A build records what either file checks: the report, its progress lines, the warnings that
reached the caller of ``build_report`` (a user's terminal), what it wrote on stderr, and
every saved figure's drawn extent (``Job.figure`` wrapped: the figure is measured after it
is saved).
"""
from __future__ import annotations

import contextlib
import dataclasses
import io
import warnings

import pytest


@dataclasses.dataclass(frozen=True)
class Built:
    """A scene's quick report and what its build let through."""
    report: object
    progress: list     # the lines handed to ``progress``
    escaped: list      # warnings that reached the caller of build_report (its terminal)
    stderr: str        # what the build wrote on stderr (progress to a callable: nothing)
    figures: list      # (name, tight bbox, figure bbox) of every saved figure, in inches


_BUILT: dict[str, Built] = {}


def _build(name, out) -> Built:
    from kapitza.report import build_report
    from kapitza.report._job import Job
    from kapitza.scenes import example_scenes

    extents, lines = [], []
    save = Job.figure

    def figure(self, fig, fname):
        rel = save(self, fig, fname)
        extents.append((fname, fig.get_tightbbox(), fig.bbox_inches))
        return rel
    err = io.StringIO()
    with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings(record=True) as caught, \
            contextlib.redirect_stderr(err):
        warnings.simplefilter("always")
        mp.setattr(Job, "figure", figure)
        report = build_report(example_scenes()[name], out, quick=True, progress=lines.append)
    return Built(report, lines, list(caught), err.getvalue(), extents)


def quick_report(name: str, tmp_path_factory) -> Built:
    """``name``'s quick report (a key of ``kapitza.scenes.example_scenes()``; "report" is the
    default scene, ``kapitza/scenes/report.toml``), built on first use in this process."""
    if name not in _BUILT:
        _BUILT[name] = _build(name, tmp_path_factory.mktemp(f"scene-{name}"))
    return _BUILT[name]

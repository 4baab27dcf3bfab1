"""What every study shares: where results go, how tables, figures and findings are written,
and the command line of a study script.

A study is one module ``studies/<name>.py`` answering one question.  It defines

``QUESTION``
    The question, one sentence (the first line of its section in ``studies/README.md``).
``run(out: Path, quick: bool = False) -> dict``
    Computes, writes ``<out>/<name>.parquet`` and ``.csv`` (:func:`write_table`) and
    ``<out>/<name>.png`` (:func:`save_figure`), and returns the *findings*: a flat dict of
    named numbers (and short strings) that the README quotes.  ``quick=True`` is the reduced
    size the test suite runs (seconds once the kernels are compiled); the full size runs in a
    few minutes on a 2-core machine.
``check(findings: dict, quick: bool) -> None``
    Asserts the study's physics against something independent (a closed form, a published
    value, another method), at the size it ran.  ``tests/test_studies.py`` runs
    ``check(run(tmp, quick=True), quick=True)`` for every study.

``python studies/<name>.py`` runs the full size into ``studies/results/<name>/`` and prints
the findings; ``--quick`` runs the reduced size; ``--out DIR`` writes elsewhere.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

#: Full-size results (figures shown by studies/README.md, data, findings.json).
RESULTS = Path(__file__).resolve().parent / "results"

__all__ = ["RESULTS", "write_table", "save_figure", "layout", "write_findings", "main"]


def write_table(frame, out: Path, name: str) -> Path:
    """``frame`` (a pandas DataFrame) as ``<out>/<name>.parquet`` and ``<out>/<name>.csv``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    frame.to_parquet(out / f"{name}.parquet")
    frame.to_csv(out / f"{name}.csv", index=False)
    return out / f"{name}.parquet"


def save_figure(fig, out: Path, name: str, dpi: int = 110, quick: bool = False) -> Path:
    """``fig`` (a matplotlib Figure) as ``<out>/<name>.png``; the figure is closed.

    The full size trims the margins (``bbox_inches="tight"``: the figures of the README);
    ``quick`` (the reduced size the tests run, whose figure is only looked at) saves the
    whole canvas: the trim draws the figure once more, 20-40 % of the save.
    """
    import matplotlib.pyplot as plt
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{name}.png"
    fig.savefig(path, dpi=dpi, **({} if quick else {"bbox_inches": "tight"}))
    plt.close(fig)
    return path


def layout(fig, quick: bool = False, **kwargs) -> None:
    """``fig.tight_layout(**kwargs)`` at full size; none at the reduced size (``quick``),
    whose figure is only looked at: the layout measures every tick label's extent, up to
    1.7 s of a reduced run's 3.7 (averaging_accuracy)."""
    if not quick:
        fig.tight_layout(**kwargs)


def _plain(value):
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def write_findings(findings: dict, out: Path) -> Path:
    """The findings as ``<out>/findings.json`` (numbers as JSON numbers, NaN as "nan")."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "findings.json"
    path.write_text(json.dumps({k: _plain(v) for k, v in findings.items()}, indent=1) + "\n")
    return path


def main(module_name: str, run, argv=None) -> int:
    """The command line of a study (``module_name``: its ``__name__`` or its file's stem):
    full size into studies/results/<name>/ by default."""
    # run as a script the module is "__main__": its file names the study
    name = Path(getattr(sys.modules.get(module_name), "__file__", None) or module_name).stem
    parser = argparse.ArgumentParser(prog=f"studies/{name}.py")
    parser.add_argument("--quick", action="store_true", help="the reduced size the tests run")
    parser.add_argument("--out", type=Path, default=None,
                        help=f"output folder (default studies/results/{name})")
    args = parser.parse_args(argv)
    out = args.out or RESULTS / name
    start = time.perf_counter()
    findings = run(out, quick=args.quick)
    findings["wall_time_s"] = round(time.perf_counter() - start, 1)
    write_findings(findings, out)
    for key, value in findings.items():
        print(f"{key:>40s}  {value}")
    print(f"written to {out}", file=sys.stderr)
    return 0

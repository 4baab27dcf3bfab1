"""What a command writes: results on stdout (text, or JSON with ``--json``), messages on
stderr, data files, and the exit codes.

Numbers that are not finite: JSON has no literal for them, so ``--json`` writes ∞, −∞
and NaN as the strings ``"inf"``, ``"-inf"`` and ``"nan"`` — the tokens the text output
prints for the same values (Python's ``float()`` and ``pandas.to_numeric`` read them
back).  ``null`` means no value at all (a file not written, a field that does not apply).
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import sys
from pathlib import Path

import numpy as np

#: The exit codes: success; a disagreement between methods that both claim validity
#: (``verify``), a failed report section or catalogue problem; a usage, input or scene
#: error; an internal error (a bug: the message says how to see the traceback);
#: interrupted (Ctrl-C).
EXIT_OK, EXIT_DISAGREEMENT, EXIT_USAGE, EXIT_INTERNAL, EXIT_INTERRUPTED = 0, 1, 2, 70, 130

#: The exit codes as ``kapitza --help`` and the module docstrings state them.
EXIT_CODES_TEXT = (f"exit codes: {EXIT_OK} success; {EXIT_DISAGREEMENT} methods that both "
                   "claim validity disagree (verify), a report section or a catalogue "
                   f"problem failed; {EXIT_USAGE} a usage, input or scene error; "
                   f"{EXIT_INTERNAL} an internal error (a bug; --traceback or "
                   f"KAPITZA_DEBUG=1 shows where); {EXIT_INTERRUPTED} interrupted (Ctrl-C, "
                   "what finished is kept)")


def non_finite(x: float) -> str:
    """The token of ∞, −∞ or NaN in both the text and the JSON output."""
    return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")


def plain(x):
    """``x`` in JSON's terms: arrays as lists, ±inf and NaN as the strings "inf", "-inf",
    "nan" (the module docstring), complex as [re, im]."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {f.name: plain(getattr(x, f.name)) for f in dataclasses.fields(x)
                if f.repr and not callable(getattr(x, f.name))}
    if isinstance(x, dict):
        return {str(k): plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return plain(x.tolist())
    if isinstance(x, np.generic):
        return plain(x.item())
    if isinstance(x, bool) or x is None or isinstance(x, (int, str)):
        return x
    if isinstance(x, float):
        return x if math.isfinite(x) else non_finite(x)
    if isinstance(x, complex):
        return [plain(x.real), plain(x.imag)]
    if isinstance(x, Path):
        return str(x)
    return str(x)


def records(frame):
    """A DataFrame as a list of JSON rows."""
    return plain(frame.to_dict(orient="records"))


def emit(args, data: dict, text: str) -> None:
    """Results on stdout: JSON with ``--json``, else ``text``."""
    if args.json:
        json.dump(plain(data), sys.stdout, indent=1, allow_nan=False)
        sys.stdout.write("\n")
    else:
        print(text)
    sys.stdout.flush()


def say(message: str) -> None:
    print(plain_message(message), file=sys.stderr, flush=True)


#: numpy's reprs in a message: ``array(0.)``, ``array([1., 2.])``, ``np.float64(0.05)``,
#: ``np.str_('x')`` (the API's messages use repr; the command line shows the value).
_NUMPY_REPR = re.compile(r"\b(?:np\.(?:float|int|uint|complex|bool|str|bytes)_?\d*|array)"
                         r"\(((?:[^()]|\([^()]*\))*?)(?:,\s*dtype=[\w.]+)?\)")


def plain_message(message: str) -> str:
    """``message`` with numpy's reprs replaced by the plain values they show:
    "got array(0.)" → "got 0.0", "np.float64(0.05)" → "0.05"."""
    return _NUMPY_REPR.sub(lambda m: re.sub(r"(\d)\.(?!\d)", r"\1.0", m.group(1)),
                           str(message))


def as_table(frame) -> str:
    """A DataFrame as text: numbers to 6 significant digits, missing values as "nan"."""
    import pandas as pd
    with pd.option_context("display.width", 200, "display.max_columns", 30,
                           "display.max_rows", 60, "display.float_format", "{:.6g}".format):
        return frame.to_string(index=False, na_rep="nan")


def write_frame(frame, path: Path) -> Path:
    """Write ``frame`` to ``path`` (.parquet, else CSV) whole or not at all (:func:`whole`)."""
    def write(tmp):
        if Path(path).suffix == ".parquet":
            frame.to_parquet(tmp, index=False)
        else:
            frame.to_csv(tmp, index=False)
    return whole(path, write)


def save_figure(fig, path, dpi=120) -> Path:
    """Save a matplotlib figure to ``path`` (its format from the suffix) whole or not at
    all (:func:`whole`); a PNG drawn once (:func:`kapitza.figures.save_png`)."""
    fmt = Path(path).suffix.lstrip(".").lower() or None
    if fmt == "png":
        from ..figures import save_png
        return whole(path, lambda tmp: save_png(fig, tmp, dpi))
    return whole(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format=fmt))


def whole(path, write) -> Path:
    """``write(tmp)`` into a temporary file beside ``path``, renamed over it when complete:
    an interrupted or failed write (Ctrl-C, a full disk) leaves the old file or none, never
    half of one.  An OSError names ``path``, not the temporary file."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write(tmp)
        os.replace(tmp, path)
    except OSError as e:
        raise OSError(e.errno, e.strerror, str(path)) from e
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def with_error(value, error) -> str:
    """``value ± error`` with the value's digits down to the error's second digit."""
    if not (math.isfinite(value) and math.isfinite(error) and error > 0):
        return f"{value:.6g} ± {error:.2g}"
    decimals = min(12, max(0, 1 - math.floor(math.log10(error))))
    return f"{value:.{decimals}f} ± {error:.2g}"

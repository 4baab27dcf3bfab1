"""What a command writes: results on stdout (text, or JSON with ``--json``), messages on
stderr, data files, and the exit codes."""
from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np

#: The exit codes: success, a disagreement beyond tolerance (or a failed catalogue problem),
#: a usage or scene error, Ctrl-C.
EXIT_OK, EXIT_DISAGREEMENT, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


def plain(x):
    """``x`` in JSON's terms: arrays as lists, NaN and ±inf as null, complex as [re, im]."""
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
        return x if math.isfinite(x) else None
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
    print(message, file=sys.stderr, flush=True)


def as_table(frame) -> str:
    import pandas as pd
    with pd.option_context("display.width", 200, "display.max_columns", 30,
                           "display.max_rows", 60, "display.float_format", "{:.6g}".format):
        return frame.to_string(index=False)


def write_frame(frame, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".parquet":
        frame.to_parquet(path, index=False)
    else:
        frame.to_csv(path, index=False)
    return path


def with_error(value, error) -> str:
    """``value ± error`` with the value's digits down to the error's second digit."""
    if not (math.isfinite(value) and math.isfinite(error) and error > 0):
        return f"{value:.6g} ± {error:.2g}"
    decimals = min(12, max(0, 1 - math.floor(math.log10(error))))
    return f"{value:.{decimals}f} ± {error:.2g}"

"""A scene file's problems, collected and raised together.

:class:`Checker` checks values (numbers in range, choices, tables with known keys) and
records what is wrong instead of raising; :meth:`Checker.done` raises every problem at
once as a :class:`SceneError`, each naming the file, the dotted key, its line (from a
light scan of the TOML text, :func:`key_lines`), what is allowed, and the nearest
allowed key for a misspelt one.  The checks of each table are in :mod:`._file`.
"""
from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass

__all__ = ["SceneError", "SceneProblem", "Checker", "key_lines", "kind_of"]


@dataclass(frozen=True)
class SceneProblem:
    """One problem of a scene file: the dotted key, its line (None where unknown), what
    is wrong and what is allowed."""

    key: str
    line: int | None
    message: str

    def format(self, source: str) -> str:
        where = f"{source}:{self.line}" if self.line else source
        return f"{where}: {self.key}: {self.message}"


class SceneError(ValueError):
    """Every problem found in a scene file, raised together.

    Attributes
    ----------
    source : str
        The file (or "<text>").
    problems : tuple of SceneProblem
    """

    def __init__(self, source: str, problems):
        self.source = str(source)
        self.problems = tuple(problems)
        n = len(self.problems)
        head = f"scene {self.source} has {n} error{'s' if n != 1 else ''}:"
        super().__init__("\n  ".join([head] + [p.format(self.source) for p in self.problems]))


def key_lines(text: str) -> dict:
    """The line of every table header and key of a TOML text (dotted key → line number).

    A light scan, not a parser (tomllib has already accepted the text): table headers,
    ``key =`` lines (dotted keys included) and the keys of inline tables on those lines;
    the lines inside a multi-line array or string are skipped."""
    lines: dict = {}
    table: list = []
    depth = 0
    in_string = False
    key_re = r'(?:[A-Za-z0-9_-]+|"[^"]*"|\'[^\']*\')'
    for no, raw in enumerate(text.splitlines(), 1):
        if in_string:
            if raw.count('"""') % 2 or raw.count("'''") % 2:
                in_string = False
            continue
        s = _strip_comment(raw).strip()
        if not s:
            continue
        if depth > 0:
            depth += _balance(s)
            continue
        m = re.fullmatch(r"\[\[?\s*(" + key_re + r"(?:\s*\.\s*" + key_re + r")*)\s*\]\]?", s)
        if m:
            table = _split_key(m.group(1))
            lines.setdefault(".".join(table), no)
            continue
        m = re.match(r"(" + key_re + r"(?:\s*\.\s*" + key_re + r")*)\s*=(.*)", s)
        if not m:
            continue
        key = table + _split_key(m.group(1))
        lines.setdefault(".".join(key), no)
        value = m.group(2)
        for inner in re.finditer(r"[{,]\s*(" + key_re + r")\s*=", value):
            lines.setdefault(".".join(key + _split_key(inner.group(1))), no)
        if value.count('"""') % 2 or value.count("'''") % 2:
            in_string = True
        depth = max(0, _balance(value))
    return lines


def _strip_comment(line: str) -> str:
    quote = None
    for i, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            return line[:i]
    return line


def _balance(s: str) -> int:
    s = re.sub(r'"[^"]*"|\'[^\']*\'', "", s)
    return s.count("[") + s.count("{") - s.count("]") - s.count("}")


def _split_key(k: str) -> list:
    return [p.strip().strip("\"'") for p in re.findall(r'"[^"]*"|\'[^\']*\'|[^.]+', k)]


class Checker:
    """Collects the problems of one scene file (never raises until :meth:`done`)."""

    def __init__(self, source: str, text: str):
        self.source = source
        self.lines = key_lines(text)
        self.problems: list = []

    def line(self, key: str):
        parts = re.sub(r"\[\d+\]", "", key).split(".")
        while parts:
            no = self.lines.get(".".join(parts))
            if no:
                return no
            parts.pop()
        return None

    def error(self, key: str, message: str):
        self.problems.append(SceneProblem(key, self.line(key), message))

    def unknown(self, key: str, name: str, allowed, what: str = "key", extra: str = ""):
        allowed = list(allowed)
        lower = {a.lower(): a for a in allowed}
        close = difflib.get_close_matches(name.lower(), list(lower), n=1, cutoff=0.6)
        hint = f". Did you mean {lower[close[0]]!r}?" if close else ""
        shown = ", ".join(allowed) if allowed else "none"
        self.error(key, f"unknown {what} {name!r}; allowed: {shown}{extra}{hint}")

    def table(self, value, key: str, allowed, *, what: str = "key"):
        """``value`` as a dict whose keys are all in ``allowed`` (unknown ones reported);
        None (reported) if it is not a table."""
        if not isinstance(value, dict):
            self.error(key, f"must be a table, got {kind_of(value)} {value!r}")
            return None
        for k in value:
            if k not in allowed:
                self.unknown(f"{key}.{k}" if key else k, k, allowed, what)
        return value

    def number(self, value, key: str, *, unit: str = "", minimum=None, strict=False,
               integer=False):
        """A finite number (an integer where asked) in range, else None (reported)."""
        unit_s = f" ({unit})" if unit else ""
        if integer:
            if isinstance(value, bool) or not isinstance(value, int):
                self.error(key, f"must be a whole number{unit_s}, got {kind_of(value)} {value!r}")
                return None
        elif isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value):
            self.error(key, f"must be a finite number{unit_s}, got {kind_of(value)} {value!r}")
            return None
        if minimum is not None and (value <= minimum if strict else value < minimum):
            self.error(key, f"must be {'>' if strict else '≥'} {minimum:g}{unit_s}, got {value!r}")
            return None
        return value if integer else float(value)

    def one_of(self, table: dict, key: str, names, what: str, required: bool = True):
        """The one of ``names`` that ``table`` has; a missing (if ``required``) or a second
        one is reported."""
        given = [k for k in names if k in table]
        if len(given) > 1:
            self.error(f"{key}.{given[1]}", f"give one of {' and '.join(names)}, not both")
        elif not given and required:
            self.error(f"{key}.{names[0]}", f"missing; give {what}")
        return given[0] if len(given) == 1 else None

    def boolean(self, value, key: str):
        if not isinstance(value, bool):
            self.error(key, f"must be true or false, got {kind_of(value)} {value!r}")
            return None
        return value

    def choice(self, value, key: str, allowed):
        if not isinstance(value, str):
            self.error(key, f"must be one of {', '.join(map(repr, allowed))}, got "
                            f"{kind_of(value)} {value!r}")
            return None
        if value not in allowed:
            self.unknown(key, value, allowed, what="value")
            return None
        return value

    def done(self):
        if self.problems:
            raise SceneError(self.source, self.problems)


def kind_of(value) -> str:
    """What ``value`` is, in the words of a message ("an integer", "a table", ...)."""
    return {bool: "a boolean", int: "an integer", float: "a number", str: "text",
            list: "an array", dict: "a table"}.get(type(value), type(value).__name__)


"""Rich display of results in Jupyter: a compact card per result (``_repr_html_``).

Every result type declares its headline rows in its ``_repr_html_`` and calls
:func:`card`, which lays them out the same way everywhere: a title (the type and what
it is about), a small table of the headline numbers with their units and errors
("Ω = 12.98 rad/s ± 4e-10"), badges ("stable", "outside validity"), every warning
visible (a result outside validity or flagged has an amber edge and says why), and for
a grid a thumbnail of its default figure.

The thumbnail is drawn only when the card is (a notebook displays it), from the result's
own ``figure()``, at a low resolution (:data:`THUMBNAIL_PIXELS` wide), with the legend
left out; a figure that cannot be drawn leaves a note instead of an error, for a repr
must never raise.  Drawing it costs ~0.1–0.3 s for a map (``tests/test_repr_html.py``
bounds it).  ``THUMBNAILS = False`` (this module) turns thumbnails off.

Everything shown is escaped (:func:`html.escape`); the markup uses inline styles only
(notebook front ends strip ``<style>`` blocks from untrusted output).
"""
from __future__ import annotations

import ast
import base64
import html
import io
import math
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

from ._xarray import quantity_of

__all__ = ["card", "number", "quantity", "span", "share", "draw", "unit", "symbol",
           "axis_rows", "state", "THUMBNAILS", "THUMBNAIL_PIXELS"]

#: Draw thumbnails of gridded results (False: tables only).
THUMBNAILS = True
#: Width of a thumbnail in pixels.
THUMBNAIL_PIXELS = 260

_TONES = {"good": ("#1b7837", "#ffffff"), "bad": ("#b2182b", "#ffffff"),
          "warn": ("#b35806", "#ffffff"), "info": ("#5a5a5a", "#ffffff")}


def number(x, digits: int = 4) -> str:
    """``x`` to ``digits`` significant digits; "NaN", "∞" spelled out; "—" for None."""
    if x is None:
        return "—"
    if isinstance(x, (bool, np.bool_)):
        return "yes" if x else "no"
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    if math.isnan(v):
        return "NaN"
    if math.isinf(v):
        return "∞" if v > 0 else "−∞"
    text = f"{v:.{digits}g}"
    return "−" + text[1:] if text.startswith("-") else text     # a typographic minus sign


def quantity(x, unit: str = "", error=None, digits: int = 4) -> str:
    """A number with its unit and error: "12.98 rad/s ± 4e-10" (the error to one digit)."""
    text = number(x, digits) + (f" {unit}" if unit else "")
    if error is not None and np.ndim(error) == 0 and math.isfinite(float(error)):
        text += f" ± {number(error, 1)}"
    return text


def span(values, unit: str = "", digits: int = 4, what: str = "values") -> str:
    """The range of an array: "5 … 200 rad/s (120 values)"; one value as itself; NaNs
    counted ("… (3 of 10 NaN)")."""
    v = np.asarray(values, dtype=float).reshape(-1)
    if v.size == 0:
        return "none"
    finite = v[np.isfinite(v)]
    nans = int(np.count_nonzero(np.isnan(v)))
    if finite.size == 0:
        body = "NaN" if nans == v.size else number(v[~np.isnan(v)][0], digits)
    elif finite.min() == finite.max():
        body = number(finite[0], digits)
    else:
        body = f"{number(finite.min(), digits)} … {number(finite.max(), digits)}"
    body += f" {unit}" if unit else ""
    extra = [f"{v.size} {what}"] if v.size > 1 else []
    if nans and finite.size:
        extra.append(f"{nans} NaN")
    return body + (f" ({', '.join(extra)})" if extra else "")


def share(mask, of: str = "points") -> str:
    """How many of a boolean array are true: "12 of 40 points (30 %)"."""
    m = np.asarray(mask, dtype=bool).reshape(-1)
    if m.size == 0:
        return f"0 {of}"
    return f"{int(m.sum())} of {m.size} {of} ({100 * m.mean():.0f} %)"


#: How a parameter is written on a card.
SYMBOLS = {"omega": "ω", "gamma": "γ", "damping": "γ", "theta": "θ"}


def unit(name: str) -> str:
    """The unit of a parameter kapitza knows, as printed ("m" for A, "m/s²" for g), ""
    otherwise."""
    return (quantity_of(name)[0] or "").replace("^2", "²")


def symbol(name: str) -> str:
    """A parameter's name as written on a card ("ω" for omega)."""
    return SYMBOLS.get(name, name)


def axis_rows(params: dict) -> list:
    """Rows for the parameters that vary over a grid: their distinct values' range."""
    rows = []
    for name, values in params.items():
        v = np.unique(np.asarray(values, dtype=float).reshape(-1))
        if v.size > 1:
            rows.append((symbol(name), span(v, unit(name))))
    return rows


def state(about) -> str:
    """An equilibrium for a card: its name as given, or its coordinates with multiples of
    π spelled so: "q = (π, 0)"."""
    if isinstance(about, str) and not about.lstrip().startswith(("[", "(")):
        return about
    try:
        values = ast.literal_eval(about) if isinstance(about, str) else about
        values = np.atleast_1d(np.asarray(values, dtype=float)).reshape(-1)
    except (ValueError, TypeError, SyntaxError):
        return str(about)
    parts = []
    for v in values:
        quarter = round(v / math.pi * 4) / 4
        close = abs(v / math.pi - quarter) < 1e-8
        parts.append(("0" if quarter == 0 else "π" if quarter == 1 else f"{quarter:g}π")
                     if close else number(v, 6))
    return f"q = ({', '.join(parts)})"


def draw(function: str, *args, **options):
    """``kapitza.figures.<function>(*args, **options)``: a result's figure, drawn by the
    figures room (imported here, when a figure is asked for: it sits above the results)."""
    from .. import figures
    return getattr(figures, function)(*args, **options)


def thumbnail(make: Callable[[], Any]) -> tuple[str | None, str | None]:
    """(a PNG data URI of the figure ``make()`` returns, None) or (None, why not)."""
    try:
        # the figures room sits above the results: imported here, as in draw (and inside
        # the try: a repr must never raise, not even for a figure that cannot be imported)
        from ..figures import save_png
        fig = make()
        for ax in fig.axes:
            legend = ax.get_legend()
            if legend is not None:
                legend.remove()                 # too small to read at this size
        width = fig.get_figwidth()
        buffer = io.BytesIO()
        save_png(fig, buffer, THUMBNAIL_PIXELS / width)
    except Exception as error:                  # a repr must never raise
        return None, f"no thumbnail: {type(error).__name__}: {error}"
    data = base64.b64encode(buffer.getvalue()).decode("ascii")
    return f"data:image/png;base64,{data}", None


def _badge(text: str, tone: str) -> str:
    back, fore = _TONES.get(tone, _TONES["info"])
    return (f'<span style="background:{back};color:{fore};border-radius:3px;'
            f'padding:0 5px;margin-left:6px;font-size:11px">{html.escape(text)}</span>')


def card(kind: str, about: str = "", *, rows: Iterable[tuple[str, str]] = (),
         badges: Iterable[tuple[str, str]] = (), warnings: Iterable[str] = (),
         notes: Iterable[str] = (), figure: Callable[[], Any] | None = None,
         alt: str = "") -> str:
    """The HTML of a result's card.

    Parameters
    ----------
    kind : str
        The result's type, e.g. "StabilityMap".
    about : str
        What it is about, after the type ("the inverted state · monodromy").
    rows : iterable of (label, value)
        The headline numbers, already formatted with their units (:func:`quantity`,
        :func:`span`, :func:`share`).
    badges : iterable of (text, tone)
        Short words beside the title; tone "good", "bad", "warn" or "info".
    warnings : iterable of str
        Shown in amber, each with ⚠; any warning also colours the card's edge.
    notes : iterable of str
        Shown in grey.
    figure : callable returning a matplotlib Figure, optional
        Draws the thumbnail (only when :data:`THUMBNAILS`).
    alt : str
        The thumbnail's alternative text.
    """
    warnings, notes, badges = list(warnings), list(notes), list(badges)
    edge = _TONES["warn"][0] if warnings else "#9e9e9e"
    parts = [f'<div class="kapitza-result" style="display:inline-block;max-width:820px;'
             f'border:1px solid #c8c8c8;border-left:4px solid {edge};border-radius:4px;'
             f'padding:6px 10px;margin:2px 0;font-family:sans-serif;font-size:13px;'
             f'line-height:1.35;text-align:left">',
             f'<div style="margin-bottom:4px"><b>{html.escape(kind)}</b>'
             + (f' <span style="opacity:0.75">{html.escape(about)}</span>' if about else "")
             + "".join(_badge(t, tone) for t, tone in badges) + "</div>",
             '<div style="display:flex;gap:14px;align-items:flex-start">']
    cells = "".join(
        f'<tr><th style="text-align:left;font-weight:normal;opacity:0.8;'
        f'padding:1px 10px 1px 0;vertical-align:top;white-space:nowrap">{html.escape(label)}'
        f'</th><td style="text-align:left;padding:1px 0">{html.escape(value)}</td></tr>'
        for label, value in rows)
    parts.append(f'<table style="border-collapse:collapse;margin:0">{cells}</table>')
    if figure is not None and THUMBNAILS:
        uri, why = thumbnail(figure)
        if uri is not None:
            parts.append(f'<img src="{uri}" alt="{html.escape(alt or kind, quote=True)}" '
                         f'width="{THUMBNAIL_PIXELS}" style="flex:none">')
        else:
            notes.append(why or "no thumbnail")
    parts.append("</div>")
    lines = [("#b35806", "⚠ " + w) for w in warnings] + [("#6b6b6b", n) for n in notes]
    if lines:
        parts.append('<ul style="margin:4px 0 0 0;padding-left:16px">' + "".join(
            f'<li style="color:{color}">{html.escape(text)}</li>' for color, text in lines)
            + "</ul>")
    parts.append("</div>")
    return "".join(parts)

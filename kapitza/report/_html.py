"""The report's page, ``index.html``: one self-contained file (inline CSS, no JavaScript,
relative links), rewritten atomically after every section so that an interrupted run
still leaves a page naming what is missing."""
from __future__ import annotations

import datetime as _dt
import html
import platform
from pathlib import Path

import numpy as np

from ._job import Job, default_scene_path
from ._sections import SECTIONS

_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;max-width:1100px;
margin:2em auto;padding:0 1em;color:#222;line-height:1.45}
h1{font-size:1.6em;margin-bottom:.2em}h2{font-size:1.25em;margin-top:2em;
border-bottom:1px solid #ccc;padding-bottom:.2em}
/* a table wider than the column scrolls inside its wrapper, never the page */
.tw{max-width:100%;overflow-x:auto;margin:.6em 0}
table{border-collapse:collapse;font-size:.85em}
td,th{border:1px solid #ddd;padding:.2em .5em;text-align:right}th{background:#f4f4f4}
td.l,th.l{text-align:left}
img{max-width:100%;height:auto;border:1px solid #eee}
.caption{font-size:.95em;margin:.4em 0 1em}
.note{background:#fff7e0;border-left:4px solid #e0a800;padding:.5em .8em}
.fail{background:#fde8e8;border-left:4px solid #c0392b;padding:.5em .8em}
.meta{font-size:.9em;color:#444}
details{margin:.5em 0}
"""


#: Significant digits of a number in a table on the page (the data files keep them all).
DIGITS = 4


def _fmt(x) -> str:
    """A cell as the page shows it: yes/no, a number to :data:`DIGITS` significant digits
    (an exponent only beyond 1e±5: "3.49e+95"), "—" for a missing value (NaN; the
    column's caption or the data files say why), "∞"/"−∞" for an infinite one."""
    if isinstance(x, (bool, np.bool_)):
        return "yes" if x else "no"
    if isinstance(x, (float, np.floating)):
        if not np.isfinite(x):
            return "—" if np.isnan(x) else ("∞" if x > 0 else "−∞")
        if x == 0:
            return "0"
        if 1e-4 <= abs(x) < 1e5:
            return f"{x:.{DIGITS}g}"
        return f"{x:.{DIGITS - 1}e}".replace("e+0", "e+").replace("e-0", "e-")
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
    return f"<div class=tw><table><tr>{head}</tr>{''.join(rows)}</table></div>{more}"


def _versions() -> dict:
    import matplotlib
    import numba
    import scipy

    from .._version import __version__
    return {"kapitza": __version__, "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__, "numba": numba.__version__,
            "matplotlib": matplotlib.__version__}


def write_page(job: Job, done: dict, seconds: float) -> None:
    """Write index.html with the sections finished so far (atomic: a temp file, renamed)."""
    scene = job.scene
    esc = html.escape
    source = scene.spec.source
    if Path(str(source)).resolve() == default_scene_path().resolve():
        source = "the built-in scene kapitza/scenes/report.toml"     # not this machine's path
    title = scene.spec.title or Path(source).stem
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
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
    parts.append(f"<div class=tw><table><tr><th class=l>section</th><th class=l>status</th>"
                 f"<th>wall time (s)</th></tr>{rows}</table></div>")
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
                              f"<a href='data/{t}.csv'>CSV</a>, <a href='data/{t}.csv-"
                              "metadata.json'>metadata</a>)" for t in s.tables)
            parts.append(f"<p class=meta>Data: {links}</p>")
    rows = []
    for name, (rows_n, section) in job.state.get("table_rows", {}).items():
        rows.append(f"<tr><td class=l>{esc(name)}</td><td class=l>{esc(SECTIONS[section])}"
                    f"</td><td>{rows_n}</td><td class=l><a href='data/{name}.parquet'>"
                    f"data/{name}.parquet</a></td><td class=l><a href='data/{name}.csv'>"
                    f"data/{name}.csv</a> (<a href='data/{name}.csv-metadata.json'>"
                    "metadata</a>)</td></tr>")
    parts.append("<h2 id=data>Data files</h2><div class=tw><table><tr><th class=l>table</th>"
                 "<th class=l>section</th><th>rows</th><th class=l>Parquet</th>"
                 f"<th class=l>CSV</th></tr>{''.join(rows)}</table></div>")
    parts.append("</body></html>\n")
    path = job.out / "index.html"
    tmp = path.with_suffix(".html.tmp")
    tmp.write_text("\n".join(parts), encoding="utf-8")
    tmp.replace(path)

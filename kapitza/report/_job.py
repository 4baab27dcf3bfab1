"""What the report's sections share: the scene and its facts (:class:`Job`), where the
files go, what a section returns (:class:`SectionResult`) and how it says it does not
apply (:class:`Skip`)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from matplotlib.figure import Figure


#: The integrator of every simulated grid (spot checks, slow frequencies, verification):
#: DOP853 at rtol 1e-9 gives the same classifications and Ω (to 1e-9 relative here) as
#: the default RKN 12 on lanes, and its grid kernel compiles in ≈ 13 s on a cold cache
#: against ≈ 90 s for the lanes kernel: the report's 3-minute budget includes compiling.
GRID_METHOD = "dop853"


class Skip(Exception):
    """A section that does not apply: its message is the reason shown on the page."""


def default_scene_path() -> Path:
    """The embedded default scene, ``kapitza/scenes/report.toml``."""
    from importlib import resources
    return Path(str(resources.files("kapitza") / "scenes" / "report.toml"))


@dataclass
class SectionResult:
    """What a section computed: its figure (relative to the report folder), the finding in
    numbers, the names of its data tables."""

    figure: Path | None
    caption: str
    tables: list = field(default_factory=list)


@dataclass
class Job:
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
        return bool(self.scene.drive.keeps_vertical_equilibria)

    @property
    def fixed(self) -> dict:
        """The parameters other than the drive's A and ω."""
        return {k: v for k, v in self.params.items() if k not in ("A", "omega")}

    @property
    def about_setting(self):
        """How the scene names the state its analyses are about: the ``about`` of its
        stability map, Floquet analysis, measurement, verification, window or continuation
        (the first one given), else "auto" (the declared state nearest the initial one)."""
        for analysis in ("stability_map", "floquet", "measure", "verify", "window",
                         "continuation"):
            about = self.scene.analyses.get(analysis, {}).get("about")
            if about is not None:
                return about
        return "auto"

    @property
    def about(self) -> np.ndarray:
        """The state every section is about, (n,) in the rig's units: the scene's choice
        (:attr:`about_setting`) resolved against the states its rig declares — for a
        user's rig with a length coordinate, e.g. r = l0 + m g/k, not π."""
        if "about" not in self.state:
            from ..scenes import about_state
            about = np.asarray(about_state(self.scene, self.about_setting), dtype=float)
            self.state["about"] = about.reshape(self.scene.system.n_dof)
        return self.state["about"].copy()

    @property
    def units(self) -> dict:
        """Coordinate → its unit ("rad", "m" or "1")."""
        return dict(self.scene.spec.units or {q: "rad" for q in self.scene.system.coordinates})

    @property
    def angles(self) -> np.ndarray:
        """Which coordinates are angles (bool, (n,))."""
        units = self.units
        return np.array([units.get(q, "rad") == "rad" for q in self.scene.system.coordinates])

    @property
    def pend_about(self) -> str:
        """The single pendulum's state: "inverted" (θ = π) or "hanging" (θ = 0)."""
        return "inverted" if math.cos(float(self.about[0])) < 0 else "hanging"

    @property
    def upright_state(self) -> bool:
        """Whether the state is the upright one (every angle at π modulo 2π)."""
        about = self.about
        return bool(self.angles.all() and np.all(np.cos(about) < -1 + 1e-9))

    @property
    def persists(self) -> bool:
        """Whether the state is an equilibrium of the driven system (else the drive moves
        it and the analyses follow the periodic orbit born from it)."""
        if "persists" not in self.state:
            from ..scenes import persists
            self.state["persists"] = bool(persists(self.scene, self.about))
        return self.state["persists"]

    def release(self, offset_angle: float) -> np.ndarray:
        """A start near :attr:`about`: each angle ``offset_angle`` (rad) off, alternating
        in sign; each other coordinate 1 % of its value (or 0.01 of its unit at 0) off."""
        about = self.about
        sign = (-1.0) ** np.arange(about.size)
        other = np.where(about != 0, 0.01 * np.abs(about), 0.01)
        return about + sign * np.where(self.angles, offset_angle, other)

    def band(self):
        """The measurement's band about :attr:`about`, per coordinate in its unit (the
        scene's ``measure.band`` where given; else π/2 for an angle, half its value for a
        length)."""
        from ..scenes import default_band
        return default_band(self.units, list(self.scene.system.coordinates), self.about,
                            self.setting("measure", "band", None))

    def setting(self, analysis, key, default):
        return self.scene.analyses.get(analysis, {}).get(key, default)

    def axis(self, analysis, key, default):
        """A grid axis (SI) from the scene's ``[analyses]``, or ``default``."""
        # the scene reader gives ω in rad/s (a file's frequency_hz converted where it is read)
        s = self.scene.analyses.get(analysis, {})
        if key in s:
            return np.asarray(s[key].values, dtype=float)
        return np.asarray(default, dtype=float)

    # -- output --------------------------------------------------------------------------
    def figure(self, fig, name: str) -> Path:
        """Save ``fig`` as figures/<name>.png (150 dpi: sharp on high-density screens),
        every title first wrapped to fit the figure (:func:`kapitza.figures.fit_texts`: a
        title the section made too long for its panel is never cut), drawn once
        (:func:`kapitza.figures.save_png`)."""
        from ..figures import agg_canvas, fit_texts, save_png
        agg_canvas(fig)          # formulas parsed once for all the report's figures
        fit_texts(fig)
        rel = Path("figures") / f"{name}.png"
        save_png(fig, self.out / rel, 150)
        return rel

    def table(self, name: str, frame, section: str, shown: str | None = None, *,
              analysis: str | None = None, method: str | None = None,
              tolerances: dict | None = None):
        """Write ``frame`` as data/<name>.parquet and data/<name>.csv (with its sidecar
        data/<name>.csv-metadata.json), each atomically, each saying what it is: the record
        of :func:`kapitza.scenes.table_metadata` — the scene (name, SHA-256 of its text),
        the parameters with units, the method (``method``, else the frame's ``method``
        column), the tolerances (the scene's settings of ``analysis`` — default: the
        analysis of the table's name or section — updated by ``tolerances``), the
        versions — plus the section, the table's name and the report's mode.  ``shown``:
        its title on the page."""
        from ..scenes import table_metadata, write_frame
        frame = frame.reset_index(drop=True)
        if method is None and "method" in frame and len(frame):
            method = "; ".join(str(m) for m in dict.fromkeys(frame["method"]))
        if analysis is None:        # the analysis a section shows, where the scene asks for it
            analysis = name if name in self.scene.analyses else {
                "map": "stability_map", "potential": "averaging", "verification": "verify",
                "spots": "measure", "slow": "measure"}.get(section)
        if analysis not in self.scene.analyses:
            analysis = None
        meta = table_metadata(self.scene, analysis, method=method, section=section,
                              table=name, report="quick" if self.quick else "full",
                              grid_integrator=GRID_METHOD)
        meta["tolerances"].update(tolerances or {})
        parquet, csv, _ = write_frame(frame, self.out / "data", name, ("parquet", "csv"), meta)
        self.tables[name] = (parquet, csv)
        self.state.setdefault("table_rows", {})[name] = (len(frame), section)
        if shown is not None:
            self.shown.setdefault(section, []).append((shown, frame))
        return name


#: The report's legend words (shared/PHYSICS.md's convention: a multiplier at +1 bounds a
#: period-T instability, at −1 a period-2T one) for the labels the map figures give.
LEGEND_WORDS = {
    "unstable, period-T boundary": "unstable: real multiplier > +1 (period-T)",
    "unstable, period-2T boundary": "unstable: real multiplier < −1 (period-2T)",
    "unstable, complex multipliers": "unstable: complex multipliers, |μ| > 1",
    "exact boundary: multiplier +1 (T)": "exact period-T boundary (multiplier +1)",
    "exact boundary: multiplier −1 (2T)": "exact period-2T boundary (multiplier −1)",
    "exact boundary: complex pair": "exact boundary of complex multipliers",
}


def physics_legend(ax, extra_words=None):
    """Put ``ax``'s legend below it (:func:`kapitza.figures.legend_below`), each entry in
    the report's words (:data:`LEGEND_WORDS`, updated by ``extra_words``)."""
    from ..figures import legend_below
    words = {**LEGEND_WORDS, **(extra_words or {})}
    handles = list(ax.get_legend().legend_handles)
    for artist in [*handles, *ax.lines]:          # the entries and the lines they stand for
        label = artist.get_label()
        bare = label.lstrip("_")
        if bare in words:
            artist.set_label(label[:len(label) - len(bare)] + words[bare])
    legend_below(ax, handles)


def new_figure(figsize) -> Figure:
    """An empty matplotlib Figure (constrained layout, its own Agg canvas: no pyplot, no
    global state), ``figsize`` in inches, for a section that lays out several panels."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def thin(values, n):
    """At most ``n`` values of an axis, evenly spaced in index, ends kept."""
    values = np.asarray(values)
    if values.size <= n:
        return values
    return values[np.unique(np.linspace(0, values.size - 1, n).round().astype(int))]


def pct(x) -> str:
    """A fraction as a percentage, two digits ("n/a" if not finite)."""
    return f"{100 * x:.2g} %" if np.isfinite(x) else "n/a"


def no_map_reason(job) -> str:
    """Why a scene whose drive leaves no equilibrium has no stability map, and where the
    page shows its slow state instead."""
    path = job.scene.drive.path if isinstance(job.scene.drive.path, str) else "oblique"
    states = ("θ = 0 and π do not persist" if job.pend is not None or
              (job.angles.all() and job.scene.system.n_dof == 1) else
              "no state of the rig persists")
    if job.pend is not None:
        where = ("; the slow state is a periodic orbit, compared with averaging and "
                 "simulation in the spot-check and slow-frequency sections.")
    elif job.scene.system.n_dof == 1:
        where = ("; the slow state is a periodic orbit, compared with averaging in the "
                 "effective-potential section.")
    else:
        where = "; the slow state is a periodic orbit (kapitza.periodic_orbit)."
    return (f"the {path} drive leaves no equilibrium ({states}), so there is no (A, ω) "
            f"stability map of one{where}")


#: How the page writes a coordinate's name.
_GREEK = {"theta": "θ", "phi": "φ", "psi": "ψ"}


def coordinate_text(name: str) -> str:
    base = name.rstrip("0123456789")
    return _GREEK.get(base, base) + name[len(base):]


def _value(v: float, unit: str) -> str:
    if unit == "rad":
        k = v / math.pi
        if abs(k - round(k)) < 1e-9:
            k = int(round(k))
            return "0" if k == 0 else "π" if k == 1 else "−π" if k == -1 else f"{k}π"
        return f"{v:.4g} rad"
    return f"{v:.4g}" + ("" if unit == "1" else f" {unit}")


def upright(job) -> str:
    """The state the sections are about as the page writes it: "θ = π", "q = (π, π)" for
    a chain of angles, "r = 1.245 m, θ = 0" for a rig with other coordinates."""
    about, units = job.about, job.units
    names = list(job.scene.system.coordinates)
    if job.angles.all():
        values = [_value(float(v), "rad") for v in about]
        if len(names) == 1:
            return f"{coordinate_text(names[0])} = {values[0]}"
        return f"q = ({', '.join(values)})"
    return ", ".join(f"{coordinate_text(q)} = {_value(float(v), units.get(q, '1'))}"
                     for q, v in zip(names, about, strict=True))


def state_name(job) -> str:
    """"the upright state", "the hanging state" or "the state <name>" (a user's rig)."""
    about = job.about
    for name, values in (job.scene.spec.states or {}).items():
        if np.allclose(values, about, rtol=0, atol=1e-12):
            return {"inverted": "the upright state", "hanging": "the hanging state"}.get(
                name, f"the state {name!r}")
    return "the upright state" if job.upright_state else "the state"

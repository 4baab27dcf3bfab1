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
    def about(self):
        """The equilibrium every section is about: upright (every coordinate π)."""
        return np.full(self.scene.system.n_dof, math.pi)

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
        rel = Path("figures") / f"{name}.png"
        fig.savefig(self.out / rel, dpi=150)      # sharp on high-density screens
        return rel

    def table(self, name: str, frame, section: str, shown: str | None = None):
        """Write ``frame`` as data/<name>.parquet and .csv; ``shown``: its title on the page."""
        parquet, csv = self.out / "data" / f"{name}.parquet", self.out / "data" / f"{name}.csv"
        frame = frame.reset_index(drop=True)
        frame.to_parquet(parquet, index=False)
        frame.to_csv(csv, index=False)
        self.tables[name] = (parquet, csv)
        self.state.setdefault("table_rows", {})[name] = (len(frame), section)
        if shown is not None:
            self.shown.setdefault(section, []).append((shown, frame))
        return name


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
    """Why a scene whose drive leaves no equilibrium has no stability map."""
    return (f"the {job.scene.drive.path if isinstance(job.scene.drive.path, str) else 'oblique'}"
            " drive leaves no equilibrium (θ = 0 and π do not persist), so there is no "
            "(A, ω) stability map of one; the slow state is a periodic orbit, compared with "
            "averaging and simulation in the slow-frequency section.")


def upright(job) -> str:
    """The upright state as the page writes it: θ = π, or q = (π, π, ...)."""
    n = job.scene.system.n_dof
    return "θ = π" if n == 1 else f"q = ({', '.join(['π'] * n)})"

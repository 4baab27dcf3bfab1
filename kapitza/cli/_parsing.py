"""The ``kapitza`` command line.

Commands (``kapitza COMMAND --help`` shows each one's options and an example):

  predict   averaging and Floquet analysis at one drive (A, ω)
  window    the exact window of stabilising amplitudes per ω, the averaging one beside it
  map       the exact (A, ω) stability map: a PNG and the data (CSV or Parquet)
  measure   simulate the full nonlinear motion at one drive and measure it
  verify    averaging, Floquet and simulation compared over a grid (exit 1: methods that
            claim validity at a point disagree; the others are reported)
  animate   a GIF of the stabilised inverted pendulum beside one that falls
  continue  follow a branch of periodic orbits in A or ω: its bifurcations, a PNG
  bifurcation  the stroboscopic bifurcation diagram over A or ω: a PNG and the dots
  lyapunov  Lyapunov exponents at one drive, or the largest one over an A × ω grid
  report    the whole story in one folder: an HTML page, figures, a GIF and the data
  run       run the analyses a scene file asks for
  sweep     run a scene's [sweep] over its grid, in resumable tiles
  warmup    compile what every analysis needs, once per installation
  summary   derive, compile and integrate the catalogue (the default: ``kapitza --rtol 1e-6``)

Drive parameters are SI numbers (``--A`` m, ``--omega`` rad/s or ``--f`` Hz) or
dimensionless ratios (``--A-over-l``, ``--omega-over-omega0`` with ω0 = √(g/l)); a
legal but implausible value is run with a warning that names the likely slip (``--A 5``:
"A is in metres; did you mean 0.05?"; ``--theta0 179``: "θ0 is in radians").  Each
command takes only the options it uses; another is refused, naming it.
``--json`` writes the results as JSON on stdout; messages and progress go to stderr.
JSON has no literal for ∞ and NaN: they are the strings "inf", "-inf" and "nan", the
tokens the text prints (``float()`` reads them back); null means no value.
Errors are one line on stderr naming the option, the value and the fix; ``--traceback``
(or KAPITZA_DEBUG=1) adds Python's traceback to an internal error.
Exit codes: 0 success; 1 methods that both claim validity at a point disagree beyond
their tolerances (verify), or a report section or catalogue problem failed; 2 a usage,
input or scene error; 70 an internal error (a bug; please report it with the
traceback); 130 interrupted (Ctrl-C; what finished is kept).
"""
from __future__ import annotations

import argparse
import difflib
import math
import os
from pathlib import Path

import numpy as np

from ._output import plain_message, say

#: Above this A/l the pivot swings farther than the pendulum is long: legal, but more
#: often a length given in centimetres than meant.
PLAUSIBLE_A_OVER_L = 1.0
#: Above this |angle| (rad) an angle is more often degrees than meant.
PLAUSIBLE_ANGLE = 2 * math.pi


class UsageError(Exception):
    """A command's arguments are wrong (exit code 2); the message names what."""


class CommandLineParser(argparse.ArgumentParser):
    """argparse's parser whose errors are one line: the command, the problem, and where
    the help is (argparse prints the whole usage first)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {plain_message(message)} (see '{self.prog} "
                  "--help')\n")


def warn(args, message: str) -> None:
    """A warning on stderr, one line, naming the command: the input is legal and is run."""
    say(f"kapitza {args.command}: warning: {message}")


def pendulum_from(args):
    """The pendulum the options describe (--l, --g, --damping, --drive)."""
    from ..pendulum import KapitzaPendulum
    return KapitzaPendulum(l=args.l, g=args.g, damping=args.damping, drive=args.drive)


def number_list(text: str, name: str) -> np.ndarray:
    """``"0.05"``, ``"0.01,0.03,0.1"`` or ``"START:STOP:NUM"`` (NUM points, linear); finite
    numbers only."""
    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) != 3:
                raise ValueError
            start, stop, num = float(parts[0]), float(parts[1]), int(parts[2])
            if num < 1:
                raise ValueError
            values = np.linspace(start, stop, num)
        else:
            values = np.array([float(v) for v in text.split(",") if v.strip()])
            if not values.size:
                raise ValueError
    except ValueError:
        raise UsageError(f"{name}: expected a number, a comma-separated list or START:STOP:NUM, "
                         f"got {text!r}.") from None
    if not np.all(np.isfinite(values)):
        raise UsageError(f"{name}: the values must be finite numbers, got {text!r}.")
    return values


def geometric(text: str, name: str) -> np.ndarray:
    """As :func:`number_list`, but START:STOP:NUM spaced geometrically (for ω)."""
    values = number_list(text, name)
    if ":" in text and len(values) > 1:
        if values[0] <= 0 or values[-1] <= 0:
            raise UsageError(f"{name}: a logarithmic range needs positive ends, got {text!r}.")
        values = np.geomspace(values[0], values[-1], len(values))
    return values


def parse_amplitude(args, grid: bool = False):
    """Drive amplitude (m) from --A or --A-over-l (times l)."""
    text = args.A if args.A is not None else args.A_over_l
    if text is None:
        raise UsageError("give the drive amplitude: --A (m) or --A-over-l.")
    name = "--A" if args.A is not None else "--A-over-l"
    values = number_list(text, name)
    if args.A is None:
        values = values * args.l
    _check_amplitude(args, name, text, values)
    if not grid:
        if values.size != 1:
            raise UsageError(f"{name}: one value here, got {text!r}.")
        return float(values[0])
    return values


def parse_frequency(args, grid: bool = False):
    """Drive angular frequency (rad/s) from --omega, --f (Hz) or --omega-over-omega0."""
    given = [(n, getattr(args, k)) for n, k in (("--omega", "omega"), ("--f", "f"),
                                                 ("--omega-over-omega0", "omega_over_omega0"))
             if getattr(args, k) is not None]
    if not given:
        raise UsageError("give the drive frequency: --omega (rad/s), --f (Hz) or "
                         "--omega-over-omega0.")
    name, text = given[0]
    log = getattr(args, "log_omega", False)
    values = geometric(text, name) if log else number_list(text, name)
    if name == "--f":
        values = 2 * math.pi * values
    elif name == "--omega-over-omega0":
        if not args.g > 0:
            raise UsageError(f"--omega-over-omega0: ω0 = √(g/l) is 0 with --g {args.g:g}; "
                             "give the frequency as --omega (rad/s) or --f (Hz).")
        values = values * math.sqrt(args.g / args.l)
    if not grid:
        if values.size != 1:
            raise UsageError(f"{name}: one value here, got {text!r}.")
        return float(values[0])
    return values


def _check_amplitude(args, name, text, values):
    """Warn where A/l > 1: legal, but most often centimetres (or a percentage) meant."""
    ratio = float(np.max(np.abs(values))) / args.l if values.size else 0.0
    if not ratio > PLAUSIBLE_A_OVER_L:
        return
    what = (f"{name} {text}: A/l = {ratio:.4g} > {PLAUSIBLE_A_OVER_L:g}, the pivot swings "
            f"farther than the pendulum is long (l = {args.l:g} m)")
    if name == "--A":
        unit = "A is in metres"
        if values.size == 1:
            warn(args, f"{what}; {unit}: did you mean {float(values[0]) / 100:g} "
                 f"({float(values[0]):g} cm)?")
        else:
            warn(args, f"{what}; {unit} (centimetres meant? divide by 100).")
    else:
        warn(args, f"{what}; A/l is a ratio (a percentage meant? did you mean "
             f"{float(values.flat[0]) / args.l / 100:g}?).")


def check_angle(args, option: str, value) -> bool:
    """Warn where an angle (rad) exceeds 2π in size: most often degrees meant.  Whether
    it warned."""
    if value is None or not np.isfinite(value) or abs(value) <= PLAUSIBLE_ANGLE:
        return False
    name = {"--theta0": "θ0", "--about": "the state's angle",
            "--starts": "a starting angle"}.get(option, option)
    warn(args, f"{option} {value:g}: |{value:g}| > 2π; {name} is in radians: did you mean "
         f"{value:g}° = {math.radians(value):.4g} rad?")
    return True


def drive_point(args, A, omega) -> dict:
    """The drive (SI and dimensionless) and the pendulum, as every command's JSON states them."""
    omega0 = math.sqrt(args.g / args.l)
    with np.errstate(divide="ignore", invalid="ignore"):     # g = 0: ω0 = 0, ω/ω0 = inf
        ratio = np.asarray(omega, dtype=float) / omega0
    return {"A": A, "omega": omega, "A_over_l": np.asarray(A) / args.l,
            "omega_over_omega0": ratio,
            "pendulum": {"l": args.l, "g": args.g, "damping": args.damping,
                         "drive": args.drive, "omega0": omega0}}


def over_omega0(omega, args) -> float:
    """ω/ω0 with ω0 = √(g/l) of the options (inf where g = 0)."""
    omega0 = math.sqrt(args.g / args.l)
    return float(omega) / omega0 if omega0 > 0 else math.inf


def data_file(text, option="--data"):
    """A data file's path: .csv or .parquet, in a place that can be written."""
    if text is None:
        return None
    path = Path(text)
    if path.suffix not in (".csv", ".parquet"):
        raise UsageError(f"{option} must end in .csv or .parquet, got {text!r}.")
    return writable(option, text)


def writable(option: str, text, *, folder: bool = False) -> Path:
    """The path ``option`` names for writing, checked before any work: a file (or with
    ``folder`` a folder, new or existing) that can be made there — a usage error naming
    the option, the path and the fix otherwise (a file where a folder is due or the
    reverse, a part of the path a file, no permission)."""
    path = Path(text)
    if folder and path.exists() and not path.is_dir():
        raise UsageError(f"{option} {text}: a file is there, and this is a folder (new or "
                         "existing): choose another name, or remove the file.")
    if not folder and path.is_dir():
        raise UsageError(f"{option} {text}: a folder is there, and this is a file: give a "
                         f"file name, e.g. {path / ('name' + (path.suffix or '.csv'))}.")
    probe = path if folder else path.parent
    while not probe.exists() and probe != probe.parent:     # the nearest existing ancestor
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise UsageError(f"{option} {text}: {probe} is a file, not a folder: choose another "
                         "path.")
    if probe.exists() and not os.access(probe, os.W_OK | os.X_OK):
        raise UsageError(f"{option} {text}: no permission to write in {probe}: choose "
                         "another path.")
    return path


def read_scene(path):
    """The scene file ``path`` (a usage error if there is none)."""
    from ..scenes import Scene
    if not Path(path).is_file():
        raise UsageError(f"no scene file {path!r}.")
    return Scene.from_toml(path)


_EXAMPLES = {
    "predict": ["kapitza predict --A 0.05 --f 60",
                "kapitza predict --A-over-l 0.05 --omega-over-omega0 120.4 --json",
                "kapitza predict --drive horizontal --A 0.05 --omega 377"],
    "window": ["kapitza window --omega 100,200,400",
               "kapitza window --omega-over-omega0 10:1000:30 --log-omega --json"],
    "map": ["kapitza map --A 0:0.5:101 --omega 20:2000:100 --log-omega --out map.png",
            "kapitza map --drive horizontal --A 0:0.2:41 --omega 40:400:30 --about hanging",
            "kapitza map --A-over-l 0:0.5:51 --omega-over-omega0 5:500:60 --log-omega "
            "--data map.parquet --dimensionless"],
    "measure": ["kapitza measure --A 0.05 --f 60 --theta0 3.13",
                "kapitza measure --A 0.05 --omega 377 --drive horizontal --theta0 1.0 --json"],
    "verify": ["kapitza verify --A 0.01,0.03,0.1 --f 40 --periods 400",
               "kapitza verify --A 0.01:0.3:10 --omega 50:500:5 --log-omega --data v.csv --json"],
    "animate": ["kapitza animate --A-over-l 0.25 --omega-over-omega0 10 --out pendulum.gif",
                "kapitza animate --A 0.2 --omega 40 --A-fall 0.05 --duration 3 --json",
                "kapitza animate kapitza/scenes/report.toml --out report.gif",
                "kapitza animate up.toml undriven.toml --out chains.gif"],
    "continue": ["kapitza continue --A 0.02 --omega 6.2642 --damping 0.47 --about hanging "
                 "--stop 0.7 --switch --out branches.png",
                 "kapitza continue --A 0.02 --omega-over-omega0 20 --about inverted --stop 0.6 "
                 "--json",
                 "kapitza continue kapitza/scenes/period_doubling.toml --json"],
    "bifurcation": ["kapitza bifurcation --omega 6.2642 --damping 0.47 --values 0:0.7:141 "
                    "--starts 0.1,2.0 --out diagram.png",
                    "kapitza bifurcation kapitza/scenes/period_doubling.toml --transient 500 "
                    "--json"],
    "lyapunov": ["kapitza lyapunov --A 0.55 --omega 6.2642 --damping 0.47 --theta0 0.1",
                 "kapitza lyapunov --A 0:0.7:36 --omega 5:8:16 --damping 0.47 --periods 300 "
                 "--out chaos-map.png --data chaos-map.csv",
                 "kapitza lyapunov kapitza/scenes/period_doubling.toml --json"],
    "report": ["kapitza report                      # the default scene, into ./kapitza-report",
               "kapitza report kapitza/scenes/double_pendulum.toml --out dp-report",
               "kapitza report --quick --out /tmp/r --json"],
    "run": ["kapitza run kapitza/scenes/kapitza_pendulum.toml",
            "kapitza run my_scene.toml --json --no-write"],
    "sweep": ["kapitza sweep kapitza/scenes/kapitza_pendulum_map.toml",
              "kapitza sweep scene.toml --analysis measure --directory out/",
              "kapitza sweep scene.toml --wait 600     # another sweep of it runs: wait"],
    "warmup": ["kapitza warmup"],
    "summary": ["kapitza summary --rtol 1e-8", "kapitza --rtol 1e-6"],
}


def _epilog(name):
    return "examples:\n" + "\n".join(f"  {e}" for e in _EXAMPLES[name])


def _common(p, json_only=False, amplitude=True):
    """The options every command shares (added to each parser: argparse's ``parents``
    would lose the drive's group title in the help); ``amplitude=False``: no --A,
    --A-over-l (a command that finds the amplitudes itself)."""
    p.add_argument("--json", action="store_true",
                   help="write the results as JSON on stdout (messages go to stderr; "
                   'non-finite numbers as "inf", "-inf", "nan")')
    if json_only:
        return
    g = p.add_argument_group("the pendulum")
    g.add_argument("--l", type=float, default=1.0, help="length l (m; default 1)")
    g.add_argument("--g", type=float, default=9.81, help="gravity g (m/s²; default 9.81)")
    g.add_argument("--damping", type=float, default=0.0, help="damping rate γ (1/s; default 0)")
    g.add_argument("--drive", choices=("vertical", "horizontal"), default="vertical",
                   help="direction of the pivot's oscillation A cos ωt (default vertical)")
    d = p.add_argument_group("the drive (SI numbers or dimensionless ratios; grids as "
                             "a,b,c or START:STOP:NUM where a command takes several)")
    if amplitude:
        a = d.add_mutually_exclusive_group()
        a.add_argument("--A", metavar="A", help="amplitude A (m)")
        a.add_argument("--A-over-l", dest="A_over_l", metavar="A/l", help="amplitude as A/l")
    f = d.add_mutually_exclusive_group()
    f.add_argument("--omega", metavar="ω", help="angular frequency ω (rad/s)")
    f.add_argument("--f", metavar="Hz", help="frequency f = ω/2π (Hz)")
    f.add_argument("--omega-over-omega0", dest="omega_over_omega0", metavar="ω/ω0",
                   help="ω as a ratio to ω0 = √(g/l)")


def build_parser() -> argparse.ArgumentParser:
    """The ``kapitza`` parser: one sub-command each, its name in ``args.command``."""
    from .._version import __version__
    raw = argparse.RawDescriptionHelpFormatter
    parser = CommandLineParser(prog="kapitza", description=__doc__, formatter_class=raw,
                               epilog=_MAIN_EPILOG)
    parser.add_argument("--version", action="version", version=f"kapitza {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    pend, plain = False, True

    def add(name, helptext, json_only, **options):
        p = sub.add_parser(name, help=helptext, description=helptext, epilog=_epilog(name),
                           formatter_class=raw)
        _common(p, json_only, **options)
        return p

    p = add("predict", "averaging and Floquet analysis at one drive (A, ω)", pend)
    p.add_argument("--about", help="Floquet about: inverted (default) or hanging; horizontal "
                   "drive: tilted (default), tilted-, hanging, inverted")
    p.add_argument("--order", type=int, choices=(1, 2), default=1, help="order of averaging")
    p.add_argument("--tol", type=float, default=1e-10, help="Floquet tolerance (default 1e-10)")

    p = add("window", "the exact window A_min < A < A_max per ω (vertical drive), the "
            "averaging window beside it", pend, amplitude=False)
    p.add_argument("--about", choices=("inverted", "hanging"), default="inverted")
    p.add_argument("--order", type=int, choices=(1, 2), default=1,
                   help="order of the averaging window (default 1)")
    p.add_argument("--tol", type=float, default=1e-10, help="relative accuracy of the edges")
    p.add_argument("--log-omega", action="store_true", help="START:STOP:NUM of ω geometric")

    p = add("map", "the exact (A, ω) stability map: a PNG and its data (about the upright or "
            "hanging equilibrium of the vertical drive; about the periodic orbits of the "
            "horizontal drive, followed across the grid)", pend)
    p.add_argument("--about", choices=("inverted", "hanging", "tilted", "tilted-"), default=None,
                   help="the state: inverted (default, vertical drive) or hanging; horizontal "
                   "drive: hanging (default), inverted, tilted, tilted- (periodic orbits)")
    p.add_argument("--out", default="kapitza-map.png", help="figure (default kapitza-map.png)")
    p.add_argument("--data", help="data file, .csv or .parquet (default: the figure's name "
                   "with .csv)")
    p.add_argument("--trace", action="store_true", help="compute the monodromy trace everywhere")
    p.add_argument("--tol", type=float, default=1e-10, help="Floquet tolerance (with --trace "
                   "or damping)")
    p.add_argument("--log-omega", action="store_true",
                   help="START:STOP:NUM of ω geometric, and a logarithmic ω axis")
    p.add_argument("--dimensionless", action="store_true", help="axes A/l and ω/ω0")

    p = add("measure", "simulate the full nonlinear motion at one drive and measure it", pend)
    p.add_argument("--theta0", type=float, default=math.pi - 0.01,
                   help="release angle from the downward vertical (rad; default π − 0.01)")
    p.add_argument("--theta-dot0", dest="theta_dot0", type=float, default=0.0,
                   help="release angular velocity (rad/s; default 0)")
    p.add_argument("--periods", type=int, default=None,
                   help="drive periods simulated (default: measure's)")
    p.add_argument("--about", help="inverted, hanging, tilted or an angle (default: inverted "
                   "for the vertical drive, tilted for the horizontal)")
    p.add_argument("--rtol", type=float, default=1e-9, help="integration tolerance")

    p = add("verify", "averaging, Floquet and simulation of the upright pendulum compared "
            "over an A × ω grid; exit code 1 where two methods that both claim validity at a "
            "point disagree beyond their tolerances (points outside a method's validity, e.g. "
            "first-order averaging beyond A/l = 0.3, are listed, not failed)", pend)
    p.add_argument("--theta0", type=float, default=math.pi - 0.01,
                   help="the simulations' release angle (rad; default π − 0.01)")
    p.add_argument("--periods", type=int, default=None,
                   help="drive periods simulated per point (default: measure's)")
    p.add_argument("--tol", type=float, default=1e-10, help="Floquet tolerance")
    p.add_argument("--rtol", type=float, default=1e-9, help="integration tolerance")
    p.add_argument("--fit-order", action="store_true",
                   help="also fit the order of averaging along A ω = 2√(gl)")
    p.add_argument("--data", help="write the per-point table (.csv or .parquet)")
    p.add_argument("--log-omega", action="store_true", help="START:STOP:NUM of ω geometric")

    p = add("animate", "a looping GIF of the stabilised inverted pendulum beside one that "
            "falls (vertical drive, slow motion)", pend)
    p.add_argument("scene", metavar="SCENE.toml", nargs="*",
                   help="one pendulum scene: l, g, damping, the drive and θ0 from it (the "
                   "falling one beside it as with the options); a chain's scene, or several "
                   "scenes: one panel each, from their [initial] states")
    p.add_argument("--theta0", type=float, default=math.pi - 0.1,
                   help="release angle of both (rad from the downward vertical; default "
                   "π − 0.1)")
    p.add_argument("--A-fall", dest="A_fall", type=float, default=0.0,
                   help="drive amplitude of the falling one (m; default 0, undriven; "
                   "must lie outside the window)")
    p.add_argument("--duration", type=float, default=4.0, help="simulated time (s; default 4)")
    p.add_argument("--fps", type=float, default=20.0, help="playback frames/s (default 20)")
    p.add_argument("--frames-per-period", dest="frames_per_period", type=int, default=8,
                   help="frames per drive period, ≥ 4 (default 8; sets the slow motion)")
    p.add_argument("--width", type=int, default=720, help="frame width (px; default 720)")
    p.add_argument("--max-frames", dest="max_frames", type=int, default=600,
                   help="refuse to render more frames (default 600)")
    p.add_argument("--mode", choices=("auto", "slow", "strobe"), default="auto",
                   help="slow motion (n frames a drive period), strobe (one frame every few "
                   "periods at one phase, the period drawn faint) or auto (slow motion when "
                   "it fits --max-frames and is at most 10× slower than real; default)")
    p.add_argument("--out", default="pendulum.gif", help="the GIF (default pendulum.gif)")

    _frontier_parsers(add)

    p = add("report", "the main job: run a scene (default: a 1 m pendulum shaken "
            "vertically) through every analysis and write a self-contained folder: "
            "index.html, PNG figures, a GIF and the data (Parquet and CSV); progress on "
            "stderr, Ctrl-C keeps the finished sections (exit 130), exit 1 if a section "
            "failed. The default scene takes about 40 s on a fresh installation "
            "(compiling included) and 20 s after", plain)
    p.add_argument("scene", metavar="SCENE.toml", nargs="?", default=None,
                   help="a scene file (default: the embedded kapitza/scenes/report.toml)")
    p.add_argument("--out", default="kapitza-report",
                   help="the report folder (default ./kapitza-report)")
    p.add_argument("--quick", action="store_true", help="small grids and short runs")

    p = add("run", "run the analyses a scene file (TOML) asks for", plain)
    p.add_argument("scene", metavar="SCENE.toml")
    p.add_argument("--no-write", action="store_true", help="write nothing (no [output] tables, "
                   "no manifest)")

    p = add("sweep", "run a scene's [sweep] over its grid in resumable tiles", plain)
    p.add_argument("scene", metavar="SCENE.toml")
    p.add_argument("--analysis", help="the swept analysis (default: the only one)")
    p.add_argument("--directory", help="where the dataset goes (default: the scene's output)")
    p.add_argument("--tile-points", dest="tile_points", type=int)
    p.add_argument("--wait", nargs="?", type=float, const=True, default=False,
                   metavar="SECONDS", help="another sweep writes the same dataset: wait for "
                   "it to finish (at most SECONDS, if given) instead of refusing")

    add("warmup", "compile what every analysis needs, once per installation", plain)

    p = add("summary", "derive, compile and integrate the catalogue (the default)", plain)
    p.add_argument("--rtol", type=float, default=1e-10,
                   help="integration tolerance (default 1e-10)")
    parser.commands = sub.choices           # name → its parser (unknown_option reads them)
    return parser


#: ``kapitza --help``'s epilog: what every command shares.
_MAIN_EPILOG = """\
every command:
  --json        the results as JSON on stdout ("inf", "-inf", "nan" for non-finite numbers,
                as the text prints them; null: no value)
  --traceback   with an internal error, Python's traceback too (or KAPITZA_DEBUG=1)

exit codes:
  0    success
  1    methods that both claim validity at a point disagree (verify); a report section
       or a catalogue problem failed
  2    a usage, input or scene error (one line naming the option, the value, the fix)
  70   an internal error: a bug (--traceback shows where; please report it)
  130  interrupted (Ctrl-C): what finished is kept
"""

#: Why a command has no such option, where the reason is not obvious.
_NOT_HERE = {
    ("window", "--A"): "the window is the range of amplitudes A_min < A < A_max at each ω, "
                       "so it takes ω only (one drive (A, ω): kapitza predict)",
    ("window", "--A-over-l"): "the window is the range of amplitudes at each ω, so it takes "
                              "ω only (one drive (A, ω): kapitza predict)",
}


def unknown_option(parser, command: str, extras: list) -> str:
    """The one-line error for arguments ``command`` does not take: the first of them, the
    commands that do take it or the nearest spelling, and why where known."""
    sub = parser.commands[command]
    first = next((a for a in extras if a.startswith("-") and a != "-"), None)
    if first is None:
        return (f"unexpected argument {extras[0]!r} (kapitza {command} takes "
                f"{_positionals(sub) or 'no positional arguments'}; see 'kapitza {command} "
                "--help').")
    option = first.split("=", 1)[0]
    message = f"{option} is not an option of kapitza {command}"
    if (command, option) in _NOT_HERE:
        message += ": " + _NOT_HERE[(command, option)]
    else:
        others = [name for name, p in parser.commands.items()
                  if option in p._option_string_actions]
        near = difflib.get_close_matches(option, [o for o in sub._option_string_actions
                                                  if o.startswith("--") and o != "--help"],
                                         n=1)
        if near:
            message += f"; did you mean {near[0]}?"
        elif others:
            message += f" (the commands that take it: {', '.join(others)})"
    return f"{message} (see 'kapitza {command} --help')."


def _positionals(p) -> str:
    return ", ".join(a.metavar or a.dest for a in p._actions if not a.option_strings)


def given_options(argv) -> set:
    """The destinations of the options ``argv`` gives explicitly (not defaults): the same
    parse with every default suppressed."""
    parser = build_parser()
    for p in (parser, *parser.commands.values()):
        for action in p._actions:
            if action.dest not in ("help", "version", "command"):
                action.default = argparse.SUPPRESS
    args, _ = parser.parse_known_args(argv)
    return set(vars(args)) - {"command"}


#: Option names by their destination, where a message names an option.
_OPTION_NAMES = {"l": "--l", "g": "--g", "damping": "--damping", "drive": "--drive",
                 "theta0": "--theta0", "theta_dot0": "--theta-dot0", "A_fall": "--A-fall"}


def refuse_with_scene(args, *keys, why="the scene file sets it (edit the scene, or leave "
                      "the scene out to use the options)") -> None:
    """A usage error naming the options of ``keys`` given explicitly alongside a scene file,
    which does not use them."""
    given = [_OPTION_NAMES[k] for k in keys if k in getattr(args, "given", ())]
    if given:
        raise UsageError(f"{', '.join(given)}: not used with a scene file: {why}.")


def check_pendulum_options(args) -> None:
    """--l, --g and --damping, where the command takes them: finite, l > 0, g and
    damping ≥ 0 (a usage error naming the option otherwise)."""
    for option, key, low, strict in (("--l", "l", 0.0, True), ("--g", "g", 0.0, False),
                                     ("--damping", "damping", 0.0, False)):
        value = getattr(args, key, None)
        if value is None:
            continue
        if not math.isfinite(value) or value < low or (strict and value == low):
            need = "> 0" if strict else "≥ 0"
            unit = {"l": "m", "g": "m/s²", "damping": "1/s"}[key]
            raise UsageError(f"{option} must be a finite number {need} ({unit}), got "
                             f"{value:g}.")


def check_tolerances(args) -> None:
    """--tol and --rtol, where the command takes them: relative tolerances in (0, 1) (the
    analyses refine the range; a command that uses --tol only sometimes still refuses a
    meaningless one)."""
    for option, key in (("--tol", "tol"), ("--rtol", "rtol")):
        value = getattr(args, key, None)
        if value is not None and not (math.isfinite(value) and 0 < value < 1):
            raise UsageError(f"{option} must be a relative tolerance in (0, 1), e.g. 1e-10; "
                             f"got {value:g}.")


def check_angles(args) -> None:
    """Warn where an angle option (rad) looks like degrees: --theta0, --about, --starts."""
    check_angle(args, "--theta0", getattr(args, "theta0", None))
    about = getattr(args, "about", None)
    if about is not None:
        try:
            values = [float(x) for x in str(about).replace(",", " ").split()]
        except ValueError:
            values = []
        any(check_angle(args, "--about", v) for v in values)         # one warning
    starts = getattr(args, "starts", None)
    if starts:
        try:
            values = [float(x) for x in str(starts).replace(",", " ").split()]
        except ValueError:
            values = []                 # the command names a malformed --starts
        any(check_angle(args, "--starts", v) for v in values)


def _frontier_parsers(add):
    """``continue``, ``bifurcation`` and ``lyapunov``: a scene file, or the pendulum and its
    drive from the options (the scene's ``[analyses]`` table of the same name gives the
    settings; the options override them)."""
    pend = False

    def scene_and_state(p, what):
        p.add_argument("scene", metavar="SCENE.toml", nargs="?", default=None,
                       help=f"a scene file: its system, parameters, initial state and "
                       f"[analyses.{what}] (the options below override its settings); "
                       "without it, the pendulum and the drive of the options")
        p.add_argument("--theta0", type=float, default=None,
                       help="initial angle from the downward vertical (rad; default 0.1, "
                       "or the scene's)")
        p.add_argument("--theta-dot0", dest="theta_dot0", type=float, default=None,
                       help="initial angular velocity (rad/s; default 0, or the scene's)")

    def parameter(p):
        p.add_argument("--parameter", help="the parameter varied: A (default), omega, "
                       "frequency_hz, gamma, l, ... (values in its SI unit; Hz for "
                       "frequency_hz)")

    def outputs(p, figure, note=""):
        p.add_argument("--out", default=figure, help=f"figure (default {figure}){note}")
        p.add_argument("--data", help="data file, .csv or .parquet (default: the figure's "
                       "name with .csv)")

    p = add("continue", "follow a branch of periodic orbits (an equilibrium that persists "
            "under the drive, or the periodic orbit of a drive that leaves none) in one "
            "parameter through folds, its bifurcations located and classified; --switch "
            "follows the branches born at them", pend)
    scene_and_state(p, "continuation")
    parameter(p)
    p.add_argument("--start", type=float, help="where the branch starts (default: the "
                   "parameter's value, e.g. --A)")
    p.add_argument("--stop", type=float, help="where it ends (required without a scene's "
                   "[analyses.continuation])")
    p.add_argument("--periods", type=int, help="orbits of this many drive periods (default 1)")
    p.add_argument("--about", help="the starting state: inverted, hanging, auto (the "
                   "persisting state nearest --theta0; default) or an angle (rad)")
    p.add_argument("--switch", action=argparse.BooleanOptionalAction, default=None,
                   help="also follow the branches born at period doublings, pitchforks and "
                   "transcritical points")
    p.add_argument("--max-points", dest="max_points", type=int,
                   help="stop a branch after this many points (default 500)")
    outputs(p, "kapitza-branches.png")

    p = add("bifurcation", "the stroboscopic bifurcation diagram: after a transient, one "
            "sample per drive period over the values of a parameter × starting angles", pend)
    scene_and_state(p, "bifurcation_diagram")
    parameter(p)
    p.add_argument("--values", help="the parameter's values: START:STOP:NUM or a,b,c "
                   "(required without a scene's [analyses.bifurcation_diagram])")
    p.add_argument("--starts", help="starting angles at rest, a,b,c (rad; several "
                   "coordinates: a1 a2,b1 b2; default --theta0)")
    p.add_argument("--periods", type=int, help="strobe samples kept per run (default 200)")
    p.add_argument("--transient", type=int, help="drive periods run first (default 500)")
    outputs(p, "kapitza-bifurcation.png")

    p = add("lyapunov", "the Lyapunov exponents of the motion from one initial state, with "
            "their error; with several --A or ω values, the largest one over the grid (a "
            "chaos map)", pend)
    scene_and_state(p, "lyapunov")
    p.add_argument("--periods", type=int, help="drive periods of the record (default 1000; "
                   "≥ 8)")
    p.add_argument("--transient", type=int, help="drive periods run first (default 100)")
    p.add_argument("--exponents", help="all (default), largest, or how many")
    p.add_argument("--log-omega", action="store_true", help="START:STOP:NUM of ω geometric")
    p.add_argument("--out", help="a grid's figure (.png: the map over two varying "
                   "parameters, or λ1 along one)")
    p.add_argument("--data", help="a grid's table, .csv or .parquet")

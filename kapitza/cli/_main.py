"""``kapitza ...``: parse the command line, run the command, turn what went wrong into an
exit code and one line on stderr.

Every way a command can end, and its exit code (``kapitza --help`` states them too):

* 0: done.
* 1: ``verify`` found methods that both claim validity at a point disagreeing beyond
  their tolerances; a report section or a catalogue problem failed.
* 2: a usage, input or scene error — one line naming the option, the value and the fix:
  argparse's own errors, an option the command does not take, a value the API refuses
  (every ValueError, e.g. a grid too large to fit in memory), a path that cannot be read
  or written (OSError: missing, a file where a folder is due, no permission, no space),
  memory exhausted.
* 70: an internal error (any other exception: a bug) — one line and the hint to see the
  traceback (``--traceback`` anywhere on the line, or ``KAPITZA_DEBUG=1``).
* 130: Ctrl-C — one line saying what was kept.

Python warnings raised while a command runs are shown as one line each, naming the
command, not as Python's two-line form.
"""
from __future__ import annotations

import contextlib
import errno
import gc
import os
import sys
import traceback
import warnings

from ._commands import COMMANDS
from ._output import (
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_USAGE,
    say,
)
from ._parsing import (
    UsageError,
    build_parser,
    check_angles,
    check_pendulum_options,
    check_tolerances,
    given_options,
    unknown_option,
)

__all__ = ["main", "program"]

#: The environment variable that shows the traceback of an internal error.
DEBUG_VARIABLE = "KAPITZA_DEBUG"


def main(argv=None) -> int:
    """Run ``kapitza`` with ``argv`` (default ``sys.argv[1:]``); the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--traceback" in argv or os.environ.get(DEBUG_VARIABLE, "") not in ("", "0")
    argv = [a for a in argv if a != "--traceback"]
    name = "kapitza"
    try:
        parser = build_parser()
        if (not argv or argv[0].startswith("-")) and not {"-h", "--help", "--version"} & set(argv):
            argv = ["summary", *argv]           # the default command takes its options
        try:
            args, extras = parser.parse_known_args(argv)
        except SystemExit as stop:              # --help, --version (0) or a usage error (2)
            return int(stop.code or 0)
        name = f"kapitza {args.command}"
        if extras:
            say(f"{name}: error: {unknown_option(parser, args.command, extras)}")
            return EXIT_USAGE
        args.given = given_options(argv)
        with warnings.catch_warnings(), _announced_as(name):
            warnings.showwarning = _one_line_warning(name)
            check_pendulum_options(args)
            check_tolerances(args)
            check_angles(args)
            if args.command in ("measure", "verify") and args.periods is None:
                from ..simulation import DEFAULT_PERIODS
                args.periods = DEFAULT_PERIODS
            return COMMANDS[args.command](args)
    except UsageError as e:
        say(f"{name}: error: {e}")
        return EXIT_USAGE
    except BrokenPipeError:                     # stdout closed early (| head): not an error
        sys.stdout = open(os.devnull, "w")
        return EXIT_OK
    except KeyboardInterrupt as stop:           # ComputationInterrupted too
        done = getattr(stop, "computed", None)
        finished = (f" after {int(done.sum())} of {done.size} points" if done is not None
                    and done.size else "")
        kept = {"kapitza run": "a scene's output is written all or nothing: the "
                               "previous output (if any) stays until a new one is complete",
                "kapitza sweep": "the finished tiles are kept (run it again to resume "
                                 "the sweep)"}.get(name, "nothing was written")
        say(f"\n{name}: interrupted{finished}; {kept}. Compiled kernels stay cached.")
        return EXIT_INTERRUPTED
    except ValueError as e:                     # SceneError, GridTooLargeError: ValueErrors
        say(f"{name}: error: {e}")
        return EXIT_USAGE
    except OSError as e:
        say(f"{name}: error: {_os_error(e)}")
        return EXIT_USAGE
    except MemoryError as e:
        say(f"{name}: error: out of memory{f' ({e})' if str(e) else ''}; use a smaller grid, "
            "or kapitza sweep, which writes its grid to disk tile by tile.")
        return EXIT_USAGE
    except Exception as e:                      # a bug: one line, the traceback on request
        if debug:
            traceback.print_exc(file=sys.stderr)
        where = "" if debug else (" (run it again with --traceback, or KAPITZA_DEBUG=1, "
                                  "to see where)")
        say(f"{name}: internal error: {type(e).__name__}: {e}{where}; please report it.")
        return EXIT_INTERNAL


def program() -> None:
    """The ``kapitza`` program (the console script and ``python -m kapitza``): :func:`main`
    on ``sys.argv``, then the exit with its code.

    Before the exit the objects still alive are frozen (:func:`gc.freeze`): Python's
    shutdown otherwise runs a last full collection over the ~600 000 objects that sympy,
    numba and the loaded systems hold, which took 0.3–0.5 s of every command (a warm ``kapitza
    predict``, measured by ``benchmarks/bench_cold_start.py --only commands``).  Nothing
    the command made depends on it: its files are closed and its temporary folders
    removed by their own exit handlers, which still run.  Only the program does this:
    :func:`main` called in a user's process leaves the collector alone."""
    code = main()
    gc.freeze()
    sys.exit(code)


#: What the user can do about an operating-system error, by its errno.
_OS_FIXES = {
    errno.ENOENT: "no such file or folder: check the path, or create its folder",
    errno.ENOTDIR: "a part of the path is a file, not a folder: choose another path",
    errno.EISDIR: "a folder is there, not a file: give a file name",
    errno.EEXIST: "a file is in the way of a folder: choose another path, or remove it",
    errno.EACCES: "permission denied: check its permissions, or choose another path",
    errno.EPERM: "not permitted: check its permissions, or choose another path",
    errno.EROFS: "the file system is read-only: choose another path",
    errno.ENOSPC: "no space left on the device: free some, or choose another disk",
}


def _os_error(e: OSError) -> str:
    """An OSError in one line: the path, what happened, what to do."""
    path = e.filename if e.filename is not None else ""
    fix = _OS_FIXES.get(e.errno, e.strerror or str(e))
    return f"{path}: {fix}." if path else f"{fix} ({e})."


def _one_line_warning(name):
    """``warnings.showwarning`` for the command line: one line on stderr, naming it."""
    def show(message, category, filename, lineno, file=None, line=None):
        text = str(message).strip().replace("\n", " ")
        label = "" if category.__name__ in ("UserWarning", "RuntimeWarning") else \
            f"{category.__name__}: "
        say(f"{name}: warning: {label}{text}")
    return show


def _announced_as(name):
    """The command as the activity a first compile's notice quotes, where its own estimate
    is known (lagrange_core._compile_notice.ACTIVITY_SECONDS: the commands whose first
    compile is in no activity of the API's)."""
    from lagrange_core._compile_notice import ACTIVITY_SECONDS, declared
    return declared(name) if name in ACTIVITY_SECONDS else contextlib.nullcontext()

"""``kapitza ...``: parse the command line, run the command, turn what went wrong into an
exit code and a message on stderr."""
from __future__ import annotations

import os
import sys

from ._commands import COMMANDS
from ._output import EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE, say
from ._parsing import UsageError, build_parser

__all__ = ["main"]


def main(argv=None) -> int:
    """Run ``kapitza`` with ``argv`` (default ``sys.argv[1:]``); the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    if (not argv or argv[0].startswith("-")) and not {"-h", "--help", "--version"} & set(argv):
        argv = ["summary", *argv]               # the default command takes its options
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:                  # --help, --version (0) or a usage error (2)
        return int(stop.code or 0)
    name = f"kapitza {args.command}"
    try:
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
        kept = ("tables already written and finished sweep tiles are kept (run it again to "
                "resume the sweep)" if args.command == "run" else "nothing was written")
        say(f"\n{name}: interrupted{finished}; {kept}. Compiled kernels stay cached.")
        return EXIT_INTERRUPTED
    except (ValueError, FileNotFoundError) as e:      # SceneError is a ValueError
        say(f"{name}: error: {e}")
        return EXIT_USAGE

"""The command line's output reaches the streams its caller gave it, whatever other threads
of the process do meanwhile.

numba makes its error messages (thousands while it compiles, nearly all caught inside its
compiler) within colorama's ``init()`` … ``deinit()``, which replace ``sys.stdout`` and
``sys.stderr`` and then set back the streams they found.  A compilation on a thread of its
own (lagrange_core._first_calls: a kernel's first call, going on after a Ctrl-C) then set
back a stream the main thread had replaced since: tests/test_properties_cli.py ran a command
inside ``contextlib.redirect_stderr`` while the compilation of an interrupted ``kapitza
summary`` went on, and the command's error line went to the process's stderr ("exit 2
without a message"; reproduced with cold caches: every command after the interrupted one).
lagrange_core._first_calls, imported with any kernel, turns numba's calls to them off.
"""
import contextlib
import io
import sys
import threading

from numba.core.errors import NumbaError

from kapitza.cli import main


def test_numba_compiling_on_another_thread_leaves_the_callers_streams():
    """A numba error made on another thread (as its compiler makes them) while the caller
    replaces the streams: the caller's streams stay in place."""
    found, go = threading.Event(), threading.Event()

    class Earlier(io.StringIO):
        """The streams of the moment the thread starts; colorama, wrapping the one it
        found, asks whether it is a terminal: the thread waits there for the caller."""
        def isatty(self):
            if threading.current_thread() is worker and not found.is_set():
                found.set()
                go.wait(10)
            return False

    def compile_something():
        NumbaError("a message numba makes, and catches, while it compiles")
        found.set()                 # (numba leaves the streams alone: nothing waited)

    worker = threading.Thread(target=compile_something, daemon=True)
    with contextlib.redirect_stdout(Earlier()), contextlib.redirect_stderr(Earlier()):
        worker.start()
        assert found.wait(10)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        go.set()
        worker.join(10)
        streams = sys.stdout, sys.stderr
        code = main(["window"])             # a usage error: exit 2 and one line on stderr
    assert not worker.is_alive()
    assert streams[0] is out and streams[1] is err, \
        f"the caller's streams were replaced by {streams} while numba made an error message"
    assert code == 2 and "kapitza window: error:" in err.getvalue(), err.getvalue()

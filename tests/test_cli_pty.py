"""The command line at a terminal (issue 22.4): progress lines where the README promises
them, and Ctrl-C from the keyboard.

Each test runs ``python -m kapitza ...`` in a child whose standard streams are a
pseudo-terminal (:func:`pty.fork`), left unsized — 0 rows × 0 columns, as CI runners,
``script(1)`` and editors' shells leave theirs.  ``kapitza sweep`` drew its progress bar
with tqdm, which at zero width draws nothing: the sweep looked stalled at a terminal.
``kapitza map`` shows a :mod:`lagrange_core.progress` line there (after 0.5 s; its grid
here takes seconds), and ^C typed at the terminal stops it keeping what finished.
"""
import os
import re
import select
import signal
import sys
import time

import pytest

from helpers import pendulum_scene, sigint_default

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="pseudo-terminals are POSIX")


def on_a_terminal(argv, cwd, *, timeout=120.0, interrupt_on=None):
    """Run ``python -m kapitza argv`` on a fresh pseudo-terminal: (exit code, all it wrote
    there, the seconds from Ctrl-C to the first line the child ended after it, or None).
    With ``interrupt_on`` (a regular expression), Ctrl-C is typed on the terminal 0.3 s
    after the output matches it (a user's reaction; at once, it can land between the
    progress line's first write and its bookkeeping); the progress line ends (a newline)
    the moment the chunked work stops, before the partial results are written."""
    import pty
    pid, fd = pty.fork()
    if pid == 0:                                # the child: exec at once
        try:
            os.chdir(cwd)
            sigint_default()
            os.execv(sys.executable, [sys.executable, "-m", "kapitza", *argv])
        finally:
            os._exit(127)
    out, sent, stopped, deadline = b"", None, None, time.monotonic() + timeout
    seen = None
    try:
        while time.monotonic() < deadline:
            ready, _, _ = select.select([fd], [], [], 0.1)
            if ready:
                try:
                    chunk = os.read(fd, 65536)
                except OSError:                 # EIO: the child closed the terminal
                    break
                if not chunk:
                    break
                if sent is not None and stopped is None and b"\n" in chunk:
                    stopped = time.monotonic() - sent
                out += chunk
            if interrupt_on and seen is None and re.search(interrupt_on,
                                                           out.decode(errors="replace")):
                seen = time.monotonic()
            if seen is not None and sent is None and time.monotonic() > seen + 0.3:
                os.write(fd, b"\x03")           # ^C: the terminal sends SIGINT
                sent = time.monotonic()
        else:
            os.kill(pid, signal.SIGKILL)
            raise AssertionError(f"kapitza {' '.join(argv)} ran over {timeout} s: {out!r}")
        _, status = os.waitpid(pid, 0)
    finally:
        os.close(fd)
    return os.waitstatus_to_exitcode(status), out.decode(errors="replace"), stopped


#: A progress line of lagrange_core.progress: "label: done/total unit (x %), t s, ~t s left".
PROGRESS_LINE = r"\r[^\r\n]+: \d+/\d+ [\w ]+ \(\d+ %\), [\d.]+ s"


def test_sweep_shows_its_progress_at_a_terminal(tmp_path):
    scene = tmp_path / "swept.toml"
    scene.write_text(pendulum_scene(theta=3.0916,
                                    analyses='measure = { periods = 20, about = "inverted" }',
                                    sweep='analyses = ["measure"]\ntile_points = 2',
                                    axes="A = [0.01, 0.03, 0.05]\nomega = [100.0, 200.0]"))
    code, out, _ = on_a_terminal(["sweep", str(scene), "--directory", "out"], tmp_path)
    assert code == 0, out
    bar = re.findall(r"measure sweep:\s+(\d+)%\|[^\r\n]*\| (\d+)/6", out)
    assert bar and bar[-1] == ("100", "6"), out
    assert "sweep: 6 points in 3 tiles" in out


def test_map_shows_progress_and_stops_on_ctrl_c_at_a_terminal(tmp_path):
    """A map's progress line appears at the terminal; ^C typed then stops the work within a
    second (here two, or the load per core if larger: the machine is shared by test
    workers): exit 130, one line saying what was kept, the finished points saved (the
    rest NaN), no traceback.  (``verify`` shows
    the same line, from the same ProgressLine, when its grid takes over 0.5 s.)"""
    # 67 600 points up to A = 500 m (~2.6 CPU-s, ~1.3 s on this machine's two threads): the
    # map outlasts its first progress line (shown after 0.5 s) and the ^C typed 0.3 s later.
    # A point's Mathieu trace costs ~√A: at A ≤ 500 m a point costs ~6× one at A ≤ 5 m, so
    # 5.3× fewer points than the 600 × 600 up to 5 m it was give a map as long (as large a
    # margin on a faster machine), and the partial map's PNG and CSV, written after the ^C
    # in proportion to the points, cost ~1.5 CPU-s less.  (Nothing there is stable: the
    # test is of the progress line and the ^C, not of the map.)
    code, out, stopped = on_a_terminal(["map", "--A", "0:500:260", "--omega", "20:2000:260",
                                        "--log-omega", "--trace", "--out", "m.png"], tmp_path,
                                       interrupt_on=PROGRESS_LINE)
    assert code == 130, out
    # 1 s on an idle machine; the chunks' wall time grows with the load per core
    limit = max(2.0, os.getloadavg()[0] / (os.cpu_count() or 1))
    assert stopped is not None and stopped < limit, (stopped, os.getloadavg())
    assert "Traceback" not in out
    line = [s for s in out.splitlines() if "interrupted" in s]
    assert len(line) == 1 and re.search(r"\d+ of 67600 points finished", line[0]), out
    assert (tmp_path / "m.png").stat().st_size > 0 and (tmp_path / "m.csv").stat().st_size > 0

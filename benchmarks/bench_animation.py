"""Writing the animation's GIF: kapitza's writer against matplotlib's and the one before it.

Run:  python benchmarks/bench_animation.py [--rounds N]

The frames: those of ``kapitza.pendulum_animation(path, A=0.1, omega=2π·10)`` (the
defaults: 720 px wide, 20 frames/s, 4 s of slow motion), drawn once and kept in memory
(:func:`kapitza.animation._drawing.render` with a writer that keeps them).  Each row then
writes the same frames to a GIF, in this one process, the rounds interleaved, the best
kept; printed: seconds, ratio to kapitza's writer, file size.

* ``kapitza``: the report's writer (``kapitza.animation._drawing._gif_writer``): one shared
  64-colour palette (median cut of first, middle and last frame, the flat colours added
  exactly), each pixel its nearest palette colour through a table over the 2²⁴ colours
  filled as colours appear;
* ``per-frame search``: the same palette and the same indices, each frame's colours found
  with ``np.unique`` and searched (the writer up to 2026-11-27; its GIF is checked to be
  byte for byte the same);
* ``matplotlib PillowWriter``: matplotlib's own writer, as a user would write the frames
  with ``Animation.save(..., writer="pillow")`` (Pillow's per-frame adaptive palettes).

Then the whole ``pendulum_animation`` call (drawing and writing), as it is and with the
per-frame search as its writer, the rounds interleaved.
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def frames_of_the_default_gif():
    """The RGBA frames (height, width, 4) ``pendulum_animation``'s defaults draw."""
    from matplotlib.animation import PillowWriter

    import kapitza
    from kapitza.animation import _drawing
    kept = []
    real = _drawing._gif_writer

    def keeping(fps, exact=()):
        keeping.exact = exact
        writer = PillowWriter(fps=fps)

        def finish():               # keeps the frames; the file is left empty
            kept.extend(writer._frames)
            Path(writer.outfile).touch()
        writer.finish = finish
        return writer
    _drawing._gif_writer = keeping
    try:
        with tempfile.TemporaryDirectory() as tmp:
            kapitza.pendulum_animation(Path(tmp) / "a.gif", A=0.1, omega=2 * math.pi * 10,
                                       progress=False)
    finally:
        _drawing._gif_writer = real
    return kept, keeping.exact


def per_frame_search(writer):
    """The writer's finish as it was before the table: np.unique per frame."""
    from PIL import Image

    def finish():
        rgb = [f[..., :3] for f in writer._frames]
        mosaic = Image.fromarray(np.hstack([rgb[0], rgb[len(rgb) // 2], rgb[-1]]))
        palette = np.array(mosaic.quantize(colors=64 - len(writer.exact),
                                           method=Image.Quantize.MEDIANCUT,
                                           dither=Image.Dither.NONE).getpalette(),
                           float).reshape(-1, 3)
        palette = np.vstack([np.array(writer.exact, float) * 255, palette])
        frames = []
        for f in rgb:
            code = (f[..., 0].astype(np.int32) << 16) | (f[..., 1].astype(np.int32) << 8) \
                | f[..., 2]
            colours, where = np.unique(code, return_inverse=True)
            c = np.stack([colours >> 16, (colours >> 8) & 255, colours & 255], 1)
            nearest = np.argmin(((c[:, None, :] - palette[None]) ** 2).sum(2), 1)
            im = Image.fromarray(nearest[where].reshape(code.shape).astype(np.uint8), "P")
            im.putpalette(np.round(palette).astype(np.uint8).ravel().tolist())
            frames.append(im)
        frames[0].save(writer.outfile, save_all=True, append_images=frames[1:],
                       duration=int(1000 / writer.fps), loop=0)
    return finish


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3, help="timed rounds (best kept)")
    args = ap.parse_args(argv)
    from matplotlib.animation import PillowWriter
    from PIL import Image

    from kapitza.animation._drawing import _gif_writer
    frames, exact = frames_of_the_default_gif()
    h, w, _ = frames[0].shape
    print(f"{len(frames)} frames of {w} × {h} px (the default pendulum_animation)")

    def kapitza_writer(path):
        writer = _gif_writer(20, exact=exact)
        writer.outfile, writer.fps, writer._frames = str(path), 20, list(frames)
        return writer.finish

    def search_writer(path):
        writer = _gif_writer(20, exact=exact)
        writer.outfile, writer.fps, writer._frames = str(path), 20, list(frames)
        return per_frame_search(writer)

    def matplotlib_writer(path):
        writer = PillowWriter(fps=20)
        writer.outfile, writer._frames = str(path), [Image.fromarray(f) for f in frames]
        return writer.finish

    rows = {"kapitza": kapitza_writer, "per-frame search": search_writer,
            "matplotlib PillowWriter": matplotlib_writer}
    best = dict.fromkeys(rows, math.inf)
    with tempfile.TemporaryDirectory() as tmp:
        paths = {name: Path(tmp) / f"{k}.gif" for k, name in enumerate(rows)}
        for _ in range(args.rounds):
            for name, make in rows.items():
                finish = make(paths[name])
                start = time.perf_counter()
                finish()
                best[name] = min(best[name], time.perf_counter() - start)
        same = paths["kapitza"].read_bytes() == paths["per-frame search"].read_bytes()
        sizes = {name: path.stat().st_size for name, path in paths.items()}
    print(f"{'writer':<26}{'s':>8}{'× kapitza':>11}{'MB':>8}")
    for name in rows:
        print(f"{name:<26}{best[name]:8.2f}{best[name] / best['kapitza']:11.2f}"
              f"{sizes[name] / 1e6:8.2f}")
    print(f"kapitza's GIF byte for byte the per-frame search's: {same}")
    whole = whole_call(args.rounds)
    print(f"the whole pendulum_animation call (the API a user calls): "
          f"{whole['kapitza']:.2f} s, with the per-frame search {whole['per-frame search']:.2f} s "
          f"({whole['per-frame search'] / whole['kapitza']:.2f}×)")
    return 0 if same else 1


def whole_call(rounds):
    """Best seconds of ``kapitza.pendulum_animation(path, A=0.1, omega=2π·10)`` as it is and
    with the per-frame search as its writer, rounds interleaved."""
    import kapitza
    from kapitza.animation import _drawing
    real = _drawing._gif_writer

    def searching(fps, exact=()):
        writer = real(fps, exact)
        writer.finish = per_frame_search(writer)
        return writer
    best = {"kapitza": math.inf, "per-frame search": math.inf}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(rounds):
            for name, factory in (("kapitza", real), ("per-frame search", searching)):
                _drawing._gif_writer = factory
                try:
                    start = time.perf_counter()
                    kapitza.pendulum_animation(Path(tmp) / "a.gif", A=0.1,
                                               omega=2 * math.pi * 10, progress=False)
                    best[name] = min(best[name], time.perf_counter() - start)
                finally:
                    _drawing._gif_writer = real
    return best


if __name__ == "__main__":
    sys.exit(main())

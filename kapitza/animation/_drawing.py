"""Drawing the frames: a figure of side-by-side panels, each a chain of particles hanging
from a pivot that may move (:class:`Stage`), and the GIF written from it with one shared
palette (:func:`render`)."""
from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

from lagrange_core.progress import ProgressLine


def render(where, stage, path, fps, progress, label):
    """Draw every frame of ``stage`` into the GIF ``path``; Ctrl-C keeps the frames done."""
    frames = stage.frames
    written = 0
    line = ProgressLine(progress, frames, label, "frames")
    try:
        writer = _gif_writer(fps, exact=[*stage.colours, "0.85", "0.6", "0.4", "0.8"])
        with writer.saving(stage.fig, str(path), dpi=stage.dpi):
            # blitting: the static figure (axes, titles, the pivot's band, the legend line)
            # is drawn once; each frame restores it and draws only what moves — text drawing
            # was most of a full redraw (the example scene's 81 frames: the report section
            # 5.5 s → 2.3 s, every frame identical to the full redraw's pixel for pixel)
            canvas = stage.fig.canvas
            moving = sorted(stage.moving(), key=lambda a: a.get_zorder())
            for artist in moving:
                artist.set_animated(True)
            canvas.draw()
            static = canvas.copy_from_bbox(stage.fig.bbox)
            clock = _ClockSplit.make(stage, static)
            if clock is not None:
                fast = [clock.head if a is stage.clock else a for a in moving]
            for k in range(frames):
                stage.draw(k)
                if clock is not None and clock.same[k]:
                    canvas.restore_region(clock.static)
                    clock.head.set_text(clock.heads[k])
                    for artist in fast:
                        stage.fig.draw_artist(artist)
                else:
                    canvas.restore_region(static)
                    for artist in moving:
                        stage.fig.draw_artist(artist)
                writer._frames.append(np.array(canvas.buffer_rgba()))   # (see _gif_writer)
                written = k + 1
                line.update(written)
    except KeyboardInterrupt:
        line.close()
        print(f"\n{where}interrupted after {written} of {frames} frames; they are in "
              f"{path}.", file=sys.stderr, flush=True)
        raise
    finally:
        stage.close()
    line.close()


@dataclass
class _ClockSplit:
    """The clock's unchanging tail drawn once into the static figure, and its head (the
    time) drawn alone each frame, at the place the whole text puts it: the same pixels.

    The clock is the longest text a frame draws ("t = 1.234 s    slow motion ×2.55 (8
    frames per drive period)"), and matplotlib lays out and renders every glyph of a text
    each time it is drawn: of the default report's 204 frames, its clock took ~3.2 s of the
    section's ~7.3 s CPU (split: 5.2 s, the GIF byte for byte the same).  ``head``,
    left-aligned at the whole text's left edge (the same float: both are ``x - width/2`` of
    the centred text) on its baseline, in the same font, places each glyph where the whole
    text does; the tail is the whole text of frame 0 clipped to the columns right of a gap
    of blank columns between the two.  Frame 0 drawn this way must equal the whole text
    drawn (pixel for pixel), else no split; a frame is drawn the split way only if its
    head's width, height and descent are frame 0's (the tail then sits where it did:
    digits of equal advance), else in full, as before (e.g. from t = 10 s on).
    """

    head: object            # the Text drawn each frame (animated)
    heads: list             # its text at each frame
    static: object          # the static figure with the tail drawn in
    same: list              # frame k may be drawn split (its head measures as frame 0's)

    @classmethod
    def make(cls, stage, static):
        from matplotlib.transforms import Bbox, IdentityTransform

        fig, clock = stage.fig, stage.clock
        canvas = fig.canvas
        renderer = canvas.get_renderer()
        parts = [stage.clock_parts(k) for k in range(stage.frames)]
        tail = parts[0][1]
        if any(p[1] != tail for p in parts) or clock.get_rotation() != 0 or \
                clock.get_ha() != "center" or clock.get_usetex() or \
                "$" in "".join(p[0] for p in parts) + tail:
            return None
        # where the whole text of frame 0 is drawn: its left edge and its baseline (its box
        # laid out on the baseline lies its descent lower)
        clock.set_text(parts[0][0] + tail)
        box = clock.get_window_extent(renderer)
        va = clock.get_va()
        clock.set_va("baseline")
        low = clock.get_window_extent(renderer).y0
        clock.set_va(va)
        anchor = clock.get_transform().transform(clock.get_position())[1]
        head = fig.text(box.x0, box.y0 + (anchor - low), parts[0][0], ha="left",
                        va="baseline", transform=IdentityTransform(),
                        fontproperties=clock.get_fontproperties(), color=clock.get_color(),
                        alpha=clock.get_alpha(), zorder=clock.get_zorder(), animated=True)
        # each head's width, height and descent (the same font): frame 0's, and the head
        # still begins and ends with the same glyph, then the whole text's are frame 0's too
        # (its box is the union of the head's and the tail's), and so is its place
        prop, first, last = clock.get_fontproperties(), parts[0][0][0], parts[0][0][-1]
        metrics = [renderer.get_text_width_height_descent(h, prop, False)
                   if h[0] == first and h[-1] == last else None for h, _ in parts]
        # frame 0: the static figure, the whole text on it, the head alone on it
        bg = np.array(canvas.buffer_rgba())
        canvas.restore_region(static)
        fig.draw_artist(clock)
        whole = np.array(canvas.buffer_rgba())
        canvas.restore_region(static)
        head.set_text(parts[0][0])
        fig.draw_artist(head)
        alone = np.array(canvas.buffer_rgba())
        canvas.restore_region(static)
        ink_head = np.flatnonzero((alone != bg).any(axis=(0, 2)))
        ink_whole = np.flatnonzero((whole != bg).any(axis=(0, 2)))
        if not ink_head.size:
            return cls._drop(head)
        after = ink_whole[ink_whole > ink_head[-1]]
        if not after.size or after[0] - ink_head[-1] < 3:
            return cls._drop(head)
        split = int(ink_head[-1] + after[0] + 1) // 2
        clock.set_clip_box(Bbox.from_extents(split, 0, fig.bbox.width, fig.bbox.height))
        fig.draw_artist(clock)
        clock.set_clip_box(None)
        with_tail = canvas.copy_from_bbox(fig.bbox)
        fig.draw_artist(head)
        if not np.array_equal(np.asarray(canvas.buffer_rgba()), whole):
            return cls._drop(head)
        return cls(head, [p[0] for p in parts], with_tail,
                   [m == metrics[0] for m in metrics])

    @staticmethod
    def _drop(head):
        """No split (``make`` returns None): the head is taken off the figure."""
        head.remove()
        return None


def _gif_writer(fps, exact=()):
    """matplotlib's PillowWriter, writing every frame with one shared palette of 64 colours
    and no dithering (each pixel its nearest palette colour): flat colours compress better
    than the per-frame dithered palettes PillowWriter writes (the default 160-frame scene:
    0.44 MB against 1.86 MB, 4.2× smaller, and faster to write)."""
    from matplotlib.animation import PillowWriter
    from matplotlib.colors import to_rgb
    from PIL import Image

    class GifWriter(PillowWriter):
        def finish(self):
            if not self._frames:
                return
            # the frames are the canvas's RGBA bytes, (height, width, 4) uint8 arrays
            # (``render``: no PIL image per frame; PillowWriter's own grab_frame appends
            # images); each pixel as a 24-bit code R | G << 8 | B << 16, its four bytes
            # read as a little-endian word with the alpha masked off (dropped, as an RGB
            # conversion drops it)
            rgba = [f if isinstance(f, np.ndarray) else np.asarray(f.convert("RGBA"))
                    for f in self._frames]
            # the palette from first, middle and last frame side by side (every colour drawn)
            mosaic = Image.fromarray(np.hstack([rgba[k][..., :3] for k in
                                                (0, len(rgba) // 2, len(rgba) - 1)]))
            palette = np.array(mosaic.quantize(colors=64 - len(self.exact),
                                               method=Image.Quantize.MEDIANCUT,
                                               dither=Image.Dither.NONE).getpalette(),
                               float).reshape(-1, 3)
            # median cut averages its boxes: the colours drawn flat (background, text, rods,
            # the pivot's band) are added exactly, so they stay what was drawn
            palette = np.vstack([np.array(self.exact, float) * 255, palette])
            # each pixel's nearest palette colour, through a table over the 2²⁴ colours
            # filled as colours appear: the frames share almost all their colours, so after
            # the first only the few new ones (antialiased edges) are looked up.  The same
            # indices as a search per frame (np.unique of each frame took 3.2 s of the 8.3 s
            # of a 321-frame pendulum_animation: benchmarks/bench_animation.py)
            unset = 255                     # (the palette has 64 colours)
            table = np.full(1 << 24, unset, np.uint8)
            colours_8bit = np.round(palette).astype(np.uint8).ravel().tolist()
            frames = []
            for f in rgba:                  # (a frame's codes at a time: 1.5 MB, not 0.5 GB)
                code = f.view("<u4")[..., 0] & 0xFFFFFF
                index = table[code]
                colours = np.unique(code[index == unset])
                if colours.size:
                    c = np.stack([colours & 255, (colours >> 8) & 255, colours >> 16], 1)
                    table[colours] = np.argmin(((c[:, None, :] - palette[None]) ** 2).sum(2), 1)
                    index = table[code]
                im = Image.fromarray(index, "P")
                im.putpalette(colours_8bit)
                frames.append(im)
            frames[0].save(self.outfile, save_all=True, append_images=frames[1:],
                           duration=int(1000 / self.fps), loop=0)

    writer = GifWriter(fps=fps)
    writer.exact = [(1.0, 1.0, 1.0), (0.0, 0.0, 0.0), *map(to_rgb, exact)]
    return writer


COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:purple")


@dataclass(frozen=True)
class Panel:
    """One chain to draw: anchor (frames, 2) and particles (frames, n, 2) in m, joined in
    order by rods; its colour, title and a text per frame; with the strobe, the whole chain
    (pivot first) at s phases of the drive period starting at each frame, drawn faint."""

    anchor: np.ndarray
    points: np.ndarray
    colour: str
    title: str
    readout: list
    blur: np.ndarray | None = None      # (frames, s, links + 1, 2): the chain over a period


class Stage:
    """The figure of side-by-side panels, each a chain of particles hanging from a pivot
    that may move, and how frame k is drawn on it.

    ``draw(k)`` sets the artists from the arrays it was given, nothing else: the tests read
    the artists' data back (``rods``, ``bobs``) against an independent simulation.  Every
    panel has the same scale: its half-width is the largest reach max|anchor| + Σ|links|.
    """

    def __init__(self, panels, t, title, slow, frames_per_period, width, subtitle="",
                 stride=None):
        import matplotlib
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.panels, self.t, self.slow = panels, t, slow
        self.frames = len(t)
        self.frames_per_period, self.stride = frames_per_period, stride
        self.colours = [p.colour for p in panels]
        self.dpi = 100
        n = len(panels)
        self.width = int(width)
        self.height = int(round(width * (0.7 if n <= 2 else 0.2 + 1.0 / n)))
        fig = Figure(figsize=(self.width / self.dpi, self.height / self.dpi), dpi=self.dpi)
        FigureCanvasAgg(fig)
        self.fig = fig
        reach = 1.06 * max(_reach(p) for p in panels)
        scale = self.width / 720 * (1 if n <= 2 else 2 / n) ** 0.5
        big, font, small = ({"fontsize": s * scale} for s in (11, 10, 8.5))
        self.rods, self.bobs, self.trails, self.tilts, self.pivots = [], [], [], [], []
        self.blurs = []
        # margins for the titles and the clock: fixed in points, so a fraction of the height
        frac = 504 * scale / self.height
        top, bottom = 1 - 0.245 * frac, 0.13 * frac
        with matplotlib.rc_context({"font.size": 10 * scale}):
            axes = np.atleast_1d(fig.subplots(1, n, gridspec_kw=dict(
                left=0.01, right=0.99, bottom=bottom, top=top, wspace=0.03)))
            for ax, panel in zip(axes, panels, strict=True):
                ax.set_xlim(-reach, reach)
                ax.set_ylim(-reach, reach)
                ax.set_aspect("equal")
                ax.set_xticks([])
                ax.set_yticks([])
                for side in ax.spines.values():
                    side.set_color("0.8")
                c = panel.colour
                # the pivot's path (its shake) as a thick grey band, and the upright direction
                band = _travel(panel.anchor if panel.blur is None
                               else panel.blur[:, :, 0].reshape(-1, 2))
                ax.plot(band[:, 0], band[:, 1], color="0.85", lw=14 * scale,
                        solid_capstyle="butt", zorder=0)
                x0, y0 = panel.anchor.mean(0)
                ax.plot([x0, x0], [y0, y0 + 0.95 * reach], ls=(0, (4, 4)), color="0.6",
                        lw=0.8, zorder=0)
                trail, = ax.plot([], [], color=c, lw=1.2, alpha=0.4, zorder=1)
                # strobe: the chain at the later phases of the frame's drive period, faint
                blur = [] if panel.blur is None else [
                    ax.plot([], [], color=c, lw=1.5 * scale, alpha=0.3, zorder=1)[0]
                    for _ in range(panel.blur.shape[1] - 1)]
                rod, = ax.plot([], [], color=c, lw=3 * scale, solid_capstyle="round",
                               solid_joinstyle="round", zorder=2)
                bob, = ax.plot([], [], "o", color=c, ms=13 * scale, zorder=3, ls="none")
                piv, = ax.plot([], [], "s", color="k", ms=6 * scale, zorder=4)
                # below the panel: a swinging chain would cross any text inside it
                tilt = ax.text(0.5, -0.008, "", transform=ax.transAxes, ha="center",
                               va="top", family="monospace", **small)
                head = ax.set_title(panel.title, color=c, pad=5, linespacing=1.35, **font)
                _fit(head, 0.98 * self.width / n)
                self.rods.append(rod)
                self.bobs.append(bob)
                self.trails.append(trail)
                self.pivots.append(piv)
                self.tilts.append(tilt)
                self.blurs.append(blur)
            _fit(fig.suptitle(title, y=0.985, **big), 0.98 * self.width)
            if subtitle:
                fig.text(0.5, 1 - 0.074 * frac, subtitle, ha="center", va="bottom",
                         color="0.3", **small)
            self.clock = fig.text(0.5, 0.052 * frac, "", ha="center", va="bottom", **font)
            bob = "bob's" if max(p.points.shape[1] for p in panels) == 1 else "outer bob's"
            faint = (f"faint: the chain and the {bob} path through the drive period after "
                     "the frame" if stride else f"faint curve: the {bob} path over the last "
                     + ("drive period" if frames_per_period else "second"))
            _fit(fig.text(0.5, 0.012 * frac, "grey band: the pivot's travel    dashed: the "
                          f"upright    {faint}", ha="center", va="bottom", color="0.4",
                          **small), 0.98 * self.width)

    def draw(self, k):
        n = self.frames_per_period or 1
        for i, p in enumerate(self.panels):
            chain = np.vstack([p.anchor[k], p.points[k]])
            self.rods[i].set_data(chain[:, 0], chain[:, 1])
            self.bobs[i].set_data(p.points[k, :, 0], p.points[k, :, 1])
            self.pivots[i].set_data([p.anchor[k, 0]], [p.anchor[k, 1]])
            if p.blur is None:
                # the last bob's path over the last drive period: the fast wobble, as a smear
                j = slice(max(0, k - n), k + 1)
                self.trails[i].set_data(p.points[j, -1, 0], p.points[j, -1, 1])
            else:
                # the drive period after the frame, which the strobe skips: drawn faint
                self.trails[i].set_data(p.blur[k, :, -1, 0], p.blur[k, :, -1, 1])
                for line, phase in zip(self.blurs[i], p.blur[k, 1:], strict=True):
                    line.set_data(phase[:, 0], phase[:, 1])
            self.tilts[i].set_text(p.readout[k])
        self.clock.set_text("".join(self.clock_parts(k)))

    def clock_parts(self, k):
        """The clock's text at frame k in two parts: the time, which changes, and how the
        frames play, which does not."""
        if self.stride:
            motion = (f"stroboscopic: one frame every {self.stride} drive period"
                      f"{'s' if self.stride > 1 else ''}, same phase ({_pace(self.slow)})")
        elif self.frames_per_period:
            motion = (f"{_pace(self.slow)} ({self.frames_per_period} frames per drive "
                      "period)")
        else:
            motion = "real time"
        return f"t = {self.t[k]:5.3f} s", f"    {motion}"

    def moving(self):
        """The artists :meth:`draw` changes (all else in the figure stays as drawn)."""
        return [*self.trails, *(line for lines in self.blurs for line in lines), *self.rods,
                *self.bobs, *self.pivots, *self.tilts, self.clock]

    def close(self):
        self.fig.clear()


def _pace(slow):
    """How fast the GIF plays: "slow motion ×4", "real time" (within 5 %), "×2 fast"."""
    if slow > 1.05:
        return f"slow motion ×{slow:.3g}"
    if slow >= 1 / 1.05:
        return "real time"
    return f"×{1 / slow:.3g} fast"


def _fit(text, width_px):
    """Shrink ``text``'s font until it is at most ``width_px`` wide (long titles)."""
    renderer = text.figure.canvas.get_renderer()
    for _ in range(8):          # glyph widths are hinted: not quite proportional to size
        wide = text.get_window_extent(renderer).width
        if wide <= width_px:
            return
        text.set_fontsize(text.get_fontsize() * 0.99 * width_px / wide)


def _travel(anchor):
    """The pivot's path to draw as its band: the segment between its extremes when it moves
    on a line (vertical, horizontal, oblique drive), else the path itself (an ellipse)."""
    centred = anchor - anchor.mean(0)
    if not np.any(centred):
        return anchor[:1]
    _, sv, vt = np.linalg.svd(centred, full_matrices=False)
    if sv[1] > 1e-9 * sv[0]:
        return anchor
    along = centred @ vt[0]
    return anchor[[np.argmin(along), np.argmax(along)]]


def _reach(panel):
    """max |anchor| + the chain's length at frame 0 (m): the farthest a bob can go."""
    chain = np.vstack([panel.anchor[0], panel.points[0]])
    anchors = panel.anchor if panel.blur is None else panel.blur[:, :, 0]
    return float(np.abs(anchors).max() + np.linalg.norm(np.diff(chain, axis=0), axis=1).sum())

"""The animation (issue 14, point 2's GIF and point 1's ``kapitza animate``).

One small GIF (ω/ω0 = 10, A/l = 0.25, 4 frames per drive period, 300 px wide, 1.6 s) is
written once per module; the tests read it back with Pillow and check the drawn state
against an independent simulation, the classifications against ``measure`` and Floquet.
"""
import json
import math
import warnings

import numpy as np
import pytest
from matplotlib.colors import to_rgb
from PIL import Image
from scipy.integrate import quad

import kapitza
from kapitza import KapitzaPendulum, cli
from kapitza.animation._pendulum import bob_position, pendulum_stage

L, G = 1.0, 9.81
W0 = math.sqrt(G / L)
OMEGA = 10 * W0                 # window 0.142 < A/l < 0.471 here
A = 0.25
THETA0 = math.pi - 0.1
SMALL = dict(duration=1.6, frames_per_period=4, width=300, fps=20)


def _keeping_frames(frames):
    """``render()``'s GIF writer, keeping in ``frames`` the RGBA frames handed to it as they
    reach its ``finish`` (which then writes the GIF as always)."""
    import kapitza.animation._drawing as drawing
    real = drawing._gif_writer

    def keeping(fps, exact=()):
        writer = real(fps, exact=exact)
        finish = writer.finish

        def finish_keeping():
            frames.extend(writer._frames)
            finish()
        writer.finish = finish_keeping
        return writer
    return keeping


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    """The module's GIF, and the RGBA frames ``render()`` handed its writer: kept as they
    reach the writer's ``finish``, which then writes the GIF as always, so the blitting
    test compares this animation's own frames with full redraws instead of drawing all
    its frames a second time."""
    import kapitza.animation._drawing as drawing
    frames = []
    path = tmp_path_factory.mktemp("anim") / "pendulum.gif"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(drawing, "_gif_writer", _keeping_frames(frames))
        anim = kapitza.pendulum_animation(path, A=A, omega=OMEGA, l=L, g=G, theta0=THETA0,
                                          progress=False, **SMALL)
    return anim, frames


@pytest.fixture(scope="module")
def anim(drawn):
    return drawn[0]


def test_the_gif_has_the_stated_frames_size_rate_and_loops(anim):
    period = 2 * math.pi / OMEGA
    expected = math.floor(1.6 / (period / 4)) + 1
    assert anim.frames == expected == len(anim.t)
    with Image.open(anim.path) as im:
        assert im.format == "GIF"
        assert im.n_frames == anim.frames
        assert im.size == (anim.width, anim.height) == (300, 210)
        assert im.info["loop"] == 0                         # loops forever
        assert im.info["duration"] == 50                    # 20 frames/s
    assert anim.bytes == anim.path.stat().st_size < 2e6
    # frames at t_k = k T/n: 4 phases of every drive period, so the slow motion is n/(T fps)
    np.testing.assert_allclose(np.diff(anim.t), period / 4, rtol=1e-12)
    assert anim.slow_motion == pytest.approx(4 / (period * 20), rel=1e-12)


def test_the_drawn_angles_are_an_independent_simulation(anim):
    pend = KapitzaPendulum(l=L, g=G)
    for i, amp in enumerate((A, 0.0)):
        ref = pend.simulate(amp, OMEGA, THETA0, 0.0, (0.0, anim.t[-1]), rtol=1e-11,
                            t_eval=anim.t)
        np.testing.assert_allclose(anim.theta[i], ref.q[:, 0], atol=1e-7)
        np.testing.assert_allclose(anim.pivot[i], amp * np.cos(OMEGA * anim.t), atol=1e-15)
    # the artists show exactly those states: rod from the pivot to l (sin θ, −cos θ)
    stage = pendulum_stage(anim.t, anim.theta, anim.pivot, anim.A, l=L, g=G, damping=0.0,
                            omega=OMEGA, window=anim.window, stayed=anim.stayed_up,
                            fall=anim.fall_time, floquet=anim.floquet_stable, tilt0=0.1,
                            slow=anim.slow_motion, frames_per_period=4, width=300)
    gif = Image.open(anim.path)
    try:
        for k in (0, anim.frames // 2, anim.frames - 1):
            stage.draw(k)
            gif.seek(k)
            pixels = np.asarray(gif.convert("RGB"), float)
            for i in range(2):
                x, y = stage.rods[i].get_data()
                yp = anim.A[i] * math.cos(OMEGA * anim.t[k])
                assert (x[0], y[0]) == (0.0, pytest.approx(yp, abs=1e-15))
                th = anim.theta[i, k]
                np.testing.assert_allclose([x[1], y[1]], [L * math.sin(th), yp - L * math.cos(th)],
                                           atol=1e-15)
                assert np.allclose(stage.bobs[i].get_data(), ([x[1]], [y[1]]))
                # and the GIF's frame k has the bob's colour at that point
                px, py = stage.bobs[i].axes.transData.transform((x[1], y[1]))
                colour = np.array(to_rgb(stage.colours[i])) * 255
                seen = pixels[int(round(stage.height - py)), int(round(px))]
                assert np.abs(seen - colour).max() < 40, (k, i, seen, colour)
                assert f"{anim.t[k]:5.3f} s" in stage.clock.get_text()
    finally:
        gif.close()
        stage.close()
    frame = anim.to_dataframe()
    assert len(frame) == anim.frames
    x, y = bob_position(anim.theta[1], anim.pivot[1], L)
    np.testing.assert_array_equal(frame["falling_bob_x"], x)
    np.testing.assert_array_equal(frame["stable_theta"], anim.theta[0])


def test_blitted_frames_equal_full_redraws(drawn):
    """render() draws the static figure once and only the moving artists per frame; each
    frame equals a full redraw of the figure pixel for pixel (before the GIF's palette).
    The frames are those the module's animation handed its GIF writer (``drawn``)."""
    anim, frames = drawn
    full = pendulum_stage(anim.t, anim.theta, anim.pivot, anim.A, l=L, g=G, damping=0.0,
                          omega=OMEGA, window=anim.window, stayed=anim.stayed_up,
                          fall=anim.fall_time, floquet=anim.floquet_stable, tilt0=0.1,
                          slow=anim.slow_motion, frames_per_period=4, width=300)
    assert len(frames) == anim.frames
    try:
        for k in (0, 7, anim.frames - 1):
            full.draw(k)
            full.fig.canvas.draw()
            np.testing.assert_array_equal(np.asarray(frames[k]),
                                          np.asarray(full.fig.canvas.buffer_rgba()))
    finally:
        full.close()


@pytest.mark.parametrize("as_images", [False, True], ids=["canvas bytes", "PIL images"])
def test_each_gif_pixel_is_its_drawn_colours_nearest_palette_colour(tmp_path, monkeypatch,
                                                                    as_images):
    """The GIF writer maps each pixel to the palette colour nearest (in RGB) to the colour
    drawn, through a table filled as colours appear: checked against a search pixel by
    pixel, on frames whose colours change from one frame to the next (later frames bring
    colours the first lacked), with the colours drawn flat kept exactly.  The frames as
    ``render`` hands them (the canvas's RGBA bytes) or as PillowWriter's ``grab_frame``
    does (images)."""
    from kapitza.animation._drawing import _gif_writer
    rng = np.random.default_rng(7)
    exact = [(0.0, 0.0, 1.0), (1.0, 0.5, 0.0)]
    flat = np.array([[255, 255, 255], [0, 0, 0], [0, 0, 255], [255, 128, 0]], np.uint8)
    frames = []
    for k in range(5):
        rgb = flat[rng.integers(0, 4, size=(12, 16))]
        rgb[:, :2 * (k + 1)] = rng.integers(0, 256, size=(12, 2 * (k + 1), 3))  # new colours
        frames.append(np.dstack([rgb, np.full((12, 16), 255, np.uint8)]))
    written = []        # the indexed frames handed to Pillow's GIF encoder
    monkeypatch.setattr(Image.Image, "save", lambda self, fp, save_all, append_images, **kw:
                        written.extend([self, *append_images]))
    writer = _gif_writer(10, exact=exact)
    writer.outfile, writer.fps = tmp_path / "t.gif", 10
    writer._frames = [Image.fromarray(f) for f in frames] if as_images else list(frames)
    writer.finish()
    assert len(written) == len(frames)
    for im, drawn in zip(written, frames, strict=True):
        assert im.mode == "P"
        palette = np.array(im.getpalette(), float).reshape(-1, 3)
        assert len(palette) == 64
        rgb = drawn[..., :3].reshape(-1, 3).astype(float)
        d2 = ((rgb[:, None, :] - palette[None]) ** 2).sum(2)
        # each pixel's index is a nearest palette colour to what was drawn (ties: any)
        chosen = d2[np.arange(rgb.shape[0]), np.asarray(im).ravel()]
        np.testing.assert_array_equal(chosen, d2.min(1))
        # the flat colours are in the palette exactly, so they are written unchanged
        is_flat = (drawn[..., :3].reshape(-1, 1, 3) == flat[None]).all(2).any(1)
        assert is_flat.sum() > 50
        np.testing.assert_array_equal(chosen[is_flat], 0.0)


def test_driven_stays_up_the_other_falls_as_measure_and_floquet_say(anim):
    pend = KapitzaPendulum(l=L, g=G)
    assert anim.stayed_up == (True, False)
    assert anim.floquet_stable == (True, False)
    assert pend.floquet(A, OMEGA).stable and not pend.floquet(0.0, OMEGA).stable
    # the driven one stays within a small band of upright: its slow amplitude ~ the tilt
    assert anim.max_tilt[0] < 0.2 and anim.max_tilt[1] > math.pi / 2
    # measure (the compiled batch integrator, the band's crossing located) agrees
    periods = int(anim.t[-1] / (2 * math.pi / OMEGA))
    up = pend.measure(A, OMEGA, THETA0, periods=periods)
    down = pend.measure(0.0, OMEGA, THETA0, periods=periods)
    assert up.stayed_up and not down.stayed_up
    # the undriven fall from rest at φ0 = 0.1 rad from the top to the horizontal, by
    # quadrature of energy conservation φ̇² = 2ω0²(cos φ0 − cos φ), independent of any
    # integrator (φ = φ0 + u² removes the 1/√ singularity at the release)
    phi0 = 0.1
    u1 = math.sqrt(math.pi / 2 - phi0)
    t_fall = quad(lambda u: 2 * u / math.sqrt(2 * W0**2 * (math.cos(phi0)
                                                           - math.cos(phi0 + u * u)))
                  if u > 0 else 2 / math.sqrt(2 * W0**2 * math.sin(phi0)), 0, u1,
                  epsabs=1e-12, epsrel=1e-12)[0]
    assert down.fall_time == pytest.approx(t_fall, rel=1e-6)
    # the label's fall time interpolates linearly between frames Δt = T/4 apart: its error
    # is ≲ Δt² θ̈/(8 θ̇) = 0.05² · 9.81/(8 · 4.42) s = 7e-4 s at the horizontal
    assert anim.fall_time[1] == pytest.approx(t_fall, abs=7e-4)


def test_bad_inputs_name_the_argument_and_the_fix(tmp_path):
    gif = tmp_path / "x.gif"
    with pytest.raises(ValueError, match=r"A = 0\.05 m is outside the window.*A_min = "
                       r"0\.142.*choose A between"):
        kapitza.pendulum_animation(gif, A=0.05, omega=OMEGA, **SMALL)
    with pytest.raises(ValueError, match=r"A = 0\.6 m is outside the window.*A_max"):
        kapitza.pendulum_animation(gif, A=0.6, omega=OMEGA, **SMALL)
    with pytest.raises(ValueError, match=r"A_fall = 0\.3 m lies inside the window.*A_fall = 0"):
        kapitza.pendulum_animation(gif, A=A, omega=OMEGA, A_fall=0.3, **SMALL)
    with pytest.raises(ValueError, match=r"duration must be a finite number > 0 \(s\), got -1"):
        kapitza.pendulum_animation(gif, A=A, omega=OMEGA, duration=-1)
    with pytest.raises(ValueError, match=r"frames_per_period must be an integer.*alias"):
        kapitza.pendulum_animation(gif, A=A, omega=OMEGA, frames_per_period=2)
    with pytest.raises(ValueError, match=r"path must end in \.gif"):
        kapitza.pendulum_animation(tmp_path / "x.png", A=A, omega=OMEGA)
    with pytest.raises(ValueError, match=r"more than max_frames = 600; shorten duration.*"
                       r"mode='strobe'"):
        kapitza.pendulum_animation(gif, A=0.05, omega=2 * math.pi * 60, duration=4,
                                   mode="slow")
    with pytest.raises(ValueError, match=r"mode must be one of"):
        kapitza.pendulum_animation(gif, A=A, omega=OMEGA, mode="fast")
    with pytest.raises(ValueError, match=r"theta0 must be released near the upright"):
        kapitza.pendulum_animation(gif, A=A, omega=OMEGA, theta0=0.3)
    assert not gif.exists()


def test_a_fast_drive_is_strobed_at_one_phase_with_the_period_drawn_faint(tmp_path):
    """Kapitza's 60 Hz: slow motion would need 8 frames every 1/60 s, so "auto" strobes one
    frame every m = round(1/(fps T)) = 3 periods; the pivot is at its top in every frame and
    the faint chains are the simulation at the n phases of the period after each frame."""
    w = 2 * math.pi * 60
    anim = kapitza.pendulum_animation(tmp_path / "k.gif", A=0.05, omega=w, duration=1.5,
                                      width=300, progress=False)
    T = 2 * math.pi / w
    assert anim.periods_per_frame == 3 and anim.frames == 31
    np.testing.assert_allclose(anim.t, np.arange(31) * 3 * T, rtol=1e-12)
    np.testing.assert_allclose(anim.pivot[0], 0.05, rtol=1e-12)       # same phase: the top
    assert anim.slow_motion == pytest.approx(1 / (3 * T * 20))         # ≈ real time
    assert anim.stayed_up == (True, False) and anim.floquet_stable == (True, False)
    pend = KapitzaPendulum()
    phases = anim.t[:, None] + np.arange(8) * T / 8
    ref = pend.simulate(0.05, w, math.pi - 0.1, 0.0, (0, phases[-1, -1]), rtol=1e-11,
                        t_eval=phases.ravel()).q[:, 0].reshape(phases.shape)
    np.testing.assert_allclose(anim.theta[0], ref[:, 0], atol=1e-7)
    stage = pendulum_stage(anim.t, ref[None].repeat(2, 0), 0.05 * np.cos(w * phases)[None]
                            .repeat(2, 0), anim.A, l=1.0, g=G, damping=0.0, omega=w,
                            window=anim.window, stayed=anim.stayed_up, fall=anim.fall_time,
                            floquet=anim.floquet_stable, tilt0=0.1, slow=anim.slow_motion,
                            frames_per_period=8, width=300, stride=3)
    try:
        k = 10
        stage.draw(k)
        for j, line in enumerate(stage.blurs[0], start=1):
            x, y = line.get_data()
            yp = 0.05 * math.cos(w * phases[k, j])
            np.testing.assert_allclose([x[1], y[1]], [math.sin(ref[k, j]),
                                                      yp - math.cos(ref[k, j])], atol=1e-12)
        assert "one frame every 3 drive periods" in stage.clock.get_text()
    finally:
        stage.close()
    with Image.open(anim.path) as im:
        assert im.n_frames == 31


def test_cli_writes_the_gif_and_json(tmp_path, capsys):
    """The command's options reach pendulum_animation and its result is the JSON; 0.4 s (8
    frames over two drive periods) is enough for that: what the frames show and the driven
    pendulum staying up over 1.6 s are the module animation's tests."""
    out = tmp_path / "cli.gif"
    code = cli.main(["animate", "--A-over-l", "0.25", "--omega-over-omega0", "10",
                     "--duration", "0.4", "--frames-per-period", "4", "--width", "300",
                     "--out", str(out), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    data = json.loads(captured.out)
    with Image.open(out) as im:
        assert im.n_frames == data["frames"] and im.size == (300, 210)
    assert data["frames"] == 8          # t_k = k T/4 ≤ 0.4 s (T = 0.2006 s): k ≤ 7
    assert data["path"] == str(out) and data["A"] == pytest.approx(0.25)
    assert data["omega_over_omega0"] == pytest.approx(10)
    assert data["floquet_stable"] == [True, False] and data["stayed_up"][0] is True
    # outside the window: exit 2, the message names A and the window
    code = cli.main(["animate", "--A", "0.05", "--omega-over-omega0", "10",
                     "--out", str(tmp_path / "bad.gif")])
    err = capsys.readouterr().err
    assert code == 2 and "A = 0.05 m is outside the window" in err
    assert cli.main(["animate", "--help"]) == 0
    assert "kapitza animate" in capsys.readouterr().out


# -- system_animation: Acheson's double pendulum, upright when shaken, falling when not ------

CHAIN = """schema = 1
title = "{title}"
[system]
name = "double_pendulum"
[parameters]
l1 = 1.0
l2 = 1.0
m1 = 1.0
m2 = 1.0
g = 9.81
[effects]
gravity = true
{drive}
[initial]
theta1 = 3.10
theta2 = 3.20
"""
DRIVE = '[effects.drive]\ndirection = "vertical"\namplitude = 0.08\nomega = 100.0'


@pytest.fixture(scope="module")
def chains(tmp_path_factory):
    up = kapitza.Scene.from_text(CHAIN.format(title="shaken", drive=DRIVE))
    down = kapitza.Scene.from_text(CHAIN.format(title="still", drive=""))
    path = tmp_path_factory.mktemp("chains") / "chains.gif"
    return kapitza.system_animation(path, [up, down], duration=1.2, frames_per_period=4,
                                    width=300, progress=False), up, down


def test_chains_draw_the_simulated_positions(chains):
    anim, up, down = chains
    with Image.open(anim.path) as im:
        assert im.n_frames == anim.frames == len(anim.t) and im.size == (300, 210)
    np.testing.assert_allclose(np.diff(anim.t), 2 * math.pi / 100 / 4, rtol=1e-12)
    for i, (scene, amp) in enumerate(((up, 0.08), (down, 0.0))):
        ref = scene.system.simulate(scene.q0, scene.qdot0, (0.0, anim.t[-1]), scene.params,
                                    rtol=1e-11, t_eval=anim.t)
        th1, th2 = ref.q[:, 0], ref.q[:, 1]
        np.testing.assert_allclose(anim.q[i], ref.q, atol=1e-7)
        # the chain by hand: pivot (0, A cos ωt), links of 1 m from the downward vertical
        yp = amp * np.cos(100.0 * anim.t)
        x1, y1 = np.sin(th1), yp - np.cos(th1)
        x2, y2 = x1 + np.sin(th2), y1 - np.cos(th2)
        np.testing.assert_allclose(anim.anchor[i, :, 1], yp, atol=1e-12)
        np.testing.assert_allclose(anim.positions[i][:, 0], np.stack([x1, y1], 1), atol=1e-6)
        np.testing.assert_allclose(anim.positions[i][:, 1], np.stack([x2, y2], 1), atol=1e-6)
    frame = anim.to_dataframe()
    assert len(frame) == 2 * anim.frames and {"theta1", "x2", "pivot_y"} <= set(frame)


def test_shaken_chain_stays_up_as_achesons_theorem_says(chains):
    anim, up, down = chains
    assert anim.stayed_up == (True, False) and anim.floquet_stable == (True, False)
    assert math.isnan(anim.fall_time[0]) and 0 < anim.fall_time[1] < anim.t[-1]
    # Acheson's theorem (closed form, first-order averaging, inside its regime here: no
    # AveragingValidityWarning): A ω = 8 m/s above √2 g/ω_min = 5.79 m/s
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        acheson = kapitza.multiple_pendulum_upright([1.0, 1.0], [1.0, 1.0], A=0.08,
                                                    omega=100.0)
    assert bool(np.all(acheson.stable))
    with pytest.raises(ValueError, match="different drive frequencies"):
        other = kapitza.Scene.from_text(CHAIN.format(title="x", drive=DRIVE.replace("100.0",
                                                                                      "90.0")))
        kapitza.system_animation(anim.path.with_name("x.gif"), [up, other], duration=0.2)


def test_cli_animates_several_scenes(chains, tmp_path, capsys):
    """Scene files on the command line: one panel each, their classification in the JSON
    (Floquet's, which does not depend on the duration: 0.1 s, 7 frames, is enough here;
    the chains' fixture checks what is drawn over 1.2 s)."""
    up, down = tmp_path / "up.toml", tmp_path / "down.toml"
    up.write_text(CHAIN.format(title="shaken", drive=DRIVE))
    down.write_text(CHAIN.format(title="still", drive=""))
    out = tmp_path / "c.gif"
    code = cli.main(["animate", str(up), str(down), "--duration", "0.1", "--width", "300",
                     "--frames-per-period", "4", "--out", str(out), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    data = json.loads(captured.out)
    assert data["scenes"] == [str(up), str(down)] and data["floquet_stable"] == [True, False]
    with Image.open(out) as im:
        assert im.n_frames == data["frames"] == 7          # t_k = k T/4 ≤ 0.1 s, k ≤ 6
    assert cli.main(["animate", str(up), "--A", "0.1", "--out", str(out)]) == 2
    assert "the scene sets the drive" in capsys.readouterr().err


def test_ctrl_c_keeps_the_finished_frames(tmp_path, monkeypatch, capsys):
    from kapitza.animation._drawing import Stage
    draw = Stage.draw

    def interrupted(self, k):
        if k == 5:
            raise KeyboardInterrupt
        draw(self, k)

    monkeypatch.setattr(Stage, "draw", interrupted)
    out = tmp_path / "cut.gif"
    with pytest.raises(KeyboardInterrupt):
        kapitza.pendulum_animation(out, A=A, omega=OMEGA, progress=False, **SMALL)
    assert "interrupted after 5 of 32 frames" in capsys.readouterr().err
    with Image.open(out) as im:
        assert im.n_frames == 5
    code = cli.main(["animate", "--A-over-l", "0.25", "--omega-over-omega0", "10",
                     "--duration", "1.6", "--frames-per-period", "4", "--width", "300",
                     "--out", str(out)])
    assert code == 130 and "frames finished are in" in capsys.readouterr().err


def test_a_drive_without_an_upright_equilibrium_is_drawn_not_classified(tmp_path):
    scene = kapitza.Scene.example("horizontal_drive")
    anim = kapitza.system_animation(tmp_path / "h.gif", [scene], duration=0.5, width=300,
                                    progress=False)
    assert anim.stayed_up == (None,) and anim.floquet_stable == (None,)
    assert "not classified" in anim.titles[0]
    # the pivot moves along x only: x_p = A cos ωt at the frames (the strobe's phase 0)
    np.testing.assert_allclose(anim.anchor[0, :, 0], 0.05 * np.cos(200.0 * anim.t),
                               atol=1e-12)
    np.testing.assert_array_equal(anim.anchor[0, :, 1], 0.0)


def test_clock_split_draws_the_frames_the_whole_clock_does(tmp_path):
    """render() draws the clock's unchanging tail once and only its time each frame
    (``_ClockSplit``): on this clip every frame is drawn that way, and each equals the frame
    drawn with the whole clock (the split turned off), pixel for pixel; so do the GIFs' bytes."""
    import kapitza.animation._drawing as drawing
    real_make = drawing._ClockSplit.make
    runs = {}

    def run(name, split):
        frames, made = [], []

        def make(stage, static):
            made.append(real_make(stage, static) if split else None)
            return made[-1]
        path = tmp_path / f"{name}.gif"
        with pytest.MonkeyPatch.context() as mp:         # each run the writer of the module
            mp.setattr(drawing, "_gif_writer", _keeping_frames(frames))
            mp.setattr(drawing._ClockSplit, "make", make)
            kapitza.pendulum_animation(path, A=A, omega=OMEGA, l=L, g=G, theta0=THETA0,
                                       progress=False, **SMALL)
        runs[name] = frames, made[0], path.read_bytes()

    run("split", True)
    run("whole", False)
    frames, split, gif = runs["split"]
    assert split is not None and all(split.same)
    assert len(frames) == len(runs["whole"][0])
    for k, (a, b) in enumerate(zip(frames, runs["whole"][0], strict=True)):
        np.testing.assert_array_equal(a, b, err_msg=f"frame {k}")
    assert gif == runs["whole"][2]

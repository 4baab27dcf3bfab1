"""How a scene's analyses are computed: once at the scene's point, or over a sweep's tile.

The method each analysis uses (the best its effects allow) is stated in
:meth:`kapitza.Scene.run`; here are the functions: ``POINT[name](scene, settings,
progress)`` returns the analysis's result at the scene's point, ``GRID[name](scene,
settings, params, q0, qdot0)`` a DataFrame over the points of a tile (``params`` values
arrays where swept), and :func:`tile_inputs` turns a tile's axis columns into those
inputs.  Every quantity arrives in SI units (the scene file's Hz were converted as it was
read, :mod:`._file`).
"""
from __future__ import annotations

import math

import numpy as np

from lagrange_core.progress import interrupt_requested

from ..averaging import average
from ..floquet import floquet_grid, floquet_point, stability_map, window
from ..results import PeriodicOrbit
from ..simulation import measure, measure_grid, periodic_orbit
from ..verification import verify
from ._frontier import FRONTIER_POINT, frontier_method
from ._rigs import default_band
from ._states import about_state as _about
from ._states import averaged_state as _averaged_state
from ._states import checked_state, naming_state, persists
from ._states import pendulum_state as _pendulum_state

__all__ = ["POINT", "GRID", "tile_inputs", "method_of", "run_analysis"]


# -- the settings passed on ------------------------------------------------------------------

#: Scene keys passed to the API under the same name, or renamed (scene key → keyword).
_RENAMED = {"taylor_order": "order"}
#: The keys of the general Floquet functions (monodromy integration) that the plain
#: pendulum's closed forms do not take: giving one runs the general function.
_MONODROMY_KEYS = ("guard_tol", "taylor_order", "coarse_tol", "A_range", "scan", "min_width")
#: The keys of a periodic orbit's shooting (floquet about a state the drive moves).
_ORBIT_KEYS = ("periods", "symmetry", "shooting", "max_iterations", "max_steps")


def _options(s, keys):
    """The settings among ``keys`` that the scene gives, as the API's keywords."""
    out = {_RENAMED.get(k, k): s[k] for k in keys if s.get(k) is not None}
    if out.get("symmetry") == "none":
        out["symmetry"] = None
    return out


def _state(scene, s, q0=None):
    """The state ``about`` names, checked (a singular mass matrix there is refused with the
    state named)."""
    return checked_state(scene, _about(scene, s.get("about"), q0), s.get("about"))


def _band(scene, s, about):
    """The measurement's band about ``about``, per coordinate in its unit (:mod:`._rigs`)."""
    return default_band(scene.spec.units or {q: "rad" for q in scene.system.coordinates},
                        list(scene.system.coordinates), about, s.get("band"))


# -- the analyses at the scene's point ---------------------------------------------------------

def _averaging(scene, s, progress):
    p = scene.spec.params
    pend = scene.pendulum
    if pend is not None and "guesses" not in s:
        return pend.averaged(p["A"], p["omega"], order=s.get("order", 1), warn=False)
    if s.get("order", 1) != 1:
        raise ValueError("order 2 is the plain pendulum's closed form; general averaging is "
                         "first order" + (" (and guesses are general averaging's)"
                                          if "guesses" in s else "") + ".")
    return average(scene.system).predict(p, _guesses(scene, s), warn=False)


def _guesses(scene, s):
    """Averaging's starting points: the scene's ``guesses``, else (a rig with a coordinate
    that is not an angle) its declared states, else None (averaging's own, for angles)."""
    if s.get("guesses") is not None:
        return np.array(s["guesses"], dtype=float)
    units = scene.spec.units
    if units and not all(u == "rad" for u in units.values()) and scene.spec.states:
        return np.array(list(scene.spec.states.values()), dtype=float)
    return None


def _floquet(scene, s, progress):
    """About an equilibrium of the driven system (the state persists): the monodromy
    (:func:`kapitza.floquet_point`); about a state the drive moves (a drive off the
    vertical, or a length on a vertically shaken pivot): the periodic orbit born from it
    (:func:`kapitza.periodic_orbit`)."""
    p = scene.spec.params
    tol = s.get("tol", 1e-10)
    q = _state(scene, s)
    with naming_state(scene, q, s.get("about")):
        if persists(scene, q):
            wrong = [k for k in _ORBIT_KEYS if k in s]
            if wrong:
                raise ValueError(f"{', '.join(wrong)} are the periodic orbit's settings, but "
                                 "the state is an equilibrium of the driven system (Floquet "
                                 "about it: kapitza.floquet_point); drop them.")
            return floquet_point(scene.system, p, q, tol=tol,
                                 **_options(s, ("guard_tol", "taylor_order")))
        wrong = [k for k in ("guard_tol", "taylor_order") if k in s]
        if wrong:
            raise ValueError(f"{', '.join(wrong)} are the monodromy's settings about an "
                             "equilibrium, but the drive moves the state (Floquet about the "
                             "periodic orbit born from it: kapitza.periodic_orbit); drop them.")
        return periodic_orbit(scene.system, p, q, tol=tol, **_options(s, _ORBIT_KEYS))


def _stability_map(scene, s, progress):
    A = np.asarray(s["A"].values)
    omega = np.asarray(s["omega"].values)
    about = s.get("about", "auto")
    pend = scene.pendulum
    if pend is not None and about in ("inverted", "hanging", "auto") \
            and not any(k in s for k in _MONODROMY_KEYS):
        return pend.stability_map(A, omega, about=_pendulum_state(scene, about),
                                  tol=s.get("tol", 1e-10), progress=progress)
    q = _state(scene, s)
    with naming_state(scene, q, about):
        return stability_map(scene.system, scene.spec.params, q, A=A, omega=omega,
                             tol=s.get("tol", 1e-8), progress=progress,
                             **_options(s, ("coarse_tol", "guard_tol", "taylor_order")))


def _window(scene, s, progress):
    """Exact unless the file asks for ``method = "averaging"``: the Mathieu window of the
    plain pendulum, :func:`kapitza.window` (certified monodromy edges) of any other
    system; never averaging in place of the exact window."""
    omega = np.asarray(s["omega"].values)
    about = s.get("about", "auto")
    averaging = s.get("method", "floquet") == "averaging"
    order = s.get("order", 1)
    pend = scene.pendulum
    if pend is not None and about in ("inverted", "hanging", "auto") \
            and not any(k in s for k in _MONODROMY_KEYS):
        state = _pendulum_state(scene, about)
        if not averaging:
            return pend.window(omega, about=state, tol=s.get("tol", 1e-10))
        if state != "inverted":
            raise ValueError("the averaging window is the upright state's (about = "
                             '"inverted"); the hanging state\'s window is exact only: drop '
                             'method = "averaging".')
        return pend.window(omega, method="averaging", order=order)
    q = _state(scene, s)
    with naming_state(scene, q, about):
        if averaging:
            if order != 1:
                raise ValueError("order 2 is the plain pendulum's closed form; the averaging "
                                 "window of any other system is first order.")
            wrong = [k for k in _MONODROMY_KEYS if k in s and k != "A_range"]
            if wrong:
                raise ValueError(f"{', '.join(wrong)} are the exact window's settings "
                                 '(method = "floquet"); the averaging window takes A_range '
                                 "only.")
            return average(scene.system).window(scene.spec.params, q, omega=omega,
                                                **_options(s, ("A_range",)))
        return window(scene.system, scene.spec.params, q, omega=omega, tol=s.get("tol", 1e-10),
                      **_options(s, ("A_range", "scan", "min_width", "guard_tol",
                                     "taylor_order")))


#: measure's settings besides its periods, band and rtol, passed on as they are.
_INTEGRATION_KEYS = ("observables", "atol", "method", "t0", "max_steps")


def _measure(scene, s, progress):
    q = _state(scene, s)
    with naming_state(scene, q, s.get("about")):
        return measure(scene.system, scene.spec.params, q, scene.q0, scene.qdot0,
                       periods=s.get("periods", 1000), band=_band(scene, s, q),
                       rtol=s.get("rtol"), progress=progress,
                       **_options(s, _INTEGRATION_KEYS))


def _span(scene, s, omega):
    if "duration" in s:
        return s["duration"]
    if "omega" in scene.spec.params:
        return s.get("periods", 100) * 2 * math.pi / omega
    return 10.0


def _simulate(scene, s, progress):
    t1 = _span(scene, s, scene.spec.params.get("omega"))
    t_eval = np.linspace(0.0, t1, s.get("samples", 1001))
    return scene.system.simulate(scene.q0, scene.qdot0, (0.0, t1), scene.spec.params,
                                 method=s.get("method"), rtol=s.get("rtol", 1e-9), t_eval=t_eval,
                                 **_options(s, ("atol", "max_steps", "h", "error_check")))


def _verify(scene, s, progress):
    A = np.asarray(s["A"].values)[:, None]
    omega = np.asarray(s["omega"].values)[None, :]
    common = dict(periods=s.get("periods", 1000), tol=s.get("tol", 1e-10),
                  rtol=s.get("rtol", 1e-9), line=None if s.get("fit_order") else False,
                  progress=progress)
    about = s.get("about", "auto")
    common.update(_options(s, ("method",)))
    pend = scene.pendulum
    if pend is not None and _pendulum_state(scene, about) == "inverted" \
            and not any(k in s for k in ("offset", "band", "length", "omega0")):
        near = 0 < abs(scene.q0[0] - math.pi) < math.pi / 2     # released near the upright
        return pend.verify(A, omega, theta0=scene.q0[0] if near else math.pi - 0.01,
                           theta_dot0=scene.qdot0[0] if near else 0.0, **common)
    q = _state(scene, s)
    with naming_state(scene, q, about):
        return verify(scene.system, scene.spec.params, q, A=A, omega=omega,
                      offset=s.get("offset", 0.01), band=_band(scene, s, q),
                      **common, **_options(s, ("length", "omega0")))


POINT = {"averaging": _averaging, "floquet": _floquet, "stability_map": _stability_map,
         "window": _window, "measure": _measure, "simulate": _simulate, "verify": _verify,
         **FRONTIER_POINT}


def run_analysis(scene, name, settings=None, *, progress=None):
    """Analysis ``name`` at the scene's point with ``settings`` (default: the scene's own;
    checked as a scene file's are), and how it was computed: (result, method).  For the
    report, which runs a scene's analyses with smaller settings in its quick mode."""
    if name not in POINT:
        raise ValueError(f"no analysis {name!r}; the analyses are {sorted(POINT)}.")
    if settings is None:
        settings = scene.spec.analyses.get(name, {})
    result = POINT[name](scene, settings, progress)
    return result, method_of(name, scene, settings, result)


# -- the method each analysis used, as its tables say ------------------------------------------

def method_of(name, scene, settings, result=None) -> str:
    """How analysis ``name`` was computed, "<family>: <detail>" (the ``method`` column of
    its tables): the family is "averaging", "floquet", "simulation", "comparison",
    "continuation" or "lyapunov".  ``result`` is the point result (None for a sweep's
    tile: the method is then the sweep's, decided by the scene alone)."""
    pend = scene.pendulum
    if name == "averaging":
        if pend is not None and "guesses" not in settings:
            return f"averaging: order {settings.get('order', 1)}, closed form"
        return "averaging: order 1 (kapitza.average)"
    if name == "floquet":
        equilibrium = (not isinstance(result, PeriodicOrbit) if result is not None
                       else _about_equilibrium(scene, settings))
        return ("floquet: monodromy about the equilibrium" if equilibrium else
                "floquet: periodic orbit by Newton shooting")
    if name == "stability_map":
        return f"floquet: {getattr(result, 'method', 'monodromy')}"
    if name == "window":
        if getattr(result, "method", settings.get("method", "floquet")) == "averaging":
            closed = ", closed form" if getattr(result, "l", None) is not None else ""
            return f"averaging: order {getattr(result, 'order', 1)}{closed}"
        # the single pendulum's closed form (its result carries l; a sweep's tile has none)
        if getattr(result, "l", None) is not None or (result is None and pend is not None):
            damping = getattr(result, "damping", None) if result is not None else pend.damping
            return ("floquet: Mathieu monodromy traces (damped)" if damping else
                    "floquet: Mathieu characteristic values")
        return "floquet: certified monodromy edges (kapitza.window)"
    if name == "measure":
        return "simulation: strobe samples of the full equations measured"
    if name == "simulate":
        return f"simulation: {getattr(result, 'method', 'one trajectory')}"
    if name == "verify":
        return "comparison: averaging, floquet and simulation"
    return frontier_method(name, result)


# -- the analyses over a sweep's tile -----------------------------------------------------------

def tile_inputs(scene, columns, size):
    """A tile's inputs from its axis columns (name → values): the parameters (arrays where
    swept), and the initial coordinates and velocities, (size, n) each."""
    params = dict(scene.spec.params)
    q0 = np.tile(scene.q0, (size, 1))
    qdot0 = np.tile(scene.qdot0, (size, 1))
    coords = list(scene.system.coordinates)
    for name, values in columns.items():
        target = scene.spec.sweep["targets"][name]
        if target.startswith("initial."):
            state = target[len("initial."):]
            if state in coords:
                q0[:, coords.index(state)] = values
            else:
                qdot0[:, coords.index(state[:-len("_dot")])] = values
        else:
            params[target] = values
    return params, q0, qdot0


def _point_params(params, i):
    return {k: float(v[i]) if np.ndim(v) else v for k, v in params.items()}


def _drop_params(frame, scene):
    return frame.drop(columns=[c for c in scene.system.parameters if c in frame])


def _grid_simulate(scene, s, params, q0, qdot0):
    t1 = _span(scene, s, params.get("omega"))
    system = scene.system
    grid = system.simulate_grid(q0, qdot0, (0.0, t1), params, method=s.get("method"),
                                rtol=s.get("rtol", 1e-9), energy=bool(
                                    system.kernels.energy_conserved), progress=False,
                                **_options(s, ("atol", "max_steps", "h")))
    return _drop_params(grid.to_dataframe(), scene)


def _grid_measure(scene, s, params, q0, qdot0):
    about = s.get("about")
    if about in (None, "auto") and scene.capabilities["floquet"] != "equilibrium":
        about = np.array([_averaged_state(scene, _point_params(params, i), q0[i])
                          for i in range(len(q0))])
    else:
        about = checked_state(scene, _about(scene, about, q0), about, _point_params(params, 0))
    m = measure_grid(scene.system, params, about, q0, qdot0, periods=s.get("periods", 1000),
                     band=_band(scene, s, about), rtol=s.get("rtol"), progress=False,
                     **_options(s, _INTEGRATION_KEYS))
    return _drop_params(m.to_dataframe(), scene)


def _about_equilibrium(scene, s) -> bool:
    """Is the scene's Floquet analysis about an equilibrium (the state ``about`` names
    persists under the drive at the scene's parameters), not about a periodic orbit?"""
    if scene.capabilities["floquet"] != "equilibrium":
        return False
    try:
        return persists(scene, _about(scene, s.get("about")))
    except ValueError:          # the state is refused where the analysis runs, and says why
        return True


def _grid_floquet(scene, s, params, q0, qdot0):
    import pandas as pd
    size = len(q0)
    if _about_equilibrium(scene, s):
        q = _state(scene, s)
        with naming_state(scene, q, s.get("about")):
            g = floquet_grid(scene.system, params, q, tol=s.get("tol", 1e-10), progress=False,
                             **_options(s, ("guard_tol", "taylor_order")))
        frame = _drop_params(g.to_dataframe(), scene)
        slow = np.asarray(g.omega_slow).reshape(size, -1)
        for k in range(slow.shape[1]):
            frame[f"omega_slow_{k}"] = slow[:, k]
        frame["flags"] = ["; ".join(f) for f in g.flags]
        return frame
    about = s.get("about", "auto")
    rows = []
    n = scene.system.n_dof
    for i in range(size):
        if interrupt_requested():
            raise KeyboardInterrupt
        p = _point_params(params, i)
        row = {}
        try:
            guess = _averaged_state(scene, p, q0[i]) if about == "auto" and \
                scene.capabilities["floquet"] != "equilibrium" else _about(scene, about, q0[i])
            o = periodic_orbit(scene.system, p, guess, tol=s.get("tol", 1e-10),
                               **_options(s, _ORBIT_KEYS))
            slow = np.atleast_1d(o.omega_slow)
            row.update(stable=o.stable, max_abs_multiplier=float(np.max(np.abs(o.multipliers))),
                       residual=o.residual, iterations=o.iterations, error="")
            row.update({f"q_mean_{c}": o.q_mean[j] for j, c in enumerate(scene.system.coordinates)})
            row.update({f"amplitude_{c}": o.amplitude[j]
                        for j, c in enumerate(scene.system.coordinates)})
            row.update({f"omega_slow_{k}": slow[k] for k in range(n)})
        except ValueError as e:
            row.update(stable=False, max_abs_multiplier=math.nan, residual=math.nan,
                       iterations=-1, error=str(e))
            row.update({f"q_mean_{c}": math.nan for c in scene.system.coordinates})
            row.update({f"amplitude_{c}": math.nan for c in scene.system.coordinates})
            row.update({f"omega_slow_{k}": math.nan for k in range(n)})
        rows.append(row)
    return pd.DataFrame(rows)


def _grid_averaging(scene, s, params, q0, qdot0):
    import pandas as pd
    size = len(q0)
    pend = scene.pendulum
    if pend is not None and all(np.ndim(params[k]) == 0 for k in ("l", "g")) \
            and np.ndim(params.get("gamma", 0.0)) == 0 and "guesses" not in s:
        A, w = np.broadcast_arrays(np.asarray(params["A"], float),
                                   np.asarray(params["omega"], float) + np.zeros(size))
        res = pend.averaged(A, w, order=s.get("order", 1), warn=False)
        frame = res.to_dataframe().drop(columns=["A", "omega"])
        frame.insert(0, "point", np.tile(np.arange(size), len(res.equilibria)))
        return frame.sort_values("point", kind="stable").reset_index(drop=True)
    if s.get("order", 1) != 1:
        raise ValueError("order 2 is the plain pendulum's closed form (with l, g and gamma not "
                         "swept); general averaging is first order.")
    avg = average(scene.system)
    coords = scene.system.coordinates
    guesses = _guesses(scene, s)
    rows = []
    for i in range(size):
        if interrupt_requested():
            raise KeyboardInterrupt
        for k, e in enumerate(avg.predict(_point_params(params, i), guesses,
                                          warn=False).equilibria):
            for j in range(len(coords)):
                row = {"point": i, "equilibrium": k}
                row.update({f"about_{c}": float(e.about[a]) for a, c in enumerate(coords)})
                row.update(mode=j, omega_squared=float(e.omega_squared[j]),
                           frequency=float(e.frequencies[j]),
                           damped_frequency=float(e.damped_frequencies[j]), stable=e.stable,
                           decay_rate=e.decay_rate, valid=e.valid)
                rows.append(row)
    return pd.DataFrame(rows) if rows else pd.DataFrame({"point": np.zeros(0, np.int64)})


GRID = {"simulate": _grid_simulate, "measure": _grid_measure, "floquet": _grid_floquet,
        "averaging": _grid_averaging}

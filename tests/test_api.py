"""The public API follows one rule (issue 20.1; the rule: docs/api-conventions.md).

The API is introspected, not listed by hand: every callable ``kapitza.__all__`` names and
the public methods of the classes users call. A new function that breaks the rule fails
here with the rule it breaks. The old spellings' equal numbers are tested beside each
room's tests (tests/test_*_deprecations.py); here: that every deprecated name is marked,
warns, and names its replacement.
"""
import inspect
import warnings

import pytest

import kapitza

#: Argument names that the rule retired (docs/api-conventions.md §3), in any public signature.
RETIRED = {"A_limit": "A_range=(low, high)", "upper": "A_range=(low, high)",
           "guess": "about"}
#: Grid axes: keyword-only wherever a function on a system takes them.
AXES = ("A", "omega")
#: The third argument of a function on any system: the state it is about, or, for the
#: analysis of one trajectory, its initial coordinates.
THIRD = ("about", "q0")
#: The classes whose public methods users call directly.
CLASSES = ("KapitzaPendulum", "AveragedSystem", "Scene")


def _public_functions():
    for name in kapitza.__all__:
        if name in kapitza.DEPRECATED:
            continue
        obj = getattr(kapitza, name)
        if inspect.isfunction(obj):
            yield name, obj


def _public_methods():
    for cls_name in CLASSES:
        cls = getattr(kapitza, cls_name)
        for name, member in vars(cls).items():
            if name.startswith("_") or not inspect.isfunction(member):
                continue
            if hasattr(member, "__deprecated__"):
                continue
            yield f"{cls_name}.{name}", member


def _parameters(function):
    return list(inspect.signature(function).parameters.values())


def test_the_api_is_found():
    functions = dict(_public_functions())
    methods = dict(_public_methods())
    assert {"stability_map", "window", "boundaries", "verify", "measure",
            "periodic_orbit", "average"} <= set(functions)
    assert {"KapitzaPendulum.window", "KapitzaPendulum.simulate",
            "AveragedSystem.window"} <= set(methods)


@pytest.mark.parametrize("name,function", list(_public_functions()))
def test_functions_on_a_system_take_system_params_about(name, function):
    """``f(system, params, about, *, axes, names, options)``."""
    params = _parameters(function)
    if not params or params[0].name != "system":
        return
    names = [p.name for p in params]
    if len(params) < 2 or names[1] != "params":
        # average(system, *, frequency=...) takes the statement alone
        assert all(p.kind is p.KEYWORD_ONLY for p in params[1:]), (
            f"{name}{inspect.signature(function)}: after system comes params")
        return
    if len(params) > 2 and params[2].kind is not params[2].KEYWORD_ONLY:
        assert names[2] in THIRD, (
            f"{name}{inspect.signature(function)}: the third argument is the state the "
            f"analysis is about ({' or '.join(THIRD)}), got {names[2]!r}")
    for p in params:
        if p.name in AXES:
            assert p.kind is p.KEYWORD_ONLY, (
                f"{name}{inspect.signature(function)}: grid axis {p.name!r} must be "
                "keyword-only (A=..., omega=...)")


@pytest.mark.parametrize("name,function", list(_public_functions()) + list(_public_methods()))
def test_no_retired_argument_names(name, function):
    for p in _parameters(function):
        assert p.name not in RETIRED, (
            f"{name}: argument {p.name!r} is retired; the rule spells it {RETIRED[p.name]}")
        if p.name in ("omega", "amplitude", "frequency") and isinstance(p.default, str):
            assert p.name in ("amplitude", "frequency"), (
                f"{name}: the drive's parameter name is given by frequency=..., not "
                f"{p.name}={p.default!r}")


@pytest.mark.parametrize("name,function", list(_public_methods()))
def test_pendulum_methods_take_the_drive_first(name, function):
    """KapitzaPendulum: (A, omega) first, in that order; then the state."""
    if not name.startswith("KapitzaPendulum."):
        return
    names = [p.name for p in _parameters(function)][1:]       # without self
    if "A" in names and "omega" in names:
        assert names[:2] == ["A", "omega"], f"{name}: the drive (A, omega) comes first"
    elif "omega" in names:
        assert names[0] == "omega", f"{name}: the drive frequency comes first"
    for state in ("theta0", "theta_dot0", "theta", "t_span"):
        if state in names and "omega" in names:
            assert names.index(state) > names.index("omega"), (
                f"{name}: the state ({state}) comes after the drive")


def test_one_family_name_for_windows():
    """Windows are ``window`` (exact) with ``method="averaging"`` or ``AveragedSystem``
    for averaging; the retired names are marked deprecated."""
    assert callable(kapitza.window) and callable(kapitza.KapitzaPendulum.window)
    assert callable(kapitza.AveragedSystem.window) and callable(kapitza.pendulum_window)
    window_names = [n for n in kapitza.__all__ if "window" in n.lower()]
    for n in window_names:
        if n not in ("window", "pendulum_window", "StabilityWindow"):
            assert n in kapitza.DEPRECATED, f"{n}: a window under another name"


def test_deprecated_names_are_marked_and_name_their_replacement():
    """``kapitza.DEPRECATED`` lists every deprecated top-level name with its replacement;
    each is in ``__all__``, and a deprecated function carries the mark and says so first
    in its docstring."""
    assert set(kapitza.DEPRECATED) == {"averaging_window", "pendulum_stability_window",
                                       "FloquetWindow"}
    assert set(kapitza.DEPRECATED) <= set(kapitza.__all__)
    for name, new in kapitza.DEPRECATED.items():
        assert new.startswith("kapitza."), name
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            obj = getattr(kapitza, name)
        if inspect.isfunction(obj):
            assert obj.__deprecated__ and "Deprecated since kapitza 0.2.0" in obj.__doc__


def test_deprecated_top_level_names_warn_and_give_equal_numbers():
    import numpy as np
    omega = np.array([30.0, 60.0])
    with pytest.warns(DeprecationWarning, match="pendulum_window"):
        old = kapitza.pendulum_stability_window(omega, l=1.0, g=9.81)
    new = kapitza.pendulum_window(omega, l=1.0, g=9.81)
    np.testing.assert_array_equal(old.A_min, new.A_min)
    np.testing.assert_array_equal(old.A_max, new.A_max)
    with pytest.warns(DeprecationWarning, match="method='averaging'"):
        old = kapitza.averaging_window(omega, l=1.0, g=9.81, order=2)
    new = kapitza.pendulum_window(omega, l=1.0, g=9.81, method="averaging", order=2)
    np.testing.assert_array_equal(old.A_min, new.A_min)
    with pytest.warns(DeprecationWarning, match="StabilityWindow"):
        cls = kapitza.FloquetWindow
    assert cls is kapitza.StabilityWindow


def test_the_package_face_lists_the_whole_api():
    """``kapitza/__init__.py`` imports every public name in the ``X as X`` form and
    ``__all__`` lists exactly those names (deprecated ones included, marked)."""
    import ast
    import pathlib
    tree = ast.parse(pathlib.Path(kapitza.__file__).read_text())
    imported = set()
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.module != "_version":
            for alias in node.names:
                assert alias.asname == alias.name, (
                    f"import {alias.name} in the 'X as X' form (explicit re-export)")
                imported.add(alias.name)
    assert set(kapitza.__all__) - {"FloquetWindow"} <= imported | {"__version__"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        for name in kapitza.__all__:
            assert hasattr(kapitza, name), name

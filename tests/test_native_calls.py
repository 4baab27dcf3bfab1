"""A numba function called by the address of its native entry
(:mod:`lagrange_core._native_calls`), against the same function called directly: the same
results (arrays written, a tuple returned, a literal argument cast), its error raised in
the caller, and a call or a declaration that does not match refused, naming it."""
import numpy as np
import pytest
from numba import njit, types
from numba.core.errors import TypingError

from lagrange_core._native_calls import native_address, native_caller


@njit
def _running_sums(a, k, out):
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i] * k
        out[i] = s
    if s < 0.0:
        raise ValueError("a negative running sum")
    return s, k + 1


_SIGNATURE = types.Tuple((types.float64, types.int64))(
    types.Array(types.float64, 1, "C"), types.int64, types.Array(types.float64, 1, "C"))
_call = native_caller("running_sums", _SIGNATURE)


@njit
def _by_address(address, a, out):
    s, k = _call(address, a, 3, out)         # (a literal 3: cast to the declared int64)
    return s + k


@njit
def _strided(address, a, out):
    return _call(address, a[::2], 3, out)


def test_a_call_by_address_equals_a_direct_call():
    a = np.linspace(-1.0, 2.0, 7)
    out, out_direct = np.zeros(7), np.zeros(7)
    value = _by_address(native_address(_running_sums, _SIGNATURE), a, out)
    s, k = _running_sums(a, 3, out_direct)
    assert value == s + k
    np.testing.assert_array_equal(out, out_direct)


def test_the_callees_error_is_raised_in_the_caller():
    with pytest.raises(ValueError, match="a negative running sum"):
        _by_address(native_address(_running_sums, _SIGNATURE), -np.ones(3), np.zeros(3))


def test_an_argument_of_another_layout_is_refused_naming_it():
    address = native_address(_running_sums, _SIGNATURE)
    with pytest.raises(TypingError, match=r"running_sums by address: argument 0 is .*"
                                          r"declared signature says"):
        _strided(address, np.ones(8), np.zeros(4))


def test_a_declaration_that_does_not_match_the_function_is_refused():
    wrong = types.float64(*_SIGNATURE.args)
    with pytest.raises(RuntimeError, match="_running_sums returns .* declared float64"):
        native_address(_running_sums, wrong)


def test_the_lanes_driver_refuses_to_run_without_its_callees_addresses():
    """RKN 12's lanes driver calls its callees by the addresses it is given: a zero (the
    table of its compiling first call, on an empty span) or a short table on points to
    run would be a call to nowhere — a crash — and is refused instead."""
    from lagrange_core import _batch_kernels as bk
    from lagrange_core import _lanes_callees, problems
    from lagrange_core.batch import _grid_arrays
    from lagrange_core.progress import KERNEL_STOP
    driven = problems.driven_pendulum()
    driven.simulate_grid([[3.0]], [[0.0]], (0.0, 0.05),      # the driver compiled, or loaded
                         dict(A=0.05, g=9.81, l=1.0, m=1.0, omega=377.0), method="rkn12",
                         progress=False)
    assert _lanes_callees.addresses().shape == (_lanes_callees.N_CALLEES,)
    assert np.all(_lanes_callees.addresses() != 0)
    g = _grid_arrays(driven, [[3.0]], [[0.0]], (0.0, 0.05),
                     dict(A=0.05, g=9.81, l=1.0, m=1.0, omega=377.0), None, None, None, None)
    assert g["N"] == 1
    for calls in (_lanes_callees.NO_CALLS, _lanes_callees.addresses()[:-1]):
        with pytest.raises(RuntimeError, match="needs its callees' addresses"):
            _lanes_block_once(bk, driven, g, calls, KERNEL_STOP)


def _lanes_block_once(bk, system, g, calls, stop):
    from lagrange_core.integrate import METHODS
    tab = METHODS["rkn12"].table
    ka = system.kernels.addresses("rhs")
    n = system.n_dof
    N = g["N"]
    bk._lanes_block(ka, np.ascontiguousarray(calls), bk.LANES_ADAPTIVE, 8,
                    np.arange(N, dtype=np.int64), np.zeros(1, dtype=np.int64), N, N, g["Y0"],
                    g["P"], g["TS"], g["H"], g["TSTR"], g["REF"], g["LO"], g["HI"], 0, 1e-6,
                    1e-6, 10**6, tab["c"], tab["A"], tab["b"], tab["bp"], tab["bh"], tab["bph"],
                    np.zeros((N, 2 * n)), np.zeros(N), np.zeros((N, 1, 2 * n)),
                    np.zeros((N, n)), np.zeros((N, n)), np.zeros(N),
                    np.zeros(N, dtype=np.int64), np.zeros(N), np.zeros((N, 3), dtype=np.int64),
                    np.zeros(N), np.zeros(N, dtype=np.int64), 10**6, stop,
                    np.arange(N, dtype=np.int64), np.zeros((N, 1)),
                    np.zeros((N, bk.SAVEI_WIDTH), dtype=np.int64), bk.DRAINED)


_ORDER_CHILD = r"""
import json
from lagrange_core import _batch_kernels as bk
from lagrange_core import problems
order = []
driver, addresses = bk._lanes_block, bk.lanes_callee_addresses

def spied_driver(*args):
    order.append(["driver", int(args[6] - args[5][0]), bool(driver.signatures)])
    return driver(*args)

def spied_addresses():
    order.append(["addresses", None, bool(driver.signatures)])
    return addresses()

bk._lanes_block, bk.lanes_callee_addresses = spied_driver, spied_addresses
problems.driven_pendulum().simulate_grid(
    [[3.0], [2.9]], [[0.0]], (0.0, 0.05), dict(A=0.05, g=9.81, l=1.0, m=1.0, omega=377.0),
    method="rkn12", progress=False)
print(json.dumps(order))
"""


def test_the_lanes_driver_compiles_before_its_callees_addresses_are_asked_for():
    """The lanes driver's first call in a process, on an empty span, compiles it (or loads
    it), while its callees compile in the second process (lagrange_core._lanes_ahead);
    only then are their addresses asked for, which waits for them.  Asked for first, the
    callees compiled in the driver's process before it, and the first grid on empty caches
    took 21.5 s instead of 13.4 s (found 2026-11-28: a change to the driver's span function
    had left its empty span without a call).  Checked by the calls' order in a fresh
    process (in this one the first call may have been made)."""
    import json
    import subprocess
    import sys
    out = subprocess.run([sys.executable, "-c", _ORDER_CHILD], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    order = json.loads(out.stdout.strip().splitlines()[-1])
    assert order[:2] == [["driver", 0, False], ["addresses", None, True]], order
    assert any(kind == "driver" and span > 0 for kind, span, _ in order[2:]), order

"""lagrange_core: state a mechanical system as a lecture does; derive, compile, integrate.

Public API
----------
System, Particle, RigidBody, rotation_matrix, coordinates, t
    State a system (:mod:`lagrange_core.systems`); rigid bodies, planar or 3-D
    (:mod:`lagrange_core.bodies`).
derive, Equations
    The Euler–Lagrange equations in the canonical form M q̈ = F + Φ_qᵀ λ
    (:mod:`lagrange_core.derive`).
compile_kernels, Kernels
    numba kernels, cached on disk (:mod:`lagrange_core.codegen`).
Linearization
    Linearisation about an equilibrium (:mod:`lagrange_core.linearize`).
Trajectory, METHODS, Event, turning_point, crossing, multiplier_zero, SimulationInterrupted
    Integration (``System.simulate``; :mod:`lagrange_core.integrate`).
GridTrajectories, GridInterrupted
    Many trajectories in one compiled parallel call, observables only
    (``System.simulate_grid``; :mod:`lagrange_core.batch`).
problems, fields
    The catalogue of the lecture's problems; 1-D fields (:class:`fields.Field1D`).
effects
    Rigs and the effects a set-up names (gravity, a pivot drive, damping, air drag,
    springs), built into a System with only those terms (:mod:`lagrange_core.effects`).
warmup
    Compile the integrators once per installation (:mod:`lagrange_core.warmup`).
work_precision, WorkPrecision
    What accuracy costs in time: error at the final time against wall time, per method
    and tolerance, with scipy and heyoka as peers (:mod:`lagrange_core.accuracy_cost`).
"""
from . import effects, fields, problems
from ._version import __version__ as __version__
from .accuracy_cost import WorkPrecision, work_precision
from .bodies import RigidBody, rotation_matrix
from .codegen import Kernels, compile_kernels
from .derive import Equations, derive
from .integrate import (
    METHODS,
    Event,
    SimulationInterrupted,
    Trajectory,
    crossing,
    multiplier_zero,
    turning_point,
)
from .linearize import Linearization
from .symbols import coordinates, t
from .systems import Particle, System
from .warmup import warmup

__all__ = ["System", "Particle", "RigidBody", "rotation_matrix", "coordinates", "t", "derive",
           "Equations", "compile_kernels", "Kernels", "Linearization", "problems", "fields",
           "effects",
           "Trajectory", "METHODS", "Event", "turning_point", "crossing", "multiplier_zero",
           "SimulationInterrupted", "GridTrajectories", "GridInterrupted", "warmup",
           "work_precision", "WorkPrecision"]


def __getattr__(name):
    # the batch kernels load on first use (80 ms of numba set-up a plain import need not pay)
    if name in ("GridTrajectories", "GridInterrupted"):
        from . import batch
        return getattr(batch, name)
    raise AttributeError(f"module 'lagrange_core' has no attribute {name!r}")

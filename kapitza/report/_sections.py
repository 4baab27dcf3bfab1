"""The report's sections, in page order: each name, its heading and the function that
computes it (``section(job) -> SectionResult``, raising ``Skip`` where it does not apply).
"""
from __future__ import annotations

from ._animation_section import animation_section
from ._checks import slow_section, verification_section, work_precision_section
from ._frontier_section import bifurcations_section
from ._potential import potential_section
from ._spots import spots_section
from ._stability import map_section

#: The report's sections, in order: name → heading.
SECTIONS = {
    "potential": "Effective potential",
    "map": "Stability map: exact boundaries and the averaging prediction",
    "spots": "Direct-simulation spot checks on the map",
    "slow": "Slow frequency: predicted against measured",
    "verification": "Verification summary",
    "bifurcations": "Bifurcations and chaos: branches, bifurcation diagram, Lyapunov exponents",
    "work_precision": "What accuracy costs in time",
    "animation": "Animation: stabilised and falling",
}

#: Section name → the function that computes it.
BUILDERS = {"potential": potential_section, "map": map_section, "spots": spots_section,
            "slow": slow_section, "verification": verification_section,
            "bifurcations": bifurcations_section, "work_precision": work_precision_section,
            "animation": animation_section}

#: Section name → the groups of :mod:`kapitza.warmup` whose kernels it runs: on an empty
#: cache ``kapitza report`` compiles them in background processes
#: (:func:`kapitza.warmup.start_background`), and a section waits for its groups' process
#: instead of compiling the same kernels beside it (the cold report 43.5 → 42.0 s, 2026-11-26).
COMPILED_IN = {"spots": ("grids (dop853)",), "slow": ("grids (dop853)",),
               "verification": ("grids (dop853)",),
               "work_precision": ("report integrators",), "animation": ("report integrators",)}

"""The catalogue of the lecture's problems, each a few lines on the engine.

Shared by tests, benchmarks and studies (one factory per problem).  Angles are
measured from the downward vertical; y points up; gravity is −g ŷ.
"""
from __future__ import annotations

import sympy as sp

from .systems import Particle, RigidBody, System, coordinates, t

__all__ = ["pendulum", "n_link_pendulum", "double_pendulum", "driven_pendulum", "central_force",
           "spherical_pendulum", "guitar_string", "bead_string", "block_on_wedge",
           "swinging_atwood", "swinging_atwood_stop", "physical_pendulum", "rolling_disc",
           "atwood_machine"]


def pendulum() -> System:
    """Simple pendulum: bob of mass ``m`` on a massless rod of length ``l``.

    Coordinate ``theta`` (rad, from the downward vertical); parameters ``g``,
    ``l``, ``m``.  θ̈ = −(g/l) sin θ; small oscillations have ω² = g/l.
    """
    (theta,), _ = coordinates("theta")
    m, l, g = sp.symbols("m l g", positive=True)
    bob = Particle(m, (l * sp.sin(theta), -l * sp.cos(theta)), "bob")
    return System([theta], particles=[bob], potential=m * g * bob.position[1], name="pendulum")


def n_link_pendulum(n: int, *, pivot=(0, 0), name: str | None = None) -> System:
    """Planar chain of ``n`` point masses on massless rods, hanging from a pivot.

    Coordinates ``theta1`` … ``thetan`` (rad, each link from the downward
    vertical); parameters ``g``, ``l1`` … ``ln``, ``m1`` … ``mn``.

    Parameters
    ----------
    n : int
        Number of links (≥ 1).
    pivot : pair of sympy expressions
        Pivot position (m), possibly a function of t (a driven pivot).
    """
    if int(n) != n or n < 1:
        raise ValueError(f"n_link_pendulum needs a whole number of links n ≥ 1, got {n!r}.")
    n = int(n)
    thetas, _ = coordinates([f"theta{i}" for i in range(1, n + 1)])
    g = sp.Symbol("g", positive=True)
    x, y = sp.sympify(pivot[0]), sp.sympify(pivot[1])
    particles, V = [], 0
    for i, th in enumerate(thetas, start=1):
        m, l = sp.symbols(f"m{i} l{i}", positive=True)
        x, y = x + l * sp.sin(th), y - l * sp.cos(th)
        particles.append(Particle(m, (x, y), f"bob {i}"))
        V += m * g * y
    return System(thetas, particles=particles, potential=V, name=name or f"{n}-link pendulum")


def double_pendulum() -> System:
    """Planar double pendulum (``n_link_pendulum(2)``).

    Coordinates ``theta1``, ``theta2``; parameters ``g``, ``l1``, ``l2``, ``m1``,
    ``m2``.  For equal masses and lengths the normal modes are
    ω² = (g/l)(2 ∓ √2).
    """
    return n_link_pendulum(2, name="double pendulum")


def driven_pendulum(direction: str = "vertical", damping: bool = False) -> System:
    """Pendulum whose pivot oscillates as A cos ωt (the Kapitza pendulum).

    Coordinate ``theta`` (rad, from the downward vertical).  Parameters ``A``
    (m), ``g``, ``l``, ``m``, ``omega`` (rad/s) and, with ``damping=True``,
    ``gamma`` (1/s) from the dissipation function D = ½ m l² γ θ̇².
    With the vertical drive y_p = A cos ωt:

        θ̈ = −γ θ̇ − (g − A ω² cos ωt) sin θ / l.

    With the horizontal drive x_p = A cos ωt:
    θ̈ = −γ θ̇ − (g sin θ − A ω² cos ωt cos θ) / l.
    """
    (theta,), (theta_dot,) = coordinates("theta")
    m, l, g, A, omega, gamma = sp.symbols("m l g A omega gamma", positive=True)
    drive = A * sp.cos(omega * t)
    if direction == "vertical":
        pivot = (0, drive)
    elif direction == "horizontal":
        pivot = (drive, 0)
    else:
        raise ValueError(f"direction must be 'vertical' or 'horizontal', got {direction!r}.")
    bob = Particle(m, (pivot[0] + l * sp.sin(theta), pivot[1] - l * sp.cos(theta)), "bob")
    D = m * l**2 * gamma * theta_dot**2 / 2 if damping else 0
    return System([theta], particles=[bob], potential=m * g * bob.position[1], dissipation=D,
                  name=f"{direction}ly driven pendulum" + (" (damped)" if damping else ""))


def physical_pendulum(driven: bool = False) -> System:
    """A rigid body swinging in a plane about a pivot (a :class:`RigidBody`, no point masses).

    Coordinate ``theta`` (rad, the line pivot → centre of mass from the downward
    vertical; the body turns with it).  Parameters ``I_c`` (kg m², moment of inertia
    about the centre of mass), ``d`` (m, pivot to centre of mass), ``g``, ``m``; with
    ``driven=True`` the pivot moves as y_p = A cos ωt (``A``, ``omega``), as in
    ``shared/PHYSICS.md``.

    Closed forms, with I = I_c + m d² the moment of inertia about the pivot:

    * I θ̈ = −m d (g + ÿ_p) sin θ (ÿ_p = −A ω² cos ωt when driven);
    * small oscillations: ω² = m g d / I, the point pendulum of length l_eq = I/(m d)
      (a uniform rod of length L: I_c = m L²/12, d = L/2, l_eq = 2L/3).
    """
    (theta,), _ = coordinates("theta")
    m, I_c, d, g, A, omega = sp.symbols("m I_c d g A omega", positive=True)
    y_p = A * sp.cos(omega * t) if driven else 0
    body = RigidBody(m, I_c, (d * sp.sin(theta), y_p - d * sp.cos(theta)), theta, "body")
    return System([theta], bodies=[body], potential=m * g * body.position[1],
                  name="driven physical pendulum" if driven else "physical pendulum")


def rolling_disc(constrained: bool = False) -> System:
    """A round body rolling without slipping down an incline (a planar :class:`RigidBody`).

    Mass ``m``, radius ``R``, moment of inertia ``I`` about its centre (kg m²; a
    uniform disc has I = m R²/2, a ring m R², a ball 2 m R²/5), incline angle ``alpha``
    (rad), gravity ``g``.  Coordinate ``s`` (m): the distance the centre has travelled
    down the incline, which descends towards +x; rolling turns the body by φ = s/R.

    Parameters
    ----------
    constrained : bool
        True: a second coordinate ``phi`` (rad, the body's rotation) held to the
        rolling condition by the constraint ``Eq(s, R*phi)`` (the lecture's y = Rθ).
        The multiplier λ is then the friction force along +s (N): the generalized
        constraint force is Φ_qᵀλ = (λ, −R λ).

    Notes
    -----
    Closed forms:

    * s̈ = g sin α / (1 + I/(m R²))   (uniform disc: 2 g sin α / 3);
    * the friction force acts up the incline, λ = −I s̈ / R²;
    * energy m ṡ² (1 + I/(m R²))/2 − m g s sin α is conserved.
    """
    m, R, I, alpha, g = sp.symbols("m R I alpha g", positive=True)
    if constrained:
        (s, phi), _ = coordinates("s phi")
        angle, constraints = phi, [sp.Eq(s, R * phi)]
    else:
        (s,), _ = coordinates("s")
        angle, constraints = s / R, []
    q = [s, phi] if constrained else [s]
    disc = RigidBody(m, I, (s * sp.cos(alpha), -s * sp.sin(alpha)), -angle, "disc")
    return System(q, bodies=[disc], potential=m * g * disc.position[1], constraints=constraints,
                  name="rolling disc" + (" (rolling constraint)" if constrained else ""))


def atwood_machine() -> System:
    """The Atwood machine with a massive pulley: masses ``m1`` and ``m2`` hang from a
    string over a uniform disc of mass ``M`` (radius R, I = M R²/2) on a fixed axle; the
    string does not slip.

    Coordinate ``y`` (m): how far m1 has descended (m2 rises by y, the pulley turns
    by y/R).  Parameters ``M``, ``R`` (m; it cancels from the equations), ``g``, ``m1``,
    ``m2``.

    Notes
    -----
    Closed forms:

    * ÿ = (m1 − m2) g / (m1 + m2 + I/R²) = (m1 − m2) g / (m1 + m2 + M/2);
    * the string's tensions T1 = m1 (g − ÿ) and T2 = m2 (g + ÿ) differ by the torque
      that turns the pulley: (T1 − T2) R = I ÿ / R.
    """
    (y,), _ = coordinates("y")
    m1, m2, M, R, g = sp.symbols("m1 m2 M R g", positive=True)
    left = Particle(m1, (-R, -y), "m1")
    right = Particle(m2, (R, y), "m2")
    pulley = RigidBody(M, M * R**2 / 2, (0, 0), y / R, "pulley")
    return System([y], particles=[left, right], bodies=[pulley],
                  potential=g * (m1 * left.position[1] + m2 * right.position[1]),
                  name="Atwood machine (massive pulley)")


# -- central force (Kepler) ---------------------------------------------------------------------

def central_force(V=None) -> System:
    """A particle of mass ``m`` in a central potential V(r), in the plane.

    Coordinates ``r`` (m, distance from the centre) and ``phi`` (rad, polar
    angle).  Parameters: ``m`` (kg), plus those of V.  The default is the Kepler
    potential V = −k/r with ``k`` > 0 (J·m), e.g. k = G M m.

    Parameters
    ----------
    V : sympy expression or callable, optional
        The potential energy V(r) (J).  Either a callable ``V(r)`` that returns a
        sympy expression, or an expression in a symbol named ``r`` (any
        assumptions); its other free symbols become parameters.

    Notes
    -----
    Closed forms (any V(r)):

    * φ is cyclic: the angular momentum p_φ = L = m r² φ̇ is conserved
      (``system.equations.conserved_momenta['phi']``), and so is the energy
      E = ½ m ṙ² + L²/(2 m r²) + V(r).
    * The radial turning points are the roots of E = L²/(2 m r²) + V(r).

    For V = −k/r with E < 0 (Kepler's ellipse, semi-major axis a = −k/(2E),
    eccentricity e = √(1 + 2 E L²/(m k²))): the turning points are r = a(1 ∓ e),
    and the period is T = 2π √(m a³ / k) (Kepler's third law), exactly.

    Examples
    --------
    >>> import sympy as sp
    >>> kappa = sp.Symbol("kappa", positive=True)
    >>> oscillator = central_force(lambda r: kappa * r**2 / 2)   # isotropic oscillator
    """
    (r, phi), _ = coordinates("r phi")
    m = sp.Symbol("m", positive=True)
    if V is None:
        k = sp.Symbol("k", positive=True)
        potential = -k / r
    else:
        potential = V(r) if callable(V) and not isinstance(V, sp.Basic) else V
        if not isinstance(potential, (sp.Expr, int, float)):
            raise TypeError(f"central_force: V must be a sympy expression in r or a callable "
                            f"r -> sympy expression, got {potential!r}.")
        potential = sp.sympify(potential)
        potential = potential.xreplace({s: r for s in potential.free_symbols if s.name == "r"})
    bad = sorted(s.name for s in potential.free_symbols if s.name in ("phi", "phi_dot", "r_dot"))
    if bad:
        raise ValueError(f"central_force: V must depend on r only (a central force), but it "
                         f"contains {bad}.")
    particle = Particle(m, (r * sp.cos(phi), r * sp.sin(phi)), "particle")
    return System([r, phi], particles=[particle], potential=potential,
                  name="Kepler problem" if V is None else "central force")


# -- spherical pendulum -------------------------------------------------------------------------

def spherical_pendulum(form: str = "spherical") -> System:
    """Bob of mass ``m`` on a massless rod of length ``l`` free to swing in 3-D.

    Parameters ``g``, ``l``, ``m``; the pivot is at the origin, z points up.

    Parameters
    ----------
    form : {"spherical", "cartesian"}
        ``"spherical"``: coordinates ``theta`` (rad, from the downward vertical)
        and ``phi`` (rad, azimuth), bob at (l sin θ cos φ, l sin θ sin φ, −l cos θ).
        The chart is singular at the poles θ = 0, π (the mass matrix
        diag(m l², m l² sin² θ) loses rank), so motion *through* the bottom
        cannot be integrated in it.

        ``"cartesian"``: coordinates ``x``, ``y``, ``z`` (m) of the bob and the
        holonomic constraint x² + y² + z² − l² = 0.  Regular everywhere,
        including through the poles.  The multiplier λ gives the constraint
        force 2λ (x, y, z) on the bob, so the rod's tension is T = −2 λ l (N).

    Notes
    -----
    Closed forms (spherical form):

    * φ is cyclic: p_φ = m l² sin² θ φ̇ is conserved; so is the energy
      E = ½ m l² (θ̇² + sin² θ φ̇²) − m g l cos θ.
    * Steady conical motion at θ0 (0 < θ0 < π/2) needs φ̇² = g / (l cos θ0).
    * Small oscillations of θ about it (at fixed p_φ) have angular frequency
      ω² = φ̇² (1 + 3 cos² θ0).
    * With p_φ = 0 the motion is the plane pendulum: period
      T = 4 K(sin²(θ_max/2)) √(l/g), K the complete elliptic integral of the first
      kind with parameter m = sin²(θ_max/2).
    """
    m, l, g = sp.symbols("m l g", positive=True)
    if form == "spherical":
        (theta, phi), _ = coordinates("theta phi")
        bob = Particle(m, (l * sp.sin(theta) * sp.cos(phi), l * sp.sin(theta) * sp.sin(phi),
                           -l * sp.cos(theta)), "bob")
        return System([theta, phi], particles=[bob], potential=m * g * bob.position[2],
                      name="spherical pendulum")
    if form == "cartesian":
        (x, y, z), _ = coordinates("x y z")
        bob = Particle(m, (x, y, z), "bob")
        return System([x, y, z], particles=[bob], potential=m * g * z,
                      constraints=[x**2 + y**2 + z**2 - l**2],
                      name="spherical pendulum (Cartesian)")
    raise ValueError(f"spherical_pendulum: form must be 'spherical' or 'cartesian', got {form!r}.")


# -- block on a wedge ---------------------------------------------------------------------------

def block_on_wedge(normal_coordinate: bool = False) -> System:
    """A block of mass ``m`` sliding without friction on a wedge of mass ``M`` that
    slides without friction on a horizontal floor (Morin, *Introduction to
    Classical Mechanics*, the sliding wedge).

    Coordinates ``X`` (m): the wedge's horizontal position; ``s`` (m): the block's
    distance down the incline from the wedge's reference point.  Parameters
    ``m``, ``M`` (kg), ``alpha`` (rad, incline angle, 0 < α < π/2), ``g``.
    The incline descends towards +x: the block is at
    (X + s cos α, −s sin α) + n (sin α, cos α).

    Parameters
    ----------
    normal_coordinate : bool
        False: the block stays on the incline by construction (coordinates
        X, s).  True: a third coordinate ``n`` (m), the block's height above the
        incline along its outward normal (sin α, cos α), held at 0 by the
        constraint n = 0.  The multiplier λ is then the generalized force on n,
        which is the normal force N the wedge exerts on the block (N).

    Notes
    -----
    Closed forms:

    With D = M + m sin² α:

    * s̈ = (M + m) g sin α / D   (the block's acceleration relative to the wedge),
    * Ẍ = −m g sin α cos α / D  (the wedge recoils towards −x),
    * N = M m g cos α / D.

    X is cyclic: the horizontal momentum p_X = (M + m) Ẋ + m ṡ cos α is
    conserved.  Limits: α → 0 gives s̈ → 0, N → m g; α → π/2 gives s̈ → g,
    Ẍ → 0, N → 0.
    """
    names = "X s n" if normal_coordinate else "X s"
    q, _ = coordinates(names)
    X, s = q[0], q[1]
    n = q[2] if normal_coordinate else 0
    m, M, alpha, g = sp.symbols("m M alpha g", positive=True)
    wedge = Particle(M, (X, 0), "wedge")
    block = Particle(m, (X + s * sp.cos(alpha) + n * sp.sin(alpha),
                         -s * sp.sin(alpha) + n * sp.cos(alpha)), "block")
    return System(q, particles=[wedge, block], potential=m * g * block.position[1],
                  constraints=[n] if normal_coordinate else (),
                  name="block on wedge" + (" (normal coordinate)" if normal_coordinate else ""))


# -- swinging Atwood machine -------------------------------------------------------------------

def swinging_atwood() -> System:
    """The swinging Atwood machine with two equal masses ``m`` (Morin; Tufillaro,
    Abbott & Griffiths, Am. J. Phys. 52, 895 (1984) for general masses).

    A string runs over two small pulleys; one mass hangs straight down from the
    left pulley, the other swings from the right pulley as a pendulum of
    variable length.  Coordinates ``r`` (m): the length of string from the right
    pulley to the swinging mass; ``theta`` (rad): its angle from the downward
    vertical.  Parameters ``g``, ``m``.  The pulleys' size and separation do not
    enter; heights are measured so that the hanging mass is at y = r (the
    string's length only adds a constant to V).

        L = m ṙ² + ½ m r² θ̇² − m g r (1 − cos θ).

    Notes
    -----
    Closed forms:

    * The energy E = m ṙ² + ½ m r² θ̇² + m g r (1 − cos θ) is conserved.
    * 2 r̈ = r θ̇² − g (1 − cos θ): with θ = θ̇ = 0 initially r moves uniformly,
      r(t) = r0 + ṙ0 t, so with ṙ0 < 0 it reaches 0 at t = −r0/ṙ0.
    * r θ̈ + 2 ṙ θ̇ + g sin θ = 0.

    At r = 0 the swinging mass reaches its pulley and the model (a point mass on
    a taut string below the pulley) ends; its chart is singular there (mass
    matrix diag(2m, m r²)).  Integrate with :func:`swinging_atwood_stop` as a
    terminal event so the Trajectory stops there and says so.
    """
    (r, theta), _ = coordinates("r theta")
    m, g = sp.symbols("m g", positive=True)
    hanging = Particle(m, (0, r), "hanging mass")
    swinging = Particle(m, (r * sp.sin(theta), -r * sp.cos(theta)), "swinging mass")
    return System([r, theta], particles=[hanging, swinging],
                  potential=m * g * (hanging.position[1] + swinging.position[1]),
                  name="swinging Atwood machine")


def swinging_atwood_stop(r_min: float = 0.0):
    """The terminal event r = ``r_min`` (falling) for :func:`swinging_atwood`.

    With it, :meth:`System.simulate` stops where the swinging mass reaches its
    pulley (the model's end) instead of integrating into the singular chart;
    the Trajectory's ``status`` is ``"event"`` and ``events[-1].name`` says why.
    ``r_min`` > 0 stops short of the pulley (a pulley of that radius).
    """
    from .integrate import Event
    r_min = float(r_min)
    if not r_min >= 0:
        raise ValueError(f"swinging_atwood_stop: r_min must be ≥ 0 (m), got {r_min}.")
    return Event("coordinate", "r", r_min, -1, True,
                 f"r = {r_min:g}: the swinging mass reaches its pulley and leaves the model")


# -- the guitar string -------------------------------------------------------------------------

def guitar_string():
    """The transverse vibrations of a string: a field, not a system of particles.

    A string of linear density ``mu`` (kg/m) under tension ``F`` (N), transverse
    displacement y(x, t) (m).  Its Lagrangian density (J/m) is

        ℒ = ½ μ y_t² − F (√(1 + y_x²) − 1),

    kinetic energy per length minus the tension times the stretch per length.
    Returns a :class:`lagrange_core.fields.Field1D`; ``.field_equation`` is
    derived by the engine:

        μ y_tt − F y_xx / (1 + y_x²)^(3/2) = 0.

    "Do you recognize the result?"  In the small-slope limit |y_x| ≪ 1
    (``.small_amplitude()``, ℒ ≈ ½ μ y_t² − ½ F y_x², relative error O(y_x²)) it
    is the **wave equation** y_tt = c² y_xx with c = √(F/μ); a string of length
    l fixed at both ends sounds the harmonic series f_n = n c / (2 l).

    The string discretised into N beads is :func:`bead_string`, an ordinary
    System; its normal modes ω_n = 2 √(F/(μ h²)) sin(nπ / (2(N + 1))),
    h = l/(N + 1), are the dispersion relation of a lattice, and for n ≪ N they
    tend to the string's harmonic series, ω_n → n π c / l (relative error
    (nπ/(N+1))²/24).
    """
    from .fields import Field1D, field_symbols
    y, y_t, y_x = field_symbols("y")
    mu, F = sp.symbols("mu F", positive=True)
    return Field1D(mu * y_t**2 / 2 - F * (sp.sqrt(1 + y_x**2) - 1), "y", "guitar string")


def bead_string(n: int, *, small_slope: bool = False) -> System:
    """The guitar string as ``n`` beads: an ordinary System of transversally moving particles.

    A string of length ``l`` (m), linear density ``mu`` (kg/m) and tension ``F``
    (N), fixed at x = 0 and x = l, is replaced by ``n`` beads of mass μ h at
    x_i = i h, h = l/(n + 1), joined by straight segments under tension F.
    Coordinates ``y1`` … ``yn`` (m), the beads' transverse displacements;
    parameters ``F``, ``l``, ``mu``.  The potential is the tension times the
    stretch, F Σ (√(h² + (y_{i+1} − y_i)²) − h) (with y_0 = y_{n+1} = 0), or
    with ``small_slope=True`` its quadratic limit F Σ (y_{i+1} − y_i)² / (2h).  (The
    stretch is evaluated as Δ²/(√(h² + Δ²) + h), which keeps full relative precision of
    the energy at slopes |Δ|/h down to 1e-8, where the difference form loses ~9 digits.)

    Closed form: both forms have the normal modes (about y = 0)

        ω_k = 2 √(F/(μ h²)) sin(kπ / (2(n + 1))),   k = 1 … n,

    which for k ≪ n approach the string's ω_k = k π c / l, c = √(F/μ)
    (see :func:`guitar_string`).
    """
    if int(n) != n or n < 1:
        raise ValueError(f"bead_string needs a whole number of beads n ≥ 1, got {n!r}.")
    n = int(n)
    ys, _ = coordinates([f"y{i}" for i in range(1, n + 1)])
    mu, F, l = sp.symbols("mu F l", positive=True)
    h = l / (n + 1)
    beads = [Particle(mu * h, (i * h, y), f"bead {i}") for i, y in enumerate(ys, start=1)]
    ends = (0,) + ys + (0,)
    gaps = [ends[i + 1] - ends[i] for i in range(n + 1)]
    if small_slope:
        V = F * sp.Add(*[d**2 for d in gaps]) / (2 * h)
    else:
        # √(h² + Δ²) − h written as Δ²/(√(h² + Δ²) + h): the same function, without the
        # cancellation that loses ~9 digits of the energy when |Δ| ≪ h
        V = F * sp.Add(*[d**2 / (sp.sqrt(h**2 + d**2) + h) for d in gaps])
    return System(ys, particles=beads, potential=V,
                  name=f"string of {n} beads" + (" (small slope)" if small_slope else ""))

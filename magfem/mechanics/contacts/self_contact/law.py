r"""Self-contact law: two-pass penalty between surfaces of one body (arm–arm, petal–petal).

Which surfaces.
    The exterior facets of a set of cell groups (``[contact]
    self_contact_groups``, default: the robot's arms). Every group is a
    *slave* towards every other listed group (its *masters*): the contact
    is two-pass and symmetric, each surface being pushed out of the other.
    Points of two groups that lie closer than ``self_contact_exclusion``
    thicknesses apart in the reference configuration never touch (groups
    that meet at the hub).

Within a group.
    With ``self_contact_within`` (on by default) every group is also its own
    master (a membrane folding onto itself, an arm curling past 180°). Its
    own neighbourhood is excluded in the reference configuration: two
    points of one group touch only when they lie at least

    .. math::

        E = \max(e\,h,\; 2\,a)

    apart at rest (e h: ``self_contact_exclusion``; a: the group's largest
    contact cell or facet, corner to corner; for a shell, measured to every
    corner of the master cell). Without it a vertex pairs with the cells
    around it: their planes pass through it, a shell's mid-surfaces are 0
    apart instead of h (g = −h), and on a membrane bent to radius R the
    neighbours at distance d are only d²/(2R) apart. With it, a cell that
    may touch a slave vertex has every corner ≥ 2a, so the cell itself
    ≥ a, away at rest, while the slave's foot must lie in the cell (up to
    ``INSIDE``, ~0.1 a laterally). On a smoothly bent inextensible membrane
    turned by θ ≤ 90° between the two points the lateral offset is
    ≥ (2/π) × the arc ≥ 0.64 a; turned by 60°–120° the facing test
    rejects the pair; turned by more, the points lie across a fold of mean
    radius R and the gap to the tangent plane, R(1 − cos θ) − h ≥ 1.5 R − h,
    is negative only for a fold tighter than R = 2h/3 (a real fold: the
    faces meet at R = h/2). So no point pairs with its neighbours however
    the membrane bends smoothly; the 2a is the margin that makes this hold
    whatever the facing and foot tests decide near the cells' edges. A
    fold is felt once its two sides are more than E apart along the
    membrane: a fold tighter than a few cells is not resolved by the mesh
    anyway. A point pairs with its own group (or any other) only once its
    gap is below a (one cell: the search is refreshed every step, so a
    surface approaching faster than a cell per step may be caught a step
    late, by the band), so that an arm curled over its own base far above
    it is no pair at all. E is a Euclidean
    distance at rest: along the membrane for the flat robots (and never
    longer than the distance along it, so it excludes no less), but two
    parts of one group that face each other at rest closer than E never
    touch: make them two groups.

Gap and traction.
    For a slave point x (current position) with master point x̄ and the
    master's outward unit normal n̄ there, the normal gap is
    g = (x − x̄)·n̄ (m; negative when the point is inside the master). Both
    passes together store the penalty energy

    .. math::

        E = \tfrac12 \sum_\text{passes} \int k_c\, R(-g)\, dA,\qquad
        k_c = \kappa_s\,\mu/h,\qquad R(\delta) = \int_0^\delta r ,

    (reported as ``energy_self_contact``; J, J/m for strips) with r the C¹
    ramp of the ground contact (:func:`magfem.mechanics.contacts.penalty.penalty_ramp`),
    exactly zero for a positive gap, onset δ0 = ``self_contact_onset`` h,
    integrals over the slave's *reference* area. Its gradient is the
    contact force: each pass pushes its slave with ½ k_c r(−g) n̄ per area and
    its master with the opposite (action = reaction), so on two matched faces
    each body carries k_c r(δ) per area. A contact carrying a pressure p
    therefore penetrates by δ = r⁻¹(p/k_c)
    (:func:`magfem.mechanics.contacts.penalty.penalty_penetration`): p h/(κ_s μ) +
    δ0/2 on the linear branch, sqrt(2 δ0 p/k_c) on the onset. This is the
    interpenetration tolerance (Wriggers, *Computational Contact Mechanics*,
    2nd ed., Springer 2006, §4.1 and §9.2 for two-pass node-to-surface
    penalty contact). A point touching a surface that does not touch back
    (a corner on a face) gets half that stiffness.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from magfem.mechanics.spec import ContactSpec

__all__ = ["SelfContactLaw", "create_self_contact_law"]

TOUCH = 1e-6
"""A pair touches when its deepest penetration exceeds TOUCH × δ0 (round-off is not a touch)."""

CANDIDATES = 8
"""Nearest master vertices examined per slave vertex and master group."""

ADJACENT = 8
"""Most contact facets kept around one vertex (4 on a structured quadrilateral surface)."""

NEIGHBOURHOOD = 2.0
"""Within a group, points closer at rest than this many of its largest cells never touch."""

FACING = -0.5
"""A master facet counts only if its normal is within 60° of opposing the slave's normal."""

INSIDE = 0.1
"""A slave point touches a master facet only if its foot on the facet's plane lies inside the
facet, up to this fraction of the facet (barycentric coordinates >= -INSIDE): a point beyond
the master's edge does not touch it."""


@dataclass(frozen=True)
class SelfContactLaw:
    """Constants of the self-contact penalty, SI units.

    Attributes:
        stiffness: k_c = κ_s μ / h (Pa/m).
        onset: δ0 > 0, width of the C¹ onset of the ramp (m).
        exclusion: reference distance (m) below which two points never touch.
        band: a slave point deeper than this inside the master (m) is ignored.
        within: every group is also its own master (its neighbourhood excluded,
            see the module docstring).
    """

    stiffness: float
    onset: float
    exclusion: float
    band: float
    within: bool = False

    def __post_init__(self) -> None:
        # programming errors only: user input is validated by ContactSpec
        for name in ("stiffness", "onset", "band"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"SelfContactLaw.{name} must be finite and > 0, got {value!r}")
        if not (math.isfinite(self.exclusion) and self.exclusion >= 0):
            raise ValueError(f"SelfContactLaw.exclusion must be >= 0, got {self.exclusion!r}")


def create_self_contact_law(
    spec: ContactSpec, *, shear_modulus: float, thickness: float
) -> SelfContactLaw:
    """The law of a ``[contact]`` table: k_c = κ_s μ/h, δ0 = onset h, exclusion × h, band h/2.

    A point deeper than half a thickness inside a membrane is nearer its other
    face (e.g. through the thickness where two arms meet), hence the band.
    """
    h = thickness
    return SelfContactLaw(
        stiffness=spec.self_contact_penalty * shear_modulus / h,
        onset=spec.self_contact_onset * h,
        exclusion=spec.self_contact_exclusion * h,
        band=0.5 * h,
        within=spec.self_contact_within,
    )

"""Geometry of the self-contact search: facet normals, facing and point-in-facet tests.

Pure array functions of the current positions (m) used by
:class:`~magfem.mechanics.contacts.self_contact.search.SurfacePairing`.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from magfem.mechanics.contacts.self_contact.law import ADJACENT, FACING, INSIDE

__all__ = ["ball_pairs", "facet_normals", "facing", "inside", "nearest_facing", "reach"]


def facet_normals(
    x: npt.NDArray[np.float64],
    facet_vertices: npt.NDArray[np.int32],
    nodal: npt.NDArray[np.float64],
    adjacent: npt.NDArray[np.int32],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Unit normals and corners of the contact facets around each vertex.

    A facet's normal is the direction of least spread of its current
    vertices (SVD; exact for segments and flat facets, the best-fit plane
    of a warped quadrilateral), oriented along the sum of its vertices'
    area-weighted nodal normals.

    Args:
        x: (vertices, gdim) current vertex positions (m).
        facet_vertices: (facets, vertices per facet) vertex indices.
        nodal: (vertices, gdim) nodal normals (zero off the contact surfaces).
        adjacent: (vertices, ADJACENT) facets around each vertex (-1: none).

    Returns:
        normals (vertices, ADJACENT, gdim) and the facets' current corner
        positions (vertices, ADJACENT, vertices per facet, gdim) (m); zero
        rows pad vertices with fewer facets.
    """
    gdim = x.shape[1]
    out = np.zeros((len(x), ADJACENT, gdim))
    corners = np.zeros((len(x), ADJACENT, facet_vertices.shape[1], gdim))
    if facet_vertices.shape[0] == 0:
        return out, corners
    pts = x[facet_vertices]  # (facets, vertices, gdim)
    _, _, vt = np.linalg.svd(pts - pts.mean(axis=1, keepdims=True))
    normal = vt[:, -1, :]
    orient = nodal[facet_vertices].sum(axis=1)
    normal *= np.where(np.einsum("fa,fa->f", normal, orient) < 0, -1.0, 1.0)[:, None]
    has = adjacent >= 0
    out[has] = normal[adjacent[has]]
    corners[has] = pts[adjacent[has]]
    return out, corners


def facing(
    normal: npt.NDArray[np.float64],
    d: npt.NDArray[np.float64],
    around: npt.NDArray[np.float64],
    offset: float,
    two_sided: bool,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Facing, gap and master normal of slave points towards candidate master facets.

    Args:
        normal: (slaves, gdim) the slaves' unit normals.
        d: (slaves, k, gdim) slave minus candidate master vertex (m).
        around: (slaves, k, ADJACENT, gdim) unit normals of the facets around
            each candidate (zero rows: padding).
        offset: distance (m) at which the points touch (0: faces; h: mid-surfaces).
        two_sided: the facets have no outside (mid-surfaces): n̄ is turned towards
            the slave's side, and a slave normal of either sign faces it.

    Returns:
        n_s·n̄ (+inf for padding; < FACING for facing surfaces), the gap
        d·n̄ − offset to each facet's plane (m) and n̄ per facet, the same shapes.
    """
    dots = np.einsum("sa,skja->skj", normal, around)
    if two_sided:
        side = np.where(np.einsum("ska,skja->skj", d, around) < 0.0, -1.0, 1.0)
        around = side[..., None] * around
        dots = -np.abs(dots)
    dots[np.all(around == 0.0, axis=-1)] = np.inf
    g = np.einsum("ska,skja->skj", d, around) - offset
    return dots, g, around


def inside(
    point: npt.NDArray[np.float64], corners: npt.NDArray[np.float64], tolerance: float
) -> npt.NDArray[np.bool_]:
    """Whether points lie in the convex hull of facet corners, up to ``tolerance``.

    Args:
        point: (..., gdim) points on the facets' planes (m).
        corners: (..., vertices, gdim) facet corners (m): 2 (segment), 3
            (triangle) or 4 (quadrilateral, any vertex order: the union of the
            four corner triangles is its hull).
        tolerance: slack in barycentric coordinates.

    Padding facets (all corners equal) contain no point.
    """
    nv = corners.shape[-2]
    if nv == 2:
        a, b = corners[..., 0, :], corners[..., 1, :]
        e = b - a
        ee = np.einsum("...a,...a->...", e, e)
        t = np.einsum("...a,...a->...", point - a, e) / np.where(ee > 0, ee, np.inf)
        return (ee > 0) & (t >= -tolerance) & (t <= 1.0 + tolerance)
    inside = np.zeros(point.shape[:-1], dtype=bool)
    for tri in itertools.combinations(range(nv), 3):
        a, b, c = (corners[..., i, :] for i in tri)
        v0, v1, v2 = b - a, c - a, point - a
        d00 = np.einsum("...a,...a->...", v0, v0)
        d01 = np.einsum("...a,...a->...", v0, v1)
        d11 = np.einsum("...a,...a->...", v1, v1)
        d20 = np.einsum("...a,...a->...", v2, v0)
        d21 = np.einsum("...a,...a->...", v2, v1)
        det = d00 * d11 - d01 * d01
        safe = np.where(det > 1e-12 * (d00 * d11), det, np.inf)
        beta = (d11 * d20 - d01 * d21) / safe
        gamma = (d00 * d21 - d01 * d20) / safe
        inside |= (
            np.isfinite(safe)
            & (beta >= -tolerance)
            & (gamma >= -tolerance)
            & (1.0 - beta - gamma >= -tolerance)
        )
    return inside


def reach(
    gap: float | npt.NDArray[np.float64],
    vertices: npt.NDArray[np.float64],
    normals: npt.NDArray[np.float64],
    corners: npt.NDArray[np.float64],
) -> npt.NDArray[np.float64]:
    """Per master vertex v: the farthest (m) a slave point x that touches a facet around it
    can be from it, so that a slave farther than that from every candidate has no master.

    x lies s = g + offset along the facet's unit normal n from its foot, |s| < ``gap``, and
    the foot passes :func:`inside`: it, or for a quadrilateral its projection q on the
    plane of one of the four corner triangles T, lies in the simplex grown about its
    centroid by 1 + (its corners) INSIDE, whose farthest corner from v is P_T away. A
    segment or triangle holds v: |x − v|² = s² + |foot − v|² ≤ gap² + P². A
    quadrilateral is warped (corners up to w from its best-fit plane, v at w_v, T's plane
    at θ to it): |foot − q| ≤ (w + E_T sin θ)/cos θ (E_T: T's grown extent from its first
    corner) and |x − v|² ≤ gap² + (P_T + |foot − q|)² + 2 gap w_v. Returns the largest over
    the facets around v, with 1e-9 of relative slack for round-off.

    Args:
        gap: bound on |g + offset| (m), one for all or one per vertex.
        vertices: (vertices, gdim) current positions (m).
        normals: (vertices, ADJACENT, gdim) unit normals of the facets around each vertex
            (zero rows: padding).
        corners: (vertices, ADJACENT, corners, gdim) current corners of those facets (m).
    """
    nv = corners.shape[-2]
    rows, around = np.nonzero(np.any(normals != 0.0, axis=-1))  # the facets, not the padding
    n, corner = normals[rows, around], corners[rows, around]  # (pairs, gdim), (pairs, nv, gdim)
    v = vertices[rows][:, None, :]
    centre = corner.mean(axis=1, keepdims=True)
    worst = np.zeros(len(rows))
    for simplex in [(0, 1)] if nv == 2 else itertools.combinations(range(nv), 3):
        pts = corner[:, list(simplex), :]
        middle = pts.mean(axis=1, keepdims=True)
        grown = middle + (1.0 + len(simplex) * INSIDE) * (pts - middle)
        far = np.linalg.norm(grown - v, axis=-1).max(axis=-1)
        if nv == 4:
            n_t = np.cross(pts[:, 1] - pts[:, 0], pts[:, 2] - pts[:, 0])
            length = np.linalg.norm(n_t, axis=-1)
            cos = np.abs(np.einsum("pa,pa->p", n_t, n)) / np.maximum(length, 1e-300)
            sin = np.sqrt(np.maximum(1.0 - cos**2, 0.0))
            extent = np.linalg.norm(grown - pts[:, :1], axis=-1).max(axis=-1)
            tilt = np.abs(np.einsum("pca,pa->pc", corner - centre, n)).max(axis=-1)
            lift = tilt + extent * sin
            far = far + np.divide(lift, cos, out=np.full_like(lift, np.inf), where=cos > 1e-6)
        worst = np.maximum(worst, far)
    gap = np.broadcast_to(np.asarray(gap, dtype=np.float64), (len(vertices),))[rows]
    square = gap**2 + worst**2
    if nv == 4:  # v off the best-fit plane
        square += 2.0 * gap * np.abs(np.einsum("pa,pa->p", v[:, 0] - centre[:, 0], n))
    out = np.zeros(len(vertices))
    np.maximum.at(out, rows, square)
    return np.sqrt(out) * (1.0 + 1e-9)


def ball_pairs(
    tree: cKDTree, index: npt.NDArray[np.int64], points: npt.NDArray[np.float64], radius: float
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """The tree's points within ``radius`` of each of ``points``: per point their number,
    and all their indices (through ``index``) one point after the other, each point's in the
    tree's order. Points that repeat (slave nodes sharing a master vertex) are queried once.
    """
    distinct, which = np.unique(points, axis=0, return_inverse=True)
    which = which.ravel()
    patches = tree.query_ball_point(distinct, r=radius)
    count = np.fromiter(map(len, patches), dtype=np.int64, count=len(patches))
    flat = np.fromiter(itertools.chain.from_iterable(patches), np.int64, int(count.sum()))
    sizes = count[which]
    shift = np.repeat((np.cumsum(count) - count)[which] - (np.cumsum(sizes) - sizes), sizes)
    return sizes, index[flat[shift + np.arange(int(sizes.sum()))]]


def nearest_facing(
    slaves: npt.NDArray[np.int64],
    sizes: npt.NDArray[np.int64],
    candidates: npt.NDArray[np.int64],
    normal: npt.NDArray[Any],
    candidate_normal: npt.NDArray[Any],
    position: npt.NDArray[Any],
    candidate_position: npt.NDArray[Any],
    two_sided: bool,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Per slave node its nearest candidate (current positions) whose unit normal is within
    60° of opposing the slave's n̄ (either way for ``two_sided``); the first of equals.

    Args:
        slaves: (slaves,) slave node indices; ``sizes`` their numbers of candidates and
            ``candidates`` those, one slave after the other (:func:`ball_pairs`).
        normal, position: per node n̄ (not unit; zero: no master) and current position (m).
        candidate_normal, candidate_position: per candidate index its unit normal and
            current position (m).

    Returns:
        the slaves that have one, and their candidates.
    """
    s = np.repeat(slaves, sizes)
    dots = np.einsum("pa,pa->p", candidate_normal[candidates], normal[s])
    bound = -FACING * np.maximum(np.linalg.norm(normal[slaves], axis=1), 1e-300)
    ok = (np.abs(dots) if two_sided else dots) > np.repeat(bound, sizes)
    c, s = candidates[ok], s[ok]
    if len(s) == 0:
        return s, c
    distance = np.linalg.norm(candidate_position[c] - position[s], axis=1)
    start = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])  # each slave's run
    nearest = np.repeat(np.minimum.reduceat(distance, start), np.diff(np.r_[start, len(s)]))
    hit = np.flatnonzero(distance == nearest)
    first = hit[np.r_[True, s[hit][1:] != s[hit][:-1]]]
    return s[first], c[first]

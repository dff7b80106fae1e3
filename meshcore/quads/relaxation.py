r"""The corner relaxation of planar quad meshes: :func:`relax_quads` (§8.4.3, §8.5.3).

Untangling and smoothing by the summed corner energy (Escobar et al.'s regularized
condition number, or the regularized ``1 / sin`` of the corner angles) over the free
nodes and the boundary nodes sliding on their segments: L-BFGS-B, then Newton's
method to the minimum the run leads to, so that the result is the minimum and not the
point where the iterations ran out (which depends on rounding: the frame invariance
of the project's rules).

References
----------
Methods text §8.4.3 (smoothing by optimization), §8.5.3 (the fill's quads).
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.sparse.linalg import splu

from meshcore.partition.smoothing import boundary_points

__all__ = ["relax_quads"]

#: The corner-angle relaxation (``relax_quads`` with ``angle_power``) adds the
#: condition number times this: the ``1 / sin`` of an angle does not change
#: with the lengths of its edges, so alone it let an interior node slide
#: onto a boundary node (a collapsed edge, a quad of quality 0: the whole
#: relaxation was then refused, on the annulus at size 0.05 and the disk at
#: 0.05). 0.03 kept every relaxation valid and lost least of the mean gain
#: (annulus 0.05: 0.867 -> 0.895 at 0.03, 0.893 at 0.1, 0.889 at 0.3).
RELAX_CONDITION = 0.03
#: Newton steps after L-BFGS-B at most; they stop when no variable moves by more
#: than ``NEWTON_STILL`` (the normalized frame's lengths: the median edge is 1).
NEWTON_STEPS = 50
NEWTON_STILL = 1e-12
#: No Newton steps where the energy is over this a corner: about 1 on a fill worth
#: keeping (issue 20's stars at size 0.1), 8.5e2 to 2e8 on the degenerate fills
#: quad_medial tries on star 22 at size 0.5 (its slit test), where the steps ran 50 times
#: unconverged, 0.2-0.4 s of CPU each.
NEWTON_ENERGY = 1e2


@njit(cache=True, inline="always")
def _corner(ax, ay, bx, by, delta, angle, power, w):
    """One corner's energy (:func:`_relax_energy`) with edges ``a``, ``b`` from its node,
    and its gradient in ``a`` and ``b``: ``(e, gax, gay, gbx, gby)``."""
    sigma = ax * by - ay * bx
    root = np.sqrt(sigma * sigma + 4.0 * delta * delta)
    h = 0.5 * (sigma + root)
    dh = 0.5 * (1.0 + sigma / root)
    ec = ca = cb = dsig = 0.0
    if angle:
        la = np.sqrt(ax * ax + ay * ay)
        lb = np.sqrt(bx * bx + by * by)
        base = la * lb / h
        ec = base**power
        f = power * base ** (power - 1.0)
        ca, cb = f * lb / (h * la), f * la / (h * lb)
        dsig = -f * base / h * dh
    S = (ax * ax + ay * ay) + (bx * bx + by * by)
    e = ec + w * S / (2.0 * h)
    ca = ca + w / h
    cb = cb + w / h
    dsig = dsig - w * S / (2.0 * h * h) * dh
    return e, ca * ax + dsig * by, ca * ay - dsig * bx, cb * bx - dsig * ay, cb * by + dsig * ax


@njit(cache=True, error_model="numpy")
def _relax_corners(P, C, turns, delta, angle, power, w, g):
    """The summed corner energy of :func:`_relax_energy`, its gradient added into ``g``
    (zeroed first): one pass over the corners (a collapsed edge gives inf / nan, as
    numpy's errors ignored)."""
    g[:] = 0.0
    e = 0.0
    for c in range(C.shape[0]):
        for k in range(4):
            i, j, m = C[c, k], C[c, (k + 1) % 4], C[c, (k + 3) % 4]
            ax, ay = P[j, 0] - P[i, 0], P[j, 1] - P[i, 1]
            bx, by = P[m, 0] - P[i, 0], P[m, 1] - P[i, 1]
            ec, gax, gay, gbx, gby = _corner(ax, ay, bx, by, delta, angle and turns[c, k], power, w)
            e += ec
            g[j, 0] += gax
            g[j, 1] += gay
            g[m, 0] += gbx
            g[m, 1] += gby
            g[i, 0] -= gax + gbx
            g[i, 1] -= gay + gby
    return e


@njit(cache=True)
def _placed(x, P, free, node, A, D, L):
    """``P`` with the ``free`` nodes at ``x``'s leading pairs and the sliding ``node`` at
    ``A + x / L * D`` (the variables of :func:`relax_quads`)."""
    Q = P.copy()
    nf = free.shape[0]
    for k in range(nf):
        Q[free[k], 0] = x[2 * k]
        Q[free[k], 1] = x[2 * k + 1]
    for k in range(node.shape[0]):
        t = x[2 * nf + k] / L[k]
        Q[node[k], 0] = A[k, 0] + t * D[k, 0]
        Q[node[k], 1] = A[k, 1] + t * D[k, 1]
    return Q


@njit(cache=True, error_model="numpy")
def _relax_energy(x, P, free, node, A, D, L, C, turns, delta, angle, power, w):
    """Summed corner energy at the variables ``x`` of :func:`relax_quads` and its
    gradient in them: the nodes placed (:func:`_placed`), then :func:`_relax_corners`
    (weight ``w``): the regularized condition number ``(|a|^2 + |b|^2) / (2 h)``, or
    with ``angle`` ``(|a| |b| / h) ** power`` (the regularized ``1 / sin`` of the corner
    angle: angles only, the power weighting the worst corners) plus ``w`` times the
    condition number (a barrier against collapsing an edge, which leaves the angles'
    term unchanged). ``(inf, zeros)`` when a value is not finite (a trial step
    collapsing an edge). Compiled whole, called once per L-BFGS-B evaluation: the
    vectorized form cost 80 % of ``combine``'s CPU on curved domains (disk at size
    0.025: 0.51 of 0.83 s)."""
    Q = _placed(x, P, free, node, A, D, L)
    g = np.zeros_like(Q)
    e = _relax_corners(Q, C, turns, delta, angle, power, w, g)
    out = np.zeros(x.shape[0])
    if not np.isfinite(e) or not np.isfinite(g).all():
        return np.inf, out
    nf = free.shape[0]
    for k in range(nf):
        out[2 * k] = g[free[k], 0]
        out[2 * k + 1] = g[free[k], 1]
    for k in range(node.shape[0]):
        out[2 * nf + k] = (g[node[k], 0] * D[k, 0] + g[node[k], 1] * D[k, 1]) / L[k]
    return e, out


@njit(cache=True, inline="always")
def _definite(H):
    """Whether the symmetric 4 x 4 ``H`` is positive definite (its Cholesky factor)."""
    L = np.zeros((4, 4))
    for j in range(4):
        d = H[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        L[j, j] = math.sqrt(d)
        for i in range(j + 1, 4):
            t = H[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / L[j, j]
    return True


@njit(cache=True)
def _clamped(A, V):
    """The symmetric 4 x 4 ``A`` with its negative eigenvalues set to 0, in place
    (cyclic Jacobi rotations, ``V`` the work space for the eigenvectors): one corner's
    Hessian, where LAPACK's call and its arrays cost three times the rest."""
    V[:] = 0.0
    for i in range(4):
        V[i, i] = 1.0
    for _ in range(30):
        off = 0.0
        for p in range(4):
            for q in range(p + 1, 4):
                off += A[p, q] * A[p, q]
        scale = 0.0
        for p in range(4):
            scale += A[p, p] * A[p, p]
        if not off > 1e-30 * scale:
            break
        for p in range(3):
            for q in range(p + 1, 4):
                if A[p, q] == 0.0:
                    continue
                theta = (A[q, q] - A[p, p]) / (2.0 * A[p, q])
                t = math.copysign(1.0, theta) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                sn = t * c
                for k in range(4):  # A <- A J (columns p, q)
                    akp, akq = A[k, p], A[k, q]
                    A[k, p], A[k, q] = c * akp - sn * akq, sn * akp + c * akq
                for k in range(4):  # A <- J^T A (rows p, q)
                    apk, aqk = A[p, k], A[q, k]
                    A[p, k], A[q, k] = c * apk - sn * aqk, sn * apk + c * aqk
                for k in range(4):
                    vkp, vkq = V[k, p], V[k, q]
                    V[k, p], V[k, q] = c * vkp - sn * vkq, sn * vkp + c * vkq
    lam0, lam1, lam2, lam3 = A[0, 0], A[1, 1], A[2, 2], A[3, 3]
    for r in range(4):
        for q in range(4):
            A[r, q] = (
                V[r, 0] * max(lam0, 0.0) * V[q, 0]
                + V[r, 1] * max(lam1, 0.0) * V[q, 1]
                + V[r, 2] * max(lam2, 0.0) * V[q, 2]
                + V[r, 3] * max(lam3, 0.0) * V[q, 3]
            )


@njit(cache=True, error_model="numpy")
def _relax_hessian(x, P, free, node, A, D, L, C, turns, delta, angle, power, w, var):
    """The Hessian of :func:`_relax_energy` in its variables as triplets ``(rows,
    cols, values)`` (duplicates summed): each corner's 4 x 4 Hessian in its edges
    ``a``, ``b`` by central differences of :func:`_corner`'s gradient (steps 1e-6 of
    the corner's edges), symmetrized, carried to its nodes and their variables
    (``var[v]``: node ``v``'s first variable, -1 for none; two for a free node, one
    along its segment for a sliding one)."""
    Q = _placed(x, P, free, node, A, D, L)
    nf = free.shape[0]
    cap = C.shape[0] * 4 * 36
    rows = np.empty(cap, np.int64)
    cols = np.empty(cap, np.int64)
    vals = np.empty(cap)
    safe = np.empty(cap)
    H = np.empty((4, 4))
    u, up, um = np.empty(4), np.empty(4), np.empty(4)
    B, Bp = np.empty((2, 2)), np.empty((2, 2))
    Hp, V = np.empty((4, 4)), np.empty((4, 4))
    J = np.zeros((3, 2, 2))  # each node's d(point) / d(variables)
    nv = np.zeros(3, np.int64)
    ids = np.zeros(3, np.int64)
    ca = (-1.0, 1.0, 0.0)
    cb = (-1.0, 0.0, 1.0)
    got = 0
    for c in range(C.shape[0]):
        for k in range(4):
            corner = (C[c, k], C[c, (k + 1) % 4], C[c, (k + 3) % 4])
            if var[corner[0]] < 0 and var[corner[1]] < 0 and var[corner[2]] < 0:
                continue
            i, j, m = corner
            u[0], u[1] = Q[j, 0] - Q[i, 0], Q[j, 1] - Q[i, 1]
            u[2], u[3] = Q[m, 0] - Q[i, 0], Q[m, 1] - Q[i, 1]
            # the step a 1e-5 change of the corner's (regularized) cross product
            sigma = u[0] * u[3] - u[1] * u[2]
            h = 0.5 * (sigma + math.sqrt(sigma * sigma + 4.0 * delta * delta))
            s = 1e-5 * h / (math.hypot(u[0], u[1]) + math.hypot(u[2], u[3]))
            turn = angle and turns[c, k]
            for q in range(4):
                up[:] = u
                um[:] = u
                up[q] += s
                um[q] -= s
                gp = _corner(up[0], up[1], up[2], up[3], delta, turn, power, w)
                gm = _corner(um[0], um[1], um[2], um[3], delta, turn, power, w)
                for r in range(4):
                    H[r, q] = (gp[r + 1] - gm[r + 1]) / (2.0 * s)
            for r in range(4):
                for q in range(r + 1, 4):
                    H[r, q] = H[q, r] = 0.5 * (H[r, q] + H[q, r])
            if not np.isfinite(H).all():
                return rows[:0], cols[:0], vals[:0], safe[:0]
            Hp[:] = H
            if not _definite(H):  # the corner's Hessian made positive semidefinite
                _clamped(Hp, V)
            for t in range(3):
                v = corner[t]
                ids[t] = var[v]
                J[t] = 0.0
                if var[v] < 0:
                    nv[t] = 0
                elif var[v] < 2 * nf:
                    nv[t] = 2
                    J[t, 0, 0] = J[t, 1, 1] = 1.0
                else:
                    nv[t] = 1
                    kk = var[v] - 2 * nf
                    J[t, 0, 0], J[t, 1, 0] = D[kk, 0] / L[kk], D[kk, 1] / L[kk]
            for s1 in range(3):
                for s2 in range(3):
                    if nv[s1] == 0 or nv[s2] == 0:
                        continue
                    B[:] = 0.0  # d2 e / d(point s1) d(point s2)
                    Bp[:] = 0.0
                    for X in range(2):
                        cx = ca[s1] if X == 0 else cb[s1]
                        for Y in range(2):
                            cy = ca[s2] if Y == 0 else cb[s2]
                            f = cx * cy
                            if f != 0.0:
                                for r in range(2):
                                    for q in range(2):
                                        B[r, q] += f * H[2 * X + r, 2 * Y + q]
                                        Bp[r, q] += f * Hp[2 * X + r, 2 * Y + q]
                    for p1 in range(nv[s1]):
                        for p2 in range(nv[s2]):
                            hv = hp = 0.0
                            for r in range(2):
                                for q in range(2):
                                    hv += J[s1, r, p1] * B[r, q] * J[s2, q, p2]
                                    hp += J[s1, r, p1] * Bp[r, q] * J[s2, q, p2]
                            rows[got], cols[got] = ids[s1] + p1, ids[s2] + p2
                            vals[got], safe[got] = hv, hp
                            got += 1
    return rows[:got], cols[:got], vals[:got], safe[:got]


def _pattern(rows, cols, n):
    """The compressed-column pattern of the ``n x n`` matrix of triplets ``(rows, cols)``
    (duplicates summed) with its whole diagonal: ``(indices, indptr, where, diagonal)``,
    ``where`` each triplet's entry, ``diagonal`` each diagonal one's."""
    every = np.arange(n)
    keys, where = np.unique(
        np.concatenate([cols, every]) * n + np.concatenate([rows, every]), return_inverse=True
    )
    indptr = np.searchsorted(keys, np.arange(n + 1) * n)
    return keys % n, indptr, where[:-n], where[-n:]


def _newton(fun, hessian, x, lower, upper, corners):
    """Newton's method from ``x`` to the minimum of ``fun`` (energy and gradient) between
    ``lower`` and ``upper``, ``hessian`` giving the Hessian's triplets exact and made
    positive semidefinite corner by corner (:func:`_relax_hessian`): each step the exact
    Hessian's step where it is taken whole, else the safe Hessian's halved until the
    energy falls (Armijo), or near the minimum, where the energy is all rounding, until
    the gradient does; a variable at its bound with the gradient pushing out held
    there. Until no variable moves by ``NEWTON_STILL``, ``NEWTON_STEPS`` at most; none
    where the energy is over ``NEWTON_ENERGY`` a corner (of the ``corners``): a
    degenerate fill (the caller judges it), where the steps crawled unconverged."""
    f, g = fun(x)
    if not f <= NEWTON_ENERGY * corners:
        return x
    n = len(x)
    pattern = None
    for _ in range(NEWTON_STEPS):
        held = ((x <= lower) & (g > 0)) | ((x >= upper) & (g < 0))
        r, c, exact, safe = hessian(x)
        if not len(exact) or held.all():
            break
        if pattern is None:  # the same each step
            indices, indptr, where, diagonal = pattern = _pattern(r, c, n)
        # a held variable's row and column the identity's (its step 0), a shift of 1e-12
        # of the largest diagonal entry against a singular Hessian
        keep = ~held[r] & ~held[c]
        tiny = 1e-12 * float(np.abs(exact[r == c]).max())
        rhs = np.where(held, 0.0, -g)
        on = ~held
        y = None
        for vals in (exact, safe):
            data = np.bincount(where, np.where(keep, vals, 0.0), len(indices))
            data[diagonal] = np.where(held, 1.0, data[diagonal] + tiny)
            d = splu(sp.csc_matrix((data, indices, indptr), shape=(n, n))).solve(rhs)
            if not (np.isfinite(d).all() and d @ g < 0):
                continue
            step = 1.0
            while step > 1e-9 and y is None:
                z = np.clip(x + step * d, lower, upper)
                fz, gz = fun(z)
                if np.isfinite(fz) and (
                    fz <= f + 1e-4 * (g @ (z - x))
                    or (fz <= f + 1e-13 * abs(f) and np.abs(gz[on]).max() < np.abs(g[on]).max())
                ):
                    y, fy, gy = z, fz, gz
                elif vals is exact:  # the exact Hessian's step whole or not at all
                    break
                step *= 0.5
            if y is not None:
                break
        if y is None:
            break
        moved = float(np.abs(y - x).max())
        x, f, g = y, fy, gy
        if moved <= NEWTON_STILL:
            break
    return x


def relax_quads(
    points: np.ndarray,
    quads: np.ndarray,
    fixed: np.ndarray,
    *,
    slide: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    active: np.ndarray | None = None,
    iterations: int = 200,
    angle_power: float | None = None,
    border: np.ndarray | None = None,
) -> np.ndarray:
    """Untangle and smooth a planar quad mesh (quads of §8.4.3, §8.5.3).

    Minimizes the summed condition number of the quad corners over the free
    nodes (L-BFGS-B), regularized so that folded quads have a finite energy
    (Escobar et al., "Simultaneous untangling and smoothing of tetrahedral
    meshes", 2003, here for quad corners): a folded mesh is untangled and a
    valid one is smoothed toward right-angled corners in one process. Nodes
    in ``slide`` move only along their segment, each between the midpoints to
    its neighbours there (so no boundary edge collapses and the boundary order
    is kept), so the boundary and the area of a polygonal domain are kept.
    A sliding node's variable is its position along its segment in the
    normalized frame's lengths, as the free nodes' coordinates are (its
    fraction of the segment made a segment of k edges k**2 times stiffer: the
    square with a hole at size 0.02 reached in 200 iterations the mean quality
    it reached in 3,000 before, 0.9621 against 0.9586).

    Each L-BFGS-B run is followed by Newton's method to the minimum it leads
    to (:func:`_newton`): L-BFGS-B stopped at ``iterations`` amplified
    rounding (1e-9 of the normalized frame grew about 1.3 times an iteration:
    a 1e6 translation moved the points of issue 20's stars by 1e-4 to 1e-2 of
    the extent), the minimum moves with the input by rounding only (6.8e-11 of
    the extent translated, 1e-13 scaled by 1e-6, on every relaxation
    quad_combine makes on issue 20's stars 0-9 at size 0.1). A corner whose
    angle no move can change (a fixed node between neighbours fixed or
    sliding on its own segments: a spike's tip) has no angle term: its
    constant ``(1 / sin) ** power`` (1.7e8 at a tip of 0.5 degrees) only
    pulled, through the regularization, its sliding neighbours away, and
    left Newton's method crawling along that valley. The problem is set in a
    local frame (coordinates relative to the mean of the active quads'
    nodes, in their median edge length), so translated or scaled inputs are
    the same problem to rounding.

    Parameters
    ----------
    points : (n, 2) float64
    quads : (q, 4) int
        Counter-clockwise.
    fixed : (n,) bool
        Nodes that do not move (besides the sliding ones, which are fixed too
        except along their segment).
    slide : (node, a, b), optional
        As :func:`meshcore.quads.optimization.sliding_nodes`.
    active : (q,) bool, optional
        Only these quads enter the energy, and only nodes all of whose quads
        are active move (a band around the bad quads of a large mesh).
    iterations : int
        L-BFGS-B iterations per round at most.
    angle_power : float, optional
        Minimize ``(1 / sin(corner angle)) ** angle_power`` (regularized the
        same way) instead: angles only, closer to (8.4) than the condition
        number, which also evens the edge lengths; plus
        :data:`RELAX_CONDITION` times the condition number.
    border : (n,) bool, optional
        The mesh's boundary nodes, when the caller has them
        (:func:`meshcore.partition.smoothing.boundary_points`): they move only in
        ``slide``.

    Returns
    -------
    (n, 2) float64
        The moved points. Whether they are valid is the caller's check
        (exact predicates): a tangle that cannot be undone with the fixed
        nodes stays tangled.

    L-BFGS-B runs on one BLAS thread (:func:`threadpoolctl.threadpool_limits`):
    its many small calls made a multithreaded OpenBLAS up to 12 times slower
    in CPU on busy cores, for library callers that did not set
    ``OPENBLAS_NUM_THREADS=1`` as the service's job processes do.
    """
    from scipy.optimize import Bounds, minimize
    from threadpoolctl import threadpool_limits

    P0 = np.asarray(points, np.float64)
    C = np.asarray(quads, np.int64)
    n = len(P0)
    if active is None:
        active = np.ones(len(C), bool)
    Ca = C[active]
    if not len(Ca):
        return P0.copy()
    movable = np.zeros(n, bool)
    movable[Ca.ravel()] = True
    inactive = C[~active]
    movable[inactive.ravel()] = False
    movable &= ~fixed
    # boundary nodes move only along their segment
    movable &= ~(boundary_points(P0, C) if border is None else border)
    node, sa, sb = slide if slide is not None else (np.zeros(0, np.int64),) * 3
    ok = np.zeros(n, bool)
    ok[Ca.ravel()] = True
    ok[inactive.ravel()] = False
    keep = ok[node] & ~fixed[node]
    node, sa, sb = np.asarray(node[keep], np.int64), sa[keep], sb[keep]
    free = np.flatnonzero(movable)
    if not free.size and not node.size:
        return P0.copy()
    # the corners whose angle a move changes: at a moving node, or with a moving neighbour
    # off the node's own segments (a spike's tip, its neighbours sliding on its segments,
    # keeps its angle, and its huge constant term's regularization pulled them away)
    moves = np.zeros(n, bool)
    moves[free] = moves[node] = True
    ends = np.full((n, 2), -1)
    ends[node, 0], ends[node, 1] = sa, sb
    turns = moves[Ca].copy()
    for v in (np.roll(Ca, -1, axis=1), np.roll(Ca, 1, axis=1)):
        turns |= moves[v] & (ends[v, 0] != Ca) & (ends[v, 1] != Ca)
    centre = P0[Ca.ravel()].mean(axis=0)
    edge = np.hypot(*(P0[np.roll(Ca, -1, axis=1)] - P0[Ca]).reshape(-1, 2).T)
    scale = float(np.median(edge)) or 1.0
    P = (P0 - centre) / scale
    A, D = P[sa], P[sb] - P[sa]
    t0 = ((P[node] - A) * D).sum(-1) / (D * D).sum(-1)
    L = np.hypot(D[:, 0], D[:, 1])  # a sliding node's variable: t times its segment's length
    nf = free.size
    var = np.full(n, -1, np.int64)
    var[free] = 2 * np.arange(nf)
    var[node] = 2 * nf + np.arange(node.size)

    angle = angle_power is not None
    power, w = float(angle_power or 1.0), RELAX_CONDITION if angle else 1.0

    def fun(x, delta):
        return _relax_energy(x, P, free, node, A, D, L, Ca, turns, delta, angle, power, w)

    # each sliding node stays between the midpoints to its neighbours on its segment
    # (to the segment's ends for the first and last): none reaches an end or passes
    # another, which would collapse a boundary edge; a node projecting off its segment (as
    # rounding at coordinates 1e12 makes) keeps its own position within its range
    order = np.lexsort((t0, sb, sa))
    ts = t0[order]
    first = np.ones(len(order), bool)
    first[1:] = (sa[order][1:] != sa[order][:-1]) | (sb[order][1:] != sb[order][:-1])
    last = np.roll(first, -1)
    lo, hi = np.empty(len(order)), np.empty(len(order))
    lo[order] = (ts + np.where(first, 0.0, np.roll(ts, 1))) / 2
    hi[order] = (ts + np.where(last, 1.0, np.roll(ts, -1))) / 2
    lo, hi = np.minimum(lo, t0), np.maximum(hi, t0)
    x = np.concatenate([P[free].ravel(), t0 * L])
    lo, hi = lo * L, hi * L
    box = (
        np.concatenate([np.full(2 * nf, -np.inf), lo]),
        np.concatenate([np.full(2 * nf, np.inf), hi]),
    )

    def hessian(x, delta):
        return _relax_hessian(x, P, free, node, A, D, L, Ca, turns, delta, angle, power, w, var)

    with threadpool_limits(limits=1, user_api="blas"):
        for r in range(6):
            Q = _placed(x, P, free, node, A, D, L)
            p = Q[Ca]
            a, b = np.roll(p, -1, axis=1) - p, np.roll(p, 1, axis=1) - p
            least = float((a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]).min())
            # untangling rounds (Escobar's delta) only while a corner is folded; delta
            # shrinks each round, so that a fold among corners far smaller than the
            # median is not lost in the regularization
            eps = 1e-2 * 0.1**r
            delta = math.sqrt(eps * (eps - least)) if least <= 0 else 1e-6
            res = minimize(
                fun,
                x,
                args=(delta,),
                jac=True,
                method="L-BFGS-B",
                bounds=Bounds(*box),
                options={"maxiter": iterations},
            )
            x = res.x
            if least > 0:  # the smoothing round (untangling rounds are not polished)
                x = _newton(
                    partial(fun, delta=delta), partial(hessian, delta=delta), x, *box, 4 * len(Ca)
                )
                break
    out = P0.copy()
    out[free] = x[: 2 * nf].reshape(-1, 2) * scale + centre
    out[node] = P0[sa] + (x[2 * nf :] / L)[:, None] * (P0[sb] - P0[sa])
    return out

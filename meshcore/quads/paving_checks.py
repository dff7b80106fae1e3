"""The checks of a proposed paving row (§8.5.1): exact front-front intersection tests.

A helper of :mod:`meshcore.quads.advancing_front` (its module docstring,
step 4): which quads of a row may be laid, every sign through the compiled
exact predicates of :mod:`meshcore.quads.paving_kernel`. Each check looks
only at the front edges near the row (:func:`~meshcore.quads.paving_kernel.front_near`):
the fronts of a large domain have thousands of nodes and a row tens of quads.
"""

from __future__ import annotations

import numpy as np

from meshcore.mesh.topology import unique_ints
from meshcore.quads import paving_kernel as pk
from meshcore.quads.paving_fronts import _MIN_Q, _chains

_CLEARANCE = 0.5  # a row's new nodes stay this far (times h) from other nodes...
_GAP = 2.0  # ... and this far from the nodes of other fronts, unless joined to one


def _front_table(fronts: list, which: int):
    """``(a, b, other)``: the fronts' directed edges (:func:`_chains`) and, for each,
    whether it is of another front than ``fronts[which]`` (-1: of none); made once
    per row, for every try of it."""
    a, b = _chains(fronts)
    lens = np.array([len(g) for g in fronts], np.int64)
    return a, b, np.repeat(np.arange(len(fronts)) != which, lens)


def _good_quads(
    Q,
    quads: np.ndarray,
    table: tuple,
    n_old: int,
    h: np.ndarray,
    gap=_GAP,
    boxes: list | None = None,
):
    """(m,) bool: the quads of a proposed row that pass every check (exact predicates).

    A quad fails when it is not strictly convex or below quality ``_MIN_Q``;
    when one of its edges that is not a front edge touches a front edge or
    another new edge except at a shared node (both quads fail then); when a
    front node or a new node not its corner lies in it; or when a new node of
    it lies closer than ``_CLEARANCE * h`` to a front node or new node that
    is not a corner of a quad of that node, or closer than ``gap * h`` to a
    node of another front when its quad does not join that front (0: no gap
    check). ``table`` is :func:`_front_table` of the fronts and the row's front.
    ``h`` is the size at each point of ``Q``. The quads that pass
    form a set that overlaps no front and no other of them. The result
    depends on the fronts only through their edges whose bounding box meets
    a box around the row (:func:`~meshcore.quads.paving_kernel.front_near`):
    when ``boxes`` is a list, that box ``(lo, hi)`` is appended to it.
    """
    ok = pk.convex_and_good(Q, quads, _MIN_Q)
    ok &= (quads[:, [0, 1, 2, 3]] != quads[:, [1, 2, 3, 0]]).all(axis=1)
    ok &= (quads[:, 0] != quads[:, 2]) & (quads[:, 1] != quads[:, 3])
    fa, fb, of_other = table
    new_nodes = unique_ints(quads[quads >= n_old])
    cen = Q[quads].mean(axis=1)
    rad = np.sqrt(((Q[quads] - cen[:, None, :]) ** 2).sum(axis=2)).max(axis=1)
    reach = max(gap, _CLEARANCE) * float(h[new_nodes].max()) if len(new_nodes) else 0.0
    # only the front edges whose box meets the row's grown by the reach
    X, margin = Q[quads].reshape(-1, 2), max(float(rad.max()) * 1.0001, reach)
    lo, hi = X.min(axis=0) - margin, X.max(axis=0) + margin
    if boxes is not None:
        boxes.append((lo, hi))
    near = pk.front_near(Q, fa, fb, lo, hi)
    fa, fb = fa[near], fb[near]
    ok &= ~pk.fresh_touch_quads(Q, quads, fa, fb)
    # nodes inside quads, and new nodes too close to a node not of their quads
    nodes = np.concatenate([unique_ints(fa), new_nodes])
    ci, cj, cd = pk.near_pairs(cen, Q[nodes], float(rad.max()) * 1.0001)
    cand = np.column_stack([ci, cj])
    cand = cand[cd <= rad[ci] * 1.0001]
    if len(cand):
        ok[cand[pk.points_in_quads(Q, quads, nodes, cand), 0]] = False
    if len(new_nodes):
        other = np.zeros(len(Q), bool)
        other[table[0]] = of_other
        ok &= ~pk.quads_too_close(Q, quads, new_nodes, nodes, h[new_nodes], other, gap, _CLEARANCE)
    return ok

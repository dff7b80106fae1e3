"""Hypothesis strategies for params around a method's example, and the fuzz profiles.

A drawn params object is the example with one to three mutations:

- ``scale``: every length (coordinates, radii, sizes, steps) times a factor from
  1e-300 to 1e300, so that the problem is the same at another scale;
- ``translate``: every position moved by up to 1e300;
- ``leaf``: one number replaced by an extreme (0, -0.0, the smallest subnormal,
  1e-300, 1e300, the largest float, their negatives) or one integer by 0..3;
- ``list``: one list emptied, cut to its first element, or its first element
  repeated or its last dropped;
- ``dim``: 2D points and nodes given a z (0, tiny, 1, huge), or 3D ones cut to 2D;
- ``celltype``: one cell block's type replaced by any cell type (mixed blocks);
- ``optional``: one float field the example leaves out set to an extreme.

The profile comes from ``MESHSERVICE_FUZZ`` (``ci`` by default: a fixed seed
and a few examples per method; ``long``: ``MESHSERVICE_FUZZ_EXAMPLES`` each,
default 500, random).
"""

from __future__ import annotations

import copy
import math
import os
import sys
import typing
from typing import Any

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from meshcore.mesh import CELL_TYPES

settings.register_profile(
    "ci",
    max_examples=12,
    derandomize=True,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
settings.register_profile(
    "long",
    max_examples=int(os.environ.get("MESHSERVICE_FUZZ_EXAMPLES", "500")),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
PROFILE = settings.get_profile(os.environ.get("MESHSERVICE_FUZZ", "ci"))

EXTREMES = [
    0.0,
    -0.0,
    5e-324,
    sys.float_info.min,
    1e-300,
    -1e-300,
    1e-150,
    1e150,
    1e300,
    -1e300,
    sys.float_info.max,
    -sys.float_info.max,
]
FACTORS = [1e-300, 1e-150, 1e-100, 1e-6, 1e6, 1e100, 1e150, 1e300]
OFFSETS = [1e6, 1e12, 1e150, 1e300, -1e300]
POSITIONS = {"points", "coordinates", "nodes", "target", "center", "origin", "point"}
LENGTHS = POSITIONS | {
    "radius",
    "inner_radius",
    "outer_radius",
    "size",
    "h",
    "max_area",
    "max_edge",
    "vector",
    "tolerance",
    "threshold",
}


def _numbers(obj: Any, keys: set[str], key: str | None = None, inside: bool = False):
    """(container, index) of every number under a key in ``keys``."""
    inside = inside or key in keys
    if isinstance(obj, dict):
        items = obj.items()
    else:
        items = enumerate(obj) if isinstance(obj, list) else ()
    for k, v in items:
        if isinstance(v, bool):
            continue
        if isinstance(v, int | float):
            if inside or k in keys:
                yield obj, k
        else:
            yield from _numbers(v, keys, k if isinstance(k, str) else key, inside)


def _nodes(obj: Any, kind: type):
    """Every dict or list (``kind``) inside ``obj``, ``obj`` first."""
    if isinstance(obj, kind):
        yield obj
    for v in obj.values() if isinstance(obj, dict) else obj if isinstance(obj, list) else []:
        yield from _nodes(v, kind)


def _map(obj: Any, keys: set[str], f) -> None:
    for container, k in list(_numbers(obj, keys)):
        container[k] = f(float(container[k]))


def _rows(obj: Any):
    """Coordinate rows: lists of 2 or 3 numbers under a position key."""
    for node in _nodes(obj, dict):
        for key in POSITIONS & node.keys():
            for row in _nodes(node[key], list):
                if row and len(row) in (2, 3) and all(isinstance(x, int | float) for x in row):
                    yield row


def _float_fields(model) -> list[str]:
    names = []
    for name, field in model.model_fields.items():
        args = typing.get_args(field.annotation) or (field.annotation,)
        if float in args and int not in args:
            names.append(name)
    return names


@st.composite
def mutated(draw, spec) -> dict:
    """Params around ``spec.example`` (see the module docstring)."""
    params = copy.deepcopy(spec.example)
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(
            st.sampled_from(["scale", "translate", "leaf", "list", "dim", "celltype", "optional"])
        )
        if kind == "scale":
            s = draw(st.sampled_from(FACTORS))
            _map(params, LENGTHS, lambda v, s=s: v * s)
        elif kind == "translate":
            t = draw(st.sampled_from(OFFSETS))
            for row in list(_rows(params)):
                row[:] = [x + t for x in row]
            for node in _nodes(params, dict):
                if isinstance(node.get("center"), list):
                    node["center"] = [x + t for x in node["center"]]
        elif kind == "leaf":
            leaves = list(_numbers(params, set(), inside=True))
            if leaves:
                container, k = draw(st.sampled_from(leaves))
                if isinstance(container[k], float) or not float(container[k]).is_integer():
                    container[k] = draw(st.sampled_from(EXTREMES))
                else:
                    container[k] = draw(st.sampled_from([0, 1, 2, 3, *EXTREMES]))
        elif kind == "list":
            lists = [x for x in _nodes(params, list) if x is not params]
            if lists:
                target = draw(st.sampled_from(lists))
                how = draw(st.sampled_from(["empty", "first", "repeat", "drop"]))
                if how == "empty":
                    target.clear()
                elif how == "first":
                    del target[1:]
                elif how == "repeat" and target:
                    target.insert(0, copy.deepcopy(target[0]))
                elif target:
                    target.pop()
        elif kind == "dim":
            z = draw(st.sampled_from([0.0, 1e-300, 1.0, 1e300]))
            for row in list(_rows(params)):
                if len(row) == 2:
                    row.append(z)
                else:
                    del row[2:]
        elif kind == "celltype":
            blocks = [b for b in _nodes(params, dict) if {"type", "data"} <= b.keys()]
            if blocks:
                block = draw(st.sampled_from(blocks))
                block["type"] = draw(st.sampled_from(sorted(CELL_TYPES)))
        else:
            names = [n for n in _float_fields(spec.params) if n not in params]
            if names:
                params[draw(st.sampled_from(names))] = draw(st.sampled_from(EXTREMES))
    return _finite(params)


def _finite(params: dict) -> dict:
    """Infinities from overflowing mutations replaced by the largest float (the schema
    refuses them before any method would see them)."""
    for container, k in list(_numbers(params, set(), inside=True)):
        v = container[k]
        if isinstance(v, float) and not math.isfinite(v):
            container[k] = math.copysign(sys.float_info.max, v)
    return params

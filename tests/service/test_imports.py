"""What the API process imports: the params models, not meshcore's method code.

The method modules import meshcore's method packages only in the checks and
run functions that use them (:mod:`service.methods.registry`); the fork server
imports them all (:data:`~service.methods.registry.METHOD_CODE`), and the
limits the params models need at definition come from :mod:`meshcore.limits`.
"""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import service.methods
from meshcore.grid import cartesian
from meshcore.medial import axis, simplification
from meshcore.tets import refinement as tets_refinement
from meshcore.triangulation import refinement
from service.methods import grid, medial, registry, tets, triangulation
from tests.service.conftest import ROOT


def _function_imports() -> set[str]:
    """The meshcore modules imported inside functions of the method modules."""
    names = set()
    for path in Path(service.methods.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.FunctionDef):
                continue
            for sub in ast.walk(node):
                if isinstance(sub, ast.ImportFrom) and sub.module.startswith("meshcore."):
                    module = importlib.import_module(sub.module)
                    for alias in sub.names:  # a submodule, or a name of the module
                        value = getattr(module, alias.name)
                        is_module = isinstance(value, ModuleType)
                        names.add(value.__name__ if is_module else sub.module)
    return names


def test_the_fork_server_loads_every_module_the_methods_import_where_they_run():
    assert _function_imports() == set(registry.METHOD_CODE)


def test_the_params_limits_are_meshcores():
    assert triangulation.MAX_MIN_ANGLE == refinement.MAX_MIN_ANGLE
    assert grid.MAX_CELLS == cartesian.MAX_CELLS
    assert medial.DEFAULT_PRUNE == axis.DEFAULT_PRUNE
    assert medial.DEFAULT_THRESHOLD == simplification.DEFAULT_THRESHOLD
    assert tets.MIN_RADIUS_EDGE == tets_refinement.MIN_RADIUS_EDGE


def test_the_api_imports_no_method_code_and_the_client_no_numpy():
    """``service.app`` without meshcore's method packages; the command line's format names
    without numpy (one interpreter for both, about a second)."""
    code = (
        "import sys\n"
        "import service.cli\n"
        "client = 'numpy' in sys.modules\n"
        "import service.app\n"
        "print(client, sorted(set(sys.modules) & set(service.methods.registry.METHOD_CODE)))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout
    assert out.split(maxsplit=1) == ["False", "[]\n"]

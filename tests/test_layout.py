"""The layout's import rules (DESIGN.md, Layout), read from the sources with ``ast``.

- ``meshcore`` never imports ``service``;
- ``service/api/`` reaches ``meshcore`` only through the method registry;
- the kernel packages (geometry, mesh, domain, delaunay) import no method package;
- no package of ``meshcore`` imports a private name (``_x``) of another package.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
KERNEL = ("errors", "geometry", "mesh", "domain", "delaunay")


def _imports(path: Path) -> list[tuple[str, list[str], int]]:
    """(module, imported names, line) of every import in ``path``, relative ones resolved."""
    package = ".".join(path.relative_to(ROOT).with_suffix("").parts[:-1])
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(alias.name, [], node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join([*base, module] if module else base)
            out.append((module, [a.name for a in node.names], node.lineno))
    return out


def _sources(folder: str) -> list[Path]:
    return sorted((ROOT / folder).rglob("*.py"))


def _package(path: Path) -> str:
    """The meshcore package a file belongs to (``errors`` for meshcore/errors.py)."""
    parts = path.relative_to(ROOT / "meshcore").with_suffix("").parts
    return parts[0]


def _where(path: Path, line: int) -> str:
    return f"{path.relative_to(ROOT)}:{line}"


def test_meshcore_never_imports_service():
    bad = [
        _where(p, line)
        for p in _sources("meshcore")
        for module, _, line in _imports(p)
        if module == "service" or module.startswith("service.")
    ]
    assert not bad, f"meshcore imports service at {bad}"


def test_service_api_reaches_meshcore_only_through_the_registry():
    bad = [
        _where(p, line)
        for p in _sources("service/api")
        for module, _, line in _imports(p)
        if module == "meshcore" or module.startswith("meshcore.")
    ]
    assert not bad, f"service/api imports meshcore directly at {bad}"


def test_kernel_packages_import_no_method_package():
    bad = []
    for p in _sources("meshcore"):
        if p.name == "__init__.py" and p.parent.name == "meshcore":
            continue  # the top-level re-exports
        if _package(p) not in KERNEL:
            continue
        for module, _, line in _imports(p):
            parts = module.split(".")
            if parts[0] == "meshcore" and len(parts) > 1 and parts[1] not in KERNEL:
                bad.append(f"{_where(p, line)} imports {module}")
    assert not bad, bad


def test_no_private_name_crosses_a_package():
    bad = []
    for p in _sources("meshcore"):
        own = _package(p)
        for module, names, line in _imports(p):
            parts = module.split(".")
            if parts[0] != "meshcore" or len(parts) < 2 or parts[1] == own:
                continue
            bad += [f"{_where(p, line)}: {n} from {module}" for n in names if n.startswith("_")]
    assert not bad, bad


@pytest.mark.parametrize(
    "package",
    ["meshcore", *sorted(p.parent.name for p in (ROOT / "meshcore").glob("*/__init__.py"))],
)
def test_every_package_names_its_public_api(package):
    import importlib

    name = package if package == "meshcore" else f"meshcore.{package}"
    mod = importlib.import_module(name)
    assert mod.__doc__ and mod.__doc__.strip(), f"{name} has no docstring"
    assert mod.__all__, f"{name} has no __all__"
    for public in mod.__all__:
        assert getattr(mod, public) is not None, f"{name}.{public}"

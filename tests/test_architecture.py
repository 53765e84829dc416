"""The layout docs/ARCHITECTURE.md describes holds: no import runs up a layer, and method
names are spelled only where the architecture allows."""
import ast
from pathlib import Path

import pytest

from robocal.methods import method_names

PACKAGE = Path(__file__).resolve().parents[1] / "robocal"
LAYERS = ["spatial", "kinematics", "io", "simulation", "estimation", "planning", "compensation", "methods",
          "interfaces"]


def _modules():
    return sorted(p for p in PACKAGE.rglob("*.py") if "data" not in p.relative_to(PACKAGE).parts)


def _layer(path):
    top = path.relative_to(PACKAGE).parts[0]
    return LAYERS.index(top) if top in LAYERS else -1


def _imported_layers(path):
    """(line, layer) of every robocal package a module imports."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = path.relative_to(PACKAGE).parts[:-1]
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(package[:len(package) - node.level + 1])
                target = base + (node.module.split(".") if node.module else [])
            elif node.module and node.module.startswith("robocal."):
                target = node.module.split(".")[1:]
            else:
                continue
            names = target[:1] or [alias.name for alias in node.names]
            for name in names:
                if name in LAYERS:
                    yield node.lineno, LAYERS.index(name)


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_import_runs_up_a_layer(path):
    own = _layer(path)
    if own < 0:
        return
    upward = [(line, LAYERS[layer]) for line, layer in _imported_layers(path) if layer > own]
    assert not upward, f"{path.relative_to(PACKAGE)} ({LAYERS[own]}) imports upwards: {upward}"


def test_compensation_does_not_import_estimation():
    estimation = LAYERS.index("estimation")
    for path in (PACKAGE / "compensation").glob("*.py"):
        assert all(layer != estimation for _, layer in _imported_layers(path)), path


# The demo is the published Kriging experiment; its JSON names the model it fitted.
NAMES_ALLOWED_IN = {"interfaces/demo.py"}


def test_method_names_are_spelled_only_in_the_methods_layer_and_the_help():
    """Nothing above the methods layer asks which method it holds.  (Below it, "constraint"
    is also a kind of data, as measurement files have always said.)"""
    offenders = []
    for path in _modules():
        if LAYERS[_layer(path)] != "interfaces" or str(path.relative_to(PACKAGE)) in NAMES_ALLOWED_IN:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                      if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef)) and node.body
                      and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}
        for node in ast.walk(tree):
            if (isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings
                    and node.value in method_names() and "help" not in _context(path, node.lineno)):
                offenders.append(f"{path.relative_to(PACKAGE)}:{node.lineno} {node.value!r}")
    assert not offenders, offenders


def _context(path, line):
    return path.read_text(encoding="utf-8").splitlines()[line - 1]

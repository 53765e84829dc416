"""The layout docs/ARCHITECTURE.md describes holds: no import runs up a layer, and method
names are spelled only where the architecture allows."""
import ast
from pathlib import Path

import pytest

from robocal.methods import method_names

PACKAGE = Path(__file__).resolve().parents[1] / "robocal"
LAYERS = ["spatial", "kinematics", "io", "simulation", "estimation", "planning", "compensation", "acceptance",
          "methods", "interfaces"]


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


# ------------------------------------------------------------------------------ import cycles
def _module_name(path):
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _import_graph():
    """{module: robocal modules it imports}, counting imports inside functions too: an import
    deferred to break a cycle still ties the two modules together.  ``from . import name``
    counts as an import of the submodule ``name`` when there is one, else of the package."""
    modules = {_module_name(path): path for path in _modules()}
    graph = {}
    for name, path in modules.items():
        package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
        targets = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = ".".join(package[:len(package) - node.level + 1] + ([node.module] if node.module else []))
                elif node.module:
                    base = node.module
                else:
                    continue
                submodules = {f"{base}.{alias.name}" for alias in node.names} & modules.keys()
                targets.update(submodules or {base})
        graph[name] = sorted(target for target in targets if target in modules and target != name)
    return graph


def _cycles(graph):
    """The strongly connected components of more than one module (Tarjan's algorithm)."""
    index, low, stack, on_stack, components = {}, {}, [], set(), []

    def visit(module):
        index[module] = low[module] = len(index)
        stack.append(module)
        on_stack.add(module)
        for target in graph[module]:
            if target not in index:
                visit(target)
                low[module] = min(low[module], low[target])
            elif target in on_stack:
                low[module] = min(low[module], index[target])
        if low[module] == index[module]:
            component = set()
            while not component or module not in component:
                component.add(stack.pop())
            on_stack.difference_update(component)
            if len(component) > 1:
                components.append(frozenset(component))

    for module in graph:
        if module not in index:
            visit(module)
    return components


# Import cycles of today, each to be broken by the issue named; a new cycle fails the test.
KNOWN_CYCLES = {
    # issue 25, part 1: fleet.py checks a fleet file with the command line's own parser.
    frozenset({"robocal.interfaces.cli", "robocal.interfaces.fleet"}),
}


def test_the_import_graph_finds_a_cycle_when_there_is_one():
    assert _cycles({"a": ["b"], "b": ["c"], "c": ["a"], "d": ["a"]}) == [frozenset("abc")]
    assert _cycles({"a": ["b"], "b": [], "c": ["a", "b"]}) == []


def test_no_import_cycle_in_robocal():
    graph = _import_graph()
    assert "robocal.estimation.kriging.model" in graph["robocal.estimation.kriging"]  # the graph sees packages
    new = [sorted(cycle) for cycle in _cycles(graph) if cycle not in KNOWN_CYCLES]
    assert not new, f"import cycles: {new}"


# ------------------------------------------------------------------------------ CSV outside io/
CSV_CALLS = {"loadtxt", "genfromtxt", "savetxt", "read_csv", "to_csv"}
# CSV handling outside robocal/io/ today, each to move into io/ under the issue named; any
# other module that reads or writes CSV fails the test.
KNOWN_CSV_ACCESS = set()


def _csv_access(path):
    """Lines of ``path`` that touch CSV: the csv module, NumPy's (or pandas') text readers and
    writers, ``open`` of a literal name ending in .csv."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import) and any(alias.name == "csv" for alias in node.names):
            found.append(node.lineno)
        elif isinstance(node, ast.ImportFrom) and node.module == "csv":
            found.append(node.lineno)
        elif isinstance(node, ast.Call):
            function = node.func
            name = function.attr if isinstance(function, ast.Attribute) else getattr(function, "id", "")
            if name in CSV_CALLS:
                found.append(node.lineno)
            elif name == "open" and node.args and ".csv" in ast.unparse(node.args[0]):
                found.append(node.lineno)
    return found


def test_the_csv_check_sees_each_kind_of_access(tmp_path):
    sample = tmp_path / "sample.py"
    sample.write_text("import csv\nfrom csv import writer\nimport numpy as np\nnp.loadtxt('a.csv')\n"
                      "open(f'{name}.csv')\nopen('model.json')\n")
    assert _csv_access(sample) == [1, 2, 4, 5]


def test_no_csv_access_outside_io():
    offenders = {}
    for path in _modules():
        where = str(path.relative_to(PACKAGE))
        if path.relative_to(PACKAGE).parts[0] == "io" or where in KNOWN_CSV_ACCESS:
            continue
        if lines := _csv_access(path):
            offenders[where] = lines
    assert not offenders, f"CSV read or written outside robocal/io/: {offenders}"

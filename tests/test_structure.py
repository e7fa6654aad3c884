"""The package's shape: one installed name, stages that import only downwards,
no import cycles, no imports hidden in functions, no private names across modules.

The graph is read from the source (ast), so an import an execution order
happens to tolerate still counts, and an import under ``if TYPE_CHECKING``
(never executed) does not.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
FOLDERS = {"core": "flatweave", "app": "flatweave.app"}

# The stages, lowest first: a module may import from its own stage and the ones
# before it, never from a later one (docs/ARCHITECTURE.md's stage table).
STAGES = ("flatweave.errors", "flatweave.version", "flatweave.files", "flatweave.geometry", "flatweave.method",
          "flatweave.studies", "flatweave.export", "flatweave.document", "flatweave.reading", "flatweave.cli",
          "flatweave.app", "flatweave.__main__", "flatweave")

# Imports placed in a function on purpose, each with its reason. Nothing here
# dodges a cycle: the cycle test would still pass with them at the top.
DEFERRED = {
    ("flatweave.app.main", "flatweave.app.mainwindow"):
        "the window (Qt, VTK) loads after the arguments are read and the display is checked, "
        "so --help and a bad argument answer without a display",
}


def module_name(path: Path) -> str:
    rel = path.relative_to(REPO).with_suffix("")
    parts = list(rel.parts)
    parts = FOLDERS[parts[0]].split(".") + parts[1:]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def sources() -> dict[str, Path]:
    return {module_name(p): p for folder in FOLDERS for p in sorted((REPO / folder).rglob("*.py"))}


MODULES = sources()


def _type_checking(node) -> bool:
    test = getattr(node, "test", None)
    return isinstance(node, ast.If) and ("TYPE_CHECKING" in ast.unparse(test))


def imports(path: Path):
    """(imported flatweave module, names, at top level?) for each import of ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = {id(n) for node in ast.walk(tree) if _type_checking(node) for n in ast.walk(node)}
    top = {id(n) for n in tree.body}
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for a in node.names:
                full = f"{node.module}.{a.name}"
                target = full if full in MODULES else node.module
                yield target, a.name, id(node) in top
        elif isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, None, id(node) in top


def graph() -> dict[str, set[str]]:
    return {m: {t for t, _, at_top in imports(p) if t in MODULES and at_top and t != m} for m, p in MODULES.items()}


def stage(module: str) -> int:
    return max(i for i, s in enumerate(STAGES) if module == s or module.startswith(s + "."))


def test_the_folders_install_as_one_package():
    assert "flatweave" in MODULES and "flatweave.app" in MODULES
    assert {"flatweave.geometry", "flatweave.method", "flatweave.studies", "flatweave.export",
            "flatweave.document", "flatweave.reading"} <= set(MODULES)


def test_nothing_imports_core_or_app_by_their_folder_names():
    bad = [(m, t) for m, p in MODULES.items() for t, _, _ in imports(p) if t.split(".")[0] in ("core", "app")]
    bad += [(p.name, t) for p in (REPO / "tests").glob("*.py") for t, _, _ in imports(p)
            if t.split(".")[0] in ("core", "app")]
    assert not bad


def test_every_sub_package_says_what_it_owns():
    for m, p in MODULES.items():
        if p.name == "__init__.py":
            doc = ast.get_docstring(ast.parse(p.read_text(encoding="utf-8")))
            assert doc and len(doc) > 40, f"{m} has no docstring saying what it owns"


def test_no_import_cycles():
    g = graph()
    index, low, on_stack, stack, cycles = {}, {}, set(), [], []

    def visit(v):  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in g[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    assert not cycles, f"import cycles: {cycles}"


def test_stages_import_only_downwards():
    bad = [(m, t) for m, ts in graph().items() for t in ts if stage(t) > stage(m)]
    assert not bad, "a stage imports a later one: " + ", ".join(f"{m} -> {t}" for m, t in bad)


def test_the_engine_never_imports_the_window():
    bad = [(m, t) for m, p in MODULES.items() if not m.startswith("flatweave.app")
           for t, _, _ in imports(p) if t.startswith("flatweave.app")]
    assert not bad


def test_no_flatweave_import_inside_a_function_but_the_stated_ones():
    found = {(m, t) for m, p in MODULES.items() for t, _, at_top in imports(p)
             if not at_top and t.startswith("flatweave")}
    assert found == set(DEFERRED), f"inside functions: {sorted(found - set(DEFERRED))}"


def test_no_private_name_is_used_outside_its_module():
    bad = []
    for m, p in MODULES.items():
        tree = ast.parse(p.read_text(encoding="utf-8"))
        aliases = {}
        for t, name, _ in imports(p):
            if name is not None and name.startswith("_") and not name.startswith("__") and t != m:
                bad.append(f"{m} imports {t}.{name}")
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module:
                for a in node.names:
                    if f"{node.module}.{a.name}" in MODULES:
                        aliases[a.asname or a.name] = f"{node.module}.{a.name}"
            elif isinstance(node, ast.Import):
                for a in node.names:
                    if a.name in MODULES and a.asname:
                        aliases[a.asname] = a.name
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases
                    and node.attr.startswith("_") and not node.attr.startswith("__")):
                bad.append(f"{m} uses {aliases[node.value.id]}.{node.attr}")
    assert not bad, "; ".join(bad)


@pytest.mark.parametrize("helper", ["polygon_area", "validate_settings", "settings_to_dict", "boundary_distance"])
def test_one_helper_per_idea(helper):
    defined = [m for m, p in MODULES.items()
               if any(isinstance(n, ast.FunctionDef) and n.name == helper
                      for n in ast.parse(p.read_text(encoding="utf-8")).body)]
    assert len(defined) == 1, f"{helper} is defined in {defined}"

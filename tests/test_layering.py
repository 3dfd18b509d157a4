"""The repository's import rules, as one table, checked over every Python file.

Data and imports flow one way:  protocol  <-  jetson  <-  sim  <-  bench, tests.

Each row of RULES names a package (the longest matching prefix wins) and the project packages
it may import; THIRD_PARTY names the outside libraries a package may import at module level
(lazy imports inside a function are how optional engines such as onnxruntime stay optional, and
are checked against the project rules but not this list). On top of the table, no two modules
may import each other, directly or through others, whether the imports are at module level or
inside functions.
"""

from __future__ import annotations

import ast
import sys
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("protocol", "jetson", "sim", "bench")

# package prefix -> the project packages (prefixes) it may import
RULES: dict[str, tuple[str, ...]] = {
    "protocol": ("protocol",),
    "jetson": ("protocol", "jetson"),
    # The robot's decision code: itself and the Jetson's error types, nothing else of ours.
    "jetson.autonomy": ("jetson.autonomy", "jetson.errors"),
    "jetson.errors": (),
    "sim": ("protocol", "jetson", "sim"),
    "bench": ("protocol", "jetson", "sim", "bench"),
}

# package prefix -> outside libraries allowed at module level (None: any)
THIRD_PARTY: dict[str, tuple[str, ...] | None] = {
    "protocol": ("numpy", "cobs", "tomli"),  # tomli: tomllib on Python 3.10 (protocol.compat)
    "jetson": None,
    "jetson.autonomy": ("numpy",),
    "sim": None,
    "bench": None,
}


@dataclass(frozen=True)
class Import:
    importer: str
    imported: str  # a project module, or the top-level name of an outside library
    line: int
    lazy: bool  # inside a function
    project: bool


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def find_modules(root: Path, packages: Iterable[str] = PACKAGES) -> dict[str, Path]:
    found = {}
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):
            found[module_name(path, root)] = path
    return found


def _lazy_lines(tree: ast.AST) -> set[int]:
    """Line numbers of imports inside a function body."""
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            for inner in ast.walk(node):
                if isinstance(inner, ast.Import | ast.ImportFrom):
                    lines.add(inner.lineno)
    return lines


def imports_of(name: str, path: Path, modules: dict[str, Path]) -> list[Import]:
    tree = ast.parse(path.read_text(), str(path))
    lazy = _lazy_lines(tree)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []

    def add(target: str, line: int) -> None:
        # The longest project module the name reaches: `from a.b import c` is a.b.c when it is one.
        probe = target
        while probe and probe not in modules:
            probe = probe.rpartition(".")[0]
        if probe:
            if probe != name:
                out.append(Import(name, probe, line, line in lazy, True))
        else:
            top = target.split(".")[0]
            if top not in sys.stdlib_module_names and top != "__future__":
                out.append(Import(name, top, line, line in lazy, False))

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                add(alias.name, node.lineno)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                source = ".".join([*base, *([node.module] if node.module else [])])
            else:
                source = node.module or ""
            for alias in node.names:
                full = f"{source}.{alias.name}"
                add(full if full in modules else source, node.lineno)
    return out


def _rule_for(module: str, table: dict[str, object]) -> str:
    best = ""
    for prefix in table:
        if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > len(best):
            best = prefix
    return best


def _allowed(target: str, prefixes: Iterable[str]) -> bool:
    return any(target == p or target.startswith(p + ".") for p in prefixes)


def violations(imports: list[Import]) -> list[str]:
    """Every import against RULES and THIRD_PARTY, as 'file line: importer imports X (rule)'."""
    bad = []
    for imp in imports:
        if imp.project:
            rule = _rule_for(imp.importer, RULES)
            if not _allowed(imp.imported, RULES[rule]):
                bad.append(
                    f"{imp.importer}:{imp.line} imports {imp.imported}: {rule} may import only "
                    f"{', '.join(RULES[rule]) or 'nothing of ours'}"
                )
        elif not imp.lazy:
            rule = _rule_for(imp.importer, THIRD_PARTY)
            allowed = THIRD_PARTY[rule]
            if allowed is not None and imp.imported not in allowed:
                bad.append(
                    f"{imp.importer}:{imp.line} imports {imp.imported} at module level: {rule} "
                    f"may import only {', '.join(allowed)} (others inside a function)"
                )
    return bad


def cycles(imports: list[Import]) -> list[list[str]]:
    """The import cycles among project modules (Tarjan's strongly connected components)."""
    graph: dict[str, set[str]] = {}
    for imp in imports:
        if imp.project:
            graph.setdefault(imp.importer, set()).add(imp.imported)
            graph.setdefault(imp.imported, set())
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def check(root: Path, packages: Iterable[str] = PACKAGES) -> tuple[list[str], list[list[str]]]:
    modules = find_modules(root, packages)
    imports = [i for name, path in modules.items() for i in imports_of(name, path, modules)]
    return violations(imports), cycles(imports)


def test_every_import_keeps_the_layering() -> None:
    bad, _ = check(ROOT)
    assert not bad, "imports against the layering table:\n" + "\n".join(bad)


def test_no_import_cycle_between_any_modules() -> None:
    _, loops = check(ROOT)
    assert not loops, "import cycles:\n" + "\n".join(" <-> ".join(c) for c in loops)


def test_every_package_has_a_rule() -> None:
    for package in PACKAGES:
        assert _rule_for(package, RULES) == package


def test_the_checker_finds_a_wrong_import_and_a_cycle(tmp_path: Path) -> None:
    """The checker itself, on a made-up tree: jetson reaching into sim, a cycle inside sim,
    the decision code importing a library at module level and a lazy import that is fine."""
    files = {
        "protocol/__init__.py": "",
        "jetson/__init__.py": "",
        "jetson/errors.py": "",
        "jetson/autonomy/__init__.py": "",
        "jetson/autonomy/policy.py": (
            "import numpy\nfrom jetson.errors import X\ndef load():\n    import onnxruntime\n"
        ),
        "jetson/autonomy/bad.py": "import scipy\n",
        "jetson/daemon.py": "from sim.world import World\n",
        "sim/__init__.py": "",
        "sim/world.py": "from . import rules\n",
        "sim/rules.py": "def f():\n    from sim.world import World\n",
        "bench/__init__.py": "",
    }
    for rel, text in files.items():
        path = tmp_path / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    bad, loops = check(tmp_path)
    assert len(bad) == 2
    assert any(b.startswith("jetson.daemon:1 imports sim.world") for b in bad)
    assert any(b.startswith("jetson.autonomy.bad:1 imports scipy") for b in bad)
    assert loops == [["sim.rules", "sim.world"]]

"""The layering of ``trimd`` as a test: each subpackage imports only the layers below it.

The import graph is read from the source (every ``import``, at any depth in a module), so a
late import inside a function counts as much as one at the top.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "trimd"

#: subpackage → the trimd subpackages it may import (besides itself and ``trimd`` itself).
MAY_IMPORT: dict[str, set[str]] = {
    "core": set(),
    "ballast": {"core"},
    "identify": {"core"},
    "drivers": {"core"},
    "logs": {"core", "drivers"},
    "app": {"core", "ballast", "identify", "drivers", "logs"},
    "tui": {"core", "ballast", "identify", "drivers", "logs", "app"},
    "cli": {"core", "ballast", "identify", "drivers", "logs", "app", "tui"},
}

#: Modules that do I/O, keep clocks or run threads: none of them in the pure layers.
IO_MODULES = {"asyncio", "os", "pathlib", "select", "serial", "signal", "socket", "sqlite3",
              "subprocess", "sys", "threading", "time", "datetime", "pymavlink", "textual",
              "matplotlib", "importlib"}
PURE = {"core", "ballast", "identify"}
#: The pure-layer modules allowed some I/O, and which: the profile loader reads files
#: (shipped profiles are package data read through importlib.resources); the MILP's guard
#: points descriptor 1 away from standard output while HiGHS runs (its stray native prints).
PURE_IO = {"trimd.core.profile_yaml": {"pathlib", "importlib"},
           "trimd.ballast.highs": {"os", "sys"}}


def _modules() -> list[tuple[str, Path]]:
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out.append((".".join(parts), path))
    return out


def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


MODULES = _modules()


def test_every_module_belongs_to_a_layer() -> None:
    strays = [name for name, _ in MODULES if name.count(".") >= 1
              and name.split(".")[1] not in MAY_IMPORT and name != "trimd.__main__"]
    assert strays == [], f"modules outside the layers of MAY_IMPORT: {strays}"


LAYERED = [m for m in MODULES if m[0].count(".") >= 1 and m[0] != "trimd.__main__"]


@pytest.mark.parametrize(("name", "path"), LAYERED, ids=[m[0] for m in LAYERED])
def test_imports_follow_the_layers(name: str, path: Path) -> None:
    layer = name.split(".")[1]
    allowed = MAY_IMPORT[layer] | {layer}
    wrong = sorted(m for m in _imports(path)
                   if m.startswith("trimd.") and m.split(".")[1] not in allowed)
    assert wrong == [], f"{name} ({layer}) imports {wrong}; {layer} may import {sorted(allowed)}"
    if layer in PURE:
        io = sorted(m for m in _imports(path)
                    if m.split(".")[0] in IO_MODULES - PURE_IO.get(name, set()))
        assert io == [], f"{name} is pure computation but imports {io}"


def test_the_check_catches_a_wrong_import(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    from trimd.app.session import Session\n    import time\n")
    assert {"trimd.app.session", "time"} <= _imports(bad)


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import circles of ``graph`` (module → modules it imports): its strongly
    connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = [stack.pop()]
            while component[-1] != v:
                component.append(stack.pop())
            if len(component) > 1:
                out.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_circle_above_the_core() -> None:
    """The application's layers (app, tui, cli, …) import one way, type-checking imports
    included: a module that needs its caller takes what it needs as arguments (the TUI's
    follow-up takes the app's panels, state and a callable that starts a session)."""
    names = {name for name, _ in LAYERED if name.split(".")[1] != "core"}
    graph = {name: {m for m in _imports(path) if m in names and m != name}
             for name, path in LAYERED if name in names}
    assert _circles(graph) == []


def test_the_circle_check_finds_a_circle() -> None:
    assert _circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


#: The longest a module of trimd may be [lines]: past it, split it along its seams.
MAX_MODULE_LINES = 400


def test_no_module_is_over_the_line_limit() -> None:
    long = {name: n for name, path in MODULES
            if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES}
    assert long == {}, f"modules over {MAX_MODULE_LINES} lines (split them): {long}"


#: The one module where trimd's types stop: pymavlink's untyped messages and connections,
#: as Protocols whose generated fields are ``Any``.
UNTYPED_EDGE = "trimd.drivers.mavlink.message"
_BARE_ANY = re.compile(r"(:|->)\s*Any\b")


def test_no_bare_any_in_a_signature_outside_the_pymavlink_edge() -> None:
    bare = [f"{name}:{k}: {line.strip()}" for name, path in MODULES if name != UNTYPED_EDGE
            for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
            if _BARE_ANY.search(line)]
    assert bare == [], "a bare Any (name the type, or a Protocol):\n" + "\n".join(bare)


#: Modules of the cli that a command may import: main.py registers the commands, a command
#: registers its own sub-commands (``trimd ballast apply``), and the shared reading of
#: arguments. Everything else a command needs lives below the cli (app/, logs/, …).
CLI_SHARED = {"trimd.cli.argtypes", "trimd.cli.history_args", "trimd.cli.watch_args"}
CLI_REGISTERS = {"trimd.cli.ballast": {"trimd.cli.ballast_apply"}}


def _cli_imports(path: Path) -> set[str]:
    """The trimd.cli modules ``path`` imports (``from trimd.cli import x`` as trimd.cli.x)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("trimd.cli"))
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module == "trimd.cli":
                out.update(f"trimd.cli.{a.name}" for a in node.names)
            elif node.module.startswith("trimd.cli."):
                out.add(node.module)
    return out


CLI = [m for m in MODULES if m[0].startswith("trimd.cli.") and m[0] != "trimd.cli.main"]


@pytest.mark.parametrize(("name", "path"), CLI, ids=[m[0] for m in CLI])
def test_no_command_imports_another(name: str, path: Path) -> None:
    allowed = CLI_SHARED | CLI_REGISTERS.get(name, set()) | {name}
    wrong = sorted(_cli_imports(path) - allowed)
    assert wrong == [], (f"{name} imports {wrong}: a command may import only "
                         f"{sorted(CLI_SHARED)}; move what it shares below the cli")


TESTS = PACKAGE.parent / "tests"
#: Outside tests/cli a test may run the command line as a user does
#: (``trimd.cli.main.main``) but import nothing else of the cli: library functions live
#: below it.
OUTSIDE_CLI_TESTS = sorted(p for p in TESTS.rglob("*.py")
                           if p.relative_to(TESTS).parts[0] != "cli")


def test_tests_outside_the_cli_import_only_its_entry_point() -> None:
    wrong = {path.relative_to(PACKAGE.parent).as_posix(): sorted(reached)
             for path in OUTSIDE_CLI_TESTS
             if (reached := _cli_imports(path) - {"trimd.cli.main"})}
    assert wrong == {}, f"tests importing the cli's insides (import from app/, logs/): {wrong}"

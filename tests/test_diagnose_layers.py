"""The diagnosis package's layering: a surrogate diagnosis never loads MuJoCo, and its modules
import each other without a circle."""

from __future__ import annotations

import ast
import subprocess
import sys
import textwrap
from pathlib import Path

import mjtrack.diagnose

PACKAGE = Path(mjtrack.diagnose.__file__).parent


def test_a_surrogate_diagnosis_does_not_import_mujoco():
    code = textwrap.dedent("""
        import sys
        import mjtrack.diagnose
        assert "mujoco" not in sys.modules, "import mjtrack.diagnose loaded mujoco"
        from mjtrack.diagnose import diagnose
        from mjtrack.testing.diagnose_logs import make_log
        log, robot = make_log("cg_offset_x", seed=2, duration=30.0)
        d = diagnose(log, robot, baseline="surrogate", effects=["cg_x"], max_effects=1, n_folds=3)
        d.to_json()
        print("mujoco" in sys.modules, sorted(m for m in sys.modules if m.startswith("mjtrack.sim")))
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[0] == "False", out.stdout


def _imports(path: Path, modules) -> set[str]:
    """The mjtrack.diagnose modules ``path`` imports at module level (not inside functions, where a
    lazy import is a deliberate break): for
    ``from P import X``, the module P.X when X is one, else P itself."""
    tree = ast.parse(path.read_text())
    out = set()
    # type-only imports (under ``if TYPE_CHECKING:``) count: a circle of types is still a circle
    body = [n for node in tree.body for n in (node.body if isinstance(node, ast.If) else [node])]
    for node in body:
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("mjtrack.diagnose"):
            for a in node.names:
                sub = f"{node.module}.{a.name}"
                out.add(sub if sub in modules else node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("mjtrack.diagnose"))
    return out


def _module(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(["mjtrack", *parts])


def test_no_import_circle_inside_the_package():
    files = {_module(p): p for p in PACKAGE.rglob("*.py")}
    graph = {m: {i for i in _imports(p, files) if i in files and i != m} for m, p in files.items()}
    state: dict[str, int] = {}

    def visit(m, path):
        state[m] = 1
        for n in graph[m]:
            if state.get(n) == 1:
                raise AssertionError("import circle: " + " -> ".join(path + [m, n]))
            if n not in state:
                visit(n, path + [m])
        state[m] = 2

    for m in graph:
        if m not in state:
            visit(m, [])
    assert len(graph) > 10 and graph["mjtrack.diagnose.run"]  # the graph was read

"""host_tools' house rules: no import cycle between octo_gcs's modules (every import counts,
those inside functions too), and `python -m octo_gcs` is the `octo-gcs` command."""

import ast
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PKG = REPO / "host_tools" / "octo_gcs"


def modules():
    """{dotted name: path} of the package's modules (a package is its __init__)."""
    out = {}
    for path in PKG.rglob("*.py"):
        parts = list(path.relative_to(PKG.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def imports(name, path, known):
    """The octo_gcs modules `name` imports: `from X import Y` is module X.Y when that is a
    module, else X; relative imports resolved against the importing module's package."""
    is_pkg = path.name == "__init__.py"
    package = name if is_pkg else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name in known}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            for a in node.names:
                if f"{mod}.{a.name}" in known:
                    found.add(f"{mod}.{a.name}")
                elif mod in known:
                    found.add(mod)
    found.discard(name)
    return found


def cycles(graph):
    """Every strongly connected group of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                out.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_import_graph_is_read():
    known = modules()
    assert {"octo_gcs.cli", "octo_gcs.mission.run", "octo_gcs.commands.mission"} <= set(known)
    graph = {n: imports(n, p, known) for n, p in known.items()}
    assert "octo_gcs.commands" in graph["octo_gcs.cli"]
    assert {"octo_gcs.mission.staging", "octo_gcs.mission.flying_udp"} <= graph["octo_gcs.mission.run"]
    # and a cycle would be seen
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycle_in_octo_gcs():
    known = modules()
    graph = {n: imports(n, p, known) for n, p in known.items()}
    assert cycles(graph) == []


def test_python_m_octo_gcs_is_the_command():
    r = subprocess.run([sys.executable, "-m", "octo_gcs", "--help"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("usage: octo-gcs ")
    for cmd in ("params", "takeoff", "land", "identify", "mission", "campaign", "plot"):
        assert f"    {cmd} " in r.stdout, cmd
    gcs = Path(sys.executable).parent / "octo-gcs"
    same = subprocess.run([str(gcs), "--help"], capture_output=True, text=True, timeout=60)
    assert same.stdout == r.stdout
    r = subprocess.run([sys.executable, "-m", "octo_gcs", "mission", "--experiments", "9"], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 1 and "octo-gcs: experiment 9 unknown" in r.stderr

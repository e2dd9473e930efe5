"""The house rules, checked from the sources.

- No include cycle among the firmware's modules. A module is a basename without its extension
  (x.c with x.h, or a header alone); `#include "y.h"` in either file of module x is an edge
  x -> y when y is a file under firmware/ (generated headers, e.g. MAVLink's and LCM's, are not).
- No firmware function longer than MAX_FUNC_LINES, from its signature to its closing brace.
- README.md at most README_MAX_LINES lines.
"""

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
FIRMWARE = REPO / "firmware"
MAX_FUNC_LINES = 120
README_MAX_LINES = 250

# Include cycles still to be removed, as pairs of modules whose edges (both ways) are left out
# of the check. This list must shrink to empty, never grow.
ALLOWED_CYCLE_PAIRS = set()

# Functions still over MAX_FUNC_LINES (firmware/app/ only), as (file, function). This list must
# shrink to empty, never grow.
ALLOWED_LONG_FUNCTIONS = set()


def firmware_files(*suffixes):
    return sorted(p for p in FIRMWARE.rglob("*") if p.is_file() and p.suffix in suffixes)


INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def include_graph():
    """module -> set of modules it includes (other modules only)."""
    files = firmware_files(".c", ".h")
    modules = {p.stem for p in files}
    graph = {m: set() for m in modules}
    for p in files:
        for inc in INCLUDE.findall(p.read_text(errors="replace")):
            target = Path(inc).stem
            if target in modules and target != p.stem:
                graph[p.stem].add(target)
    return graph


def cycles(graph):
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, on_stack, stack, out = {}, {}, set(), [], []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
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
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def without_pairs(graph, pairs):
    return {a: {b for b in bs if frozenset({a, b}) not in pairs} for a, bs in graph.items()}


def test_cycle_finder_finds_a_cycle():
    g = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(g) == [["a", "b", "c"]]
    assert cycles(without_pairs(g, {frozenset({"a", "c"})})) == []


def test_no_include_cycle_among_firmware_modules():
    graph = include_graph()
    assert "motor_id" in graph and "scalar" in graph["motor_id"], "the include graph is empty: scanner broken"
    found = cycles(without_pairs(graph, ALLOWED_CYCLE_PAIRS))
    assert not found, f"include cycles among firmware modules: {found}"


def test_allowed_cycles_still_exist():
    """An entry of ALLOWED_CYCLE_PAIRS whose cycle is gone must leave the list."""
    graph = include_graph()
    stale = sorted(sorted(p) for p in ALLOWED_CYCLE_PAIRS
                   if not any(set(p) <= set(c) for c in cycles(graph)))
    assert not stale, f"no longer in a cycle, remove from ALLOWED_CYCLE_PAIRS: {stale}"


def blank_comments_and_strings(text):
    """text with comments, string and character literals blanked; newlines kept."""
    out, i, n = [], 0, len(text)
    while i < n:
        if text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text[i] in "\"'":
            q, j = text[i], i + 1
            while j < n and text[j] != q and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(q + re.sub(r"[^\n]", " ", text[i + 1:j]) + q)
            i = j + 1
        else:
            out.append(text[i])
            i += 1
    return "".join(out)


SIGNATURE = re.compile(r"^[A-Za-z_][\w\s\*]*?\b(\w+)\s*\(")


def functions(text):
    """(name, first line, length in lines) of each top-level function body of C source text:
    a brace at file level after a ')' opens one; its signature starts at the nearest line
    above that begins with a declaration and a name followed by '('."""
    lines = [("" if ln.lstrip().startswith("#") else ln) for ln in blank_comments_and_strings(text).split("\n")]
    depth, found, current = 0, [], None
    for no, line in enumerate(lines, 1):
        for k, ch in enumerate(line):
            if ch == "{":
                if depth == 0:
                    current = None
                    before = "\n".join(lines[max(0, no - 8):no - 1] + [line[:k]]).rstrip()
                    if before.endswith(")"):
                        for start in range(no, max(0, no - 8), -1):
                            m = SIGNATURE.match(lines[start - 1])
                            if m:
                                current = (m.group(1), start)
                                break
                depth += 1
            elif ch == "}":
                depth -= 1
                if depth == 0 and current:
                    found.append((current[0], current[1], no - current[1] + 1))
                    current = None
    return found


def test_function_scanner_measures_a_function():
    src = ('/* f() { */\nstatic int f(int a,\n\t\tint b)\n{\n\tconst char *s = "}";\n'
           '\tif (a) {\n\t\treturn b;\n\t}\n\treturn 0;\n}\nstruct s { int x; };\nint g(void) { return 1; }\n')
    assert functions(src) == [("f", 2, 9), ("g", 12, 1)]


def test_no_firmware_function_over_the_limit():
    long_ones, seen = [], set()
    for p in firmware_files(".c"):
        rel = p.relative_to(REPO).as_posix()
        for name, line, length in functions(p.read_text(errors="replace")):
            seen.add((rel, name))
            if length > MAX_FUNC_LINES and (rel, name) not in ALLOWED_LONG_FUNCTIONS:
                long_ones.append(f"{rel}:{line} {name}: {length} lines")
    assert ("firmware/core/mixer_setup.c", "mixer_init_design") in seen, "scanner found nothing: broken"
    assert not long_ones, "functions over %d lines:\n%s" % (MAX_FUNC_LINES, "\n".join(long_ones))


def test_allowed_long_functions_are_in_app_and_still_long():
    """ALLOWED_LONG_FUNCTIONS holds only functions of firmware/app/ that are still too long."""
    lengths = {}
    for p in firmware_files(".c"):
        rel = p.relative_to(REPO).as_posix()
        for name, _, length in functions(p.read_text(errors="replace")):
            lengths[(rel, name)] = max(length, lengths.get((rel, name), 0))
    for rel, name in sorted(ALLOWED_LONG_FUNCTIONS):
        assert rel.startswith("firmware/app/"), (rel, name)
        assert lengths.get((rel, name), 0) > MAX_FUNC_LINES, \
            f"{rel} {name} is within {MAX_FUNC_LINES} lines (or gone): remove it from ALLOWED_LONG_FUNCTIONS"


def test_readme_is_a_guide_not_a_notebook():
    n = len((REPO / "README.md").read_text().splitlines())
    assert n <= README_MAX_LINES, f"README.md has {n} lines (at most {README_MAX_LINES})"

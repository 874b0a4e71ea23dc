"""Contract tests over the whole tree: the layout docs/architecture.md
describes holds (import direction, no cycles, module size) and every numeric
CLI option refuses what it cannot mean, with the bad-input exit status.

Imports are read from the source (AST), function-level ones included: a lazy
import hides a cycle from the interpreter, not from this test.
"""
from __future__ import annotations

import ast
import math
import re
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from workbench.cli import cli
from workbench.errors import EXIT_BAD_INPUT

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("solver", "flighttest", "workbench")
MAX_LINES = 600


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py"))}


MODULES = _modules()


def _imports(name: str, path: Path) -> set[str]:
    """The project modules `name` imports, anywhere in its body: `from a.b import c`
    names a.b.c when that is a module, else a.b."""
    is_pkg = path.name == "__init__.py"
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = name.split(".")
                anchor = anchor[:len(anchor) - node.level + (1 if is_pkg else 0)]
                base = ".".join(anchor + ([base] if base else []))
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base for a in node.names]
        else:
            continue
        out |= {t for t in targets if t in MODULES and t != name}
    return out


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def test_the_scan_sees_the_imports():
    # the scan itself must work, or the tests below pass on nothing
    assert "solver.units" in GRAPH["flighttest.schema"]
    assert "workbench.simulate" in GRAPH["workbench.validation"]
    assert len(MODULES) > 60


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycle_lazy_imports_included():
    assert _cycles(GRAPH) == []


def test_no_module_over_600_lines():
    long = {n: len(p.read_text().splitlines()) for n, p in MODULES.items()}
    assert {n: k for n, k in long.items() if k > MAX_LINES} == {}


def test_imports_flow_one_way():
    """solver knows nothing of logs or the workbench; flighttest takes only the
    unit factors from the solver (a leaf module of constants) and nothing from
    the workbench."""
    bad = []
    for name, deps in GRAPH.items():
        for d in deps:
            if name.startswith("solver") and not d.startswith("solver"):
                bad.append((name, d))
            if name.startswith("flighttest") and (d.startswith("workbench") or
                                                  (d.startswith("solver") and d != "solver.units")):
                bad.append((name, d))
    assert bad == []
    assert GRAPH["solver.units"] == set()


def test_architecture_doc_lists_every_module_and_no_other():
    """docs/architecture.md's package map names each module once, as its path."""
    doc = (ROOT / "docs" / "architecture.md").read_text()
    listed = set(re.findall(r"^- `((?:solver|flighttest|workbench)/[\w/]+\.py)`", doc, re.M))
    actual = {str(p.relative_to(ROOT)) for p in MODULES.values()}
    assert sorted(actual - listed) == [] and sorted(listed - actual) == []


# ---- every numeric CLI option refuses out-of-range values (exit 2) ----------------------

def _commands(group: click.Group, path=()):
    for name, cmd in group.commands.items():
        if isinstance(cmd, click.Group):
            yield from _commands(cmd, path + (name,))
        else:
            yield path + (name,), cmd


def _bad_values(t: click.ParamType) -> list[str]:
    """Values a numeric parameter type must refuse: beyond each bound, and for
    floats NaN and infinity, which pass a plain range check."""
    out = ["not-a-number"]
    lo, hi = getattr(t, "min", None), getattr(t, "max", None)
    step = 1 if isinstance(t, click.IntRange) else 1e-9
    if lo is not None:
        out.append(str(lo if getattr(t, "min_open", False) else lo - step))
    if hi is not None:
        out.append(str(hi if getattr(t, "max_open", False) else hi + step))
    if isinstance(t, (click.FloatRange, type(click.FLOAT))):
        out += ["nan", "inf", "-inf"]
    return out


def _numeric(t: click.ParamType) -> bool:
    return isinstance(t, (click.IntRange, click.FloatRange, type(click.INT), type(click.FLOAT)))


NUMERIC = [(" ".join(path), p) for path, cmd in _commands(cli) for p in cmd.params if _numeric(p.type)]

# a valid invocation of each command with numeric parameters; the value under test replaces its own
VALID = {
    "run": {"case_file": "case.toml", "--duration": "1"},
    "compare": {"log_file": "log.mcap", "--mcap": "out.mcap", "--duration": "1"},
    "properties lookup": {"hose": "hose", "temperature_f": "60", "element_length_m": "0.5"},
    "validate": {"targets": "case.toml", "--workers": "1"},
    "diagnose": {"--n": "1", "--seed": "1", "--n-elements": "20", "--workers": "1"},
}


def test_every_numeric_option_declares_a_range():
    # a bare int or float accepts anything: each option says what it can mean
    bare = [f"{cmd} {p.name}" for cmd, p in NUMERIC if not isinstance(p.type, (click.IntRange, click.FloatRange))]
    assert bare == []
    assert {cmd for cmd, _ in NUMERIC} <= set(VALID)


@pytest.mark.parametrize("cmd,param", NUMERIC, ids=[f"{c} {p.name}" for c, p in NUMERIC])
def test_numeric_option_rejects_out_of_range_with_exit_2(cmd, param):
    for bad in _bad_values(param.type):
        args, positional = cmd.split(), []
        for key, value in VALID[cmd].items():
            is_this = key == param.name or key in param.opts
            value = bad if is_this else value
            if key.startswith("--"):
                args += [key, value]
            else:
                positional.append(value)
        args += ["--", *positional]     # a negative bad value is an argument, not an option
        res = CliRunner().invoke(cli, args)
        assert res.exit_code == EXIT_BAD_INPUT, (args, res.output)
        label = param.opts[0] if param.opts[0].startswith("--") else param.human_readable_name
        assert label.lower() in res.output.lower(), (args, res.output)


def test_bad_values_cover_the_bounds():
    assert _bad_values(click.IntRange(2, 400)) == ["not-a-number", "1", "401"]
    vals = _bad_values(click.FloatRange(min=0, min_open=True))
    assert vals[:2] == ["not-a-number", "0"] and math.isnan(float(vals[2]))

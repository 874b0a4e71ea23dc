"""JUnit XML of a validation (one test per gate and per finding) and the
one-line messages of a failed gate and a changed finding."""
from __future__ import annotations

from xml.sax.saxutils import escape, quoteattr

from workbench.report.document import fmt


def junit_xml(results: dict) -> str:
    """One test case per gate and per finding (findings in their own class,
    `<case>.findings`), and one per case that failed to run."""
    cases = []
    fails = 0
    for c in results["cases"]:
        if c["error"]:
            fails += 1
            cases.append(f'<testcase classname={quoteattr(c["id"])} name="run">'
                         f'<failure message={quoteattr(c["error"])}/></testcase>')
        checks = ([(c["id"], g, gate_message(c["id"], g), g["source"]) for g in c["gates"]]
                  + [(f'{c["id"]}.findings', f, finding_message(c["id"], f), f["source"]) for f in c["findings"]])
        for classname, check, msg, source in checks:
            name = f'{check["variant"]}.{check["metric"]}'
            if check["passed"]:
                cases.append(f'<testcase classname={quoteattr(classname)} name={quoteattr(name)}/>')
            else:
                fails += 1
                cases.append(f'<testcase classname={quoteattr(classname)} name={quoteattr(name)}>'
                             f'<failure message={quoteattr(msg)}>{escape(source)}</failure></testcase>')
    return ('<?xml version="1.0" encoding="utf-8"?>\n'
            f'<testsuite name="workbench-validate" tests="{len(cases)}" failures="{fails}">\n'
            + "\n".join(cases) + "\n</testsuite>\n")


def gate_message(case_id: str, g: dict) -> str:
    op = "<=" if g["kind"] == "max" else ">="
    return (f"{case_id}: {g['metric']} ({g['variant']}) = {fmt(g['value'])}, "
            f"needs {op} {fmt(g['threshold'])}")


def finding_message(case_id: str, f: dict) -> str:
    return (f"{case_id}: finding {f['metric']} ({f['variant']}) = {fmt(f['value'])}, expected "
            f"{fmt(f['expected'])} +- {fmt(f['band'])} ({f['status']}: the reference model moved)")

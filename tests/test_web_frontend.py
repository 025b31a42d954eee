"""The web page's JavaScript, read from its source (no browser): every file in ``web/static`` is reached from the
page's entry points, every name imported is exported, no module imports one that imports it back, only ``store.js``
writes into the page's state, the browser tests read the page through its test hook, and no module is long."""

from __future__ import annotations

import re
from pathlib import Path

import sightplan

STATIC = Path(sightplan.__file__).parent / "web" / "static"
# served as /static/colours.js: the colouring the page shares with the HTML report
SHARED = {"colours.js": Path(sightplan.__file__).parent / "report" / "colours.js"}
TESTS = Path(__file__).parent
MAX_LINES = 600

# import … from './x.js', import './x.js', export … from './x.js', import('./x.js')
RELATIVE = re.compile(r"""(?:\bfrom|\bimport)\s*\(?\s*['"](\./[\w.-]+\.js)['"]""")
NAMED = re.compile(r"""\bimport\s*\{([^}]*)\}\s*from\s*['"]\./([\w.-]+\.js)['"]""")
EXPORTED = re.compile(r"\bexport\s+(?:async\s+)?(?:function\*?|const|let|var|class)\s+([\w$]+)")
EXPORT_LIST = re.compile(r"\bexport\s*\{([^}]*)\}")
SCRIPT = re.compile(r"""<script\b[^>]*\bsrc=['"]/static/([\w.-]+\.js)['"]""")

# writes into the state: state.x = …, state.x.y += …, state.x[k] = …, ++state.x, state.x.push(…), delete state.x,
# Object.assign(state, …); the old name S too
TARGET = r"\b(?:state|S)\.[\w$]+(?:\.[\w$]+|\[[^\]\n]*\])*"
WRITES = [
    re.compile(TARGET + r"\s*(?:[-+*/%&|^]|\*\*|<<|>>>?|&&|\|\||\?\?)?=(?![=>])"),
    re.compile(TARGET + r"\s*(?:\+\+|--)"),
    re.compile(r"(?:\+\+|--)\s*" + TARGET),
    re.compile(TARGET + r"\.(?:push|pop|shift|unshift|splice|sort|reverse|fill|copyWithin|add|delete|clear)\("),
    re.compile(r"\bdelete\s+" + TARGET),
    re.compile(r"\bObject\.assign\(\s*(?:state|S)\b"),
    re.compile(r"\b(?:moveFrame|turnFrame|deleteFrame|copyFrame)\(\s*(?:state|S)\."),  # planedit.js edits in place
]


def modules() -> dict[str, str]:
    return {p.name: p.read_text(encoding="utf-8") for p in sorted(STATIC.glob("*.js"))}


def source(name: str) -> str:
    path = SHARED[name] if name in SHARED else STATIC / name
    return path.read_text(encoding="utf-8")


def code(text: str) -> str:
    """The source without its comments (block comments, and line comments outside strings and regular expressions
    are close enough: the page writes no // inside either)."""
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return "\n".join(re.sub(r"(^|\s)//.*$", "", line) for line in text.splitlines())


def relative_imports(name: str) -> list[str]:
    return RELATIVE.findall(code(source(name)))


def entry_points() -> list[str]:
    return [m for page in ("index.html", "docs.html") for m in SCRIPT.findall((STATIC / page).read_text(encoding="utf-8"))]


def test_every_module_is_reached_from_the_pages_entry_points():
    entries = entry_points()
    assert "app.js" in entries, entries
    seen, todo = set(), list(entries)
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        for target in relative_imports(name):
            target = target.removeprefix("./")
            assert (STATIC / target).is_file() or target in SHARED, f"{name} imports {target}, which is not served"
            todo.append(target)
    # the generated types (python -m sightplan.web.jstypes) are named in JSDoc comments only: reached when a loaded
    # module names them
    named = {"api-types.js"} if any("import('./api-types.js')" in source(m) for m in seen if m not in SHARED) else set()
    unreached = set(modules()) - seen - named
    assert not unreached, f"not loaded by the page (nor imported by a module it loads): {sorted(unreached)}"


def test_every_name_imported_is_exported():
    def exports(name: str) -> set[str]:
        text = code(source(name))
        names = set(EXPORTED.findall(text))
        for group in EXPORT_LIST.findall(text):
            names |= {n.split(" as ")[-1].strip() for n in group.split(",") if n.strip()}
        return names

    missing = [f"{name} imports {n} from {target}" for name in modules()
               for group, target in NAMED.findall(code(source(name)))
               for n in (x.split(" as ")[0].strip() for x in group.split(",")) if n and n not in exports(target)]
    assert not missing, "\n".join(missing)


def test_no_module_imports_one_that_imports_it_back():
    edges = {name: {t.removeprefix("./") for t in relative_imports(name)} for name in [*modules(), *SHARED]}

    def reaches(start: str, goal: str) -> bool:
        seen, todo = set(), list(edges[start])
        while todo:
            n = todo.pop()
            if n == goal:
                return True
            if n not in seen:
                seen.add(n)
                todo.extend(edges.get(n, ()))
        return False

    cycles = sorted({" ↔ ".join(sorted((a, b))) for a in edges for b in edges[a] if reaches(b, a)})
    assert not cycles, "import cycles (an area hands what it needs of another as a callback to its bind…()):\n" \
        + "\n".join(cycles)


def test_only_the_store_writes_into_the_state():
    found = [f"{name}:{k}: {line.strip()}" for name, text in modules().items() if name != "store.js"
             for k, line in enumerate(code(text).splitlines(), 1) if any(p.search(line) for p in WRITES)]
    assert not found, "state changes go through set(…) of store.js:\n" + "\n".join(found)


def test_the_write_patterns_catch_writes_and_pass_reads():
    writes = ["state.plan = p", "state.bounds[state.metric] = [lo, hi]", "state.plans.push(plan)", "S.dirty = true",
              "state.realityHidden.add(3)", "delete state.bounds.ssd", "Object.assign(state, patch)", "state.n += 1",
              "moveFrame(state.draft, i, d)", "state.selectedFrame++"]
    reads = ["if (state.plan === p) x = 1", "const a = state.bounds[state.metric] || b", "x = state.dirty ? 1 : 2",
             "state.plans.find((p) => p.id === id)", "(e) => state.colourer.colourOf(e) >= 0", "set({ dirty: true })",
             "state.realityHidden.has(r.id)", "moveFrame(draft, i, d)"]
    assert [w for w in writes if not any(p.search(w) for p in WRITES)] == []
    assert [r for r in reads if any(p.search(r) for p in WRITES)] == []


def test_the_browser_tests_read_the_page_through_its_test_hook():
    hook = [name for name, text in modules().items() if "window.sightplanTest =" in code(text)]
    assert hook == ["testhook.js"], hook
    old = [f"{p.name}:{k}" for p in TESTS.glob("*.py") if p.name != Path(__file__).name
           for k, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1) if re.search(r"window\.sightplan\.", line)]
    assert not old, f"reads of the page's internals (window.sightplan.…) instead of window.sightplanTest: {old}"


def test_no_module_is_long():
    long = {name: n for name, text in modules().items()
            if name != "api-types.js"  # generated from the OpenAPI document: as long as the API
            and (n := len(text.splitlines())) > MAX_LINES}
    assert not long, f"split these (at most {MAX_LINES} lines a module): {long}"

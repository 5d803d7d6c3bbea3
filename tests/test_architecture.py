"""The architecture of docs/architecture.md, checked: one-way layers, no import cycles, no
private names taken across package levels, and no references to files outside the repository.

The layers are an import-linter contract (``[tool.importlinter]`` in pyproject.toml, also run as
``lint-imports``); the cycle and private-name rules are checked a second time here by a plain
scan of the source (every ``import`` statement, at module level or inside functions, relative or
absolute), so the two must agree.  Each checker is also run on a copy of the package with a
deliberate fault, to show that it can fail.
"""

import ast
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "gfgpu"


# --------------------------------------------------------------------------------------
# the scan: modules and the imports between them
# --------------------------------------------------------------------------------------
def find_modules(root, package=PACKAGE):
    """``{module name: (path, is_package)}`` for every ``.py`` file of ``package`` under ``root``."""
    modules = {}
    for path in sorted((Path(root) / package).rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        parts = path.relative_to(root).with_suffix("").parts
        is_package = parts[-1] == "__init__"
        modules[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return modules


def _resolve(module, is_package, level, name):
    """The absolute module named by ``from <level dots><name> import ...`` inside ``module``."""
    if level == 0:
        return name
    base = module.split(".") if is_package else module.split(".")[:-1]
    if level - 1 > len(base) - 1:
        raise ImportError(f"relative import beyond the top-level package in {module}")
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def _inside(name, package=PACKAGE):
    return name == package or name.startswith(package + ".")


def _longest_module(name, modules):
    """``name`` or its longest prefix that is a module (``import a.b.c`` where c is a function)."""
    parts = name.split(".")
    while parts and ".".join(parts) not in modules:
        parts.pop()
    return ".".join(parts) if parts else None


def scan_imports(root, package=PACKAGE):
    """Every import of a ``package`` module by a ``package`` module.

    Returns ``{importer: [(imported module, name or None, line), ...]}``: ``from X import y``
    imports the module ``X.y`` where that is a module, else the name ``y`` of module ``X``;
    ``import X.Y`` imports module ``X.Y``.  Imports inside functions, classes, ``if`` and
    ``try`` blocks count like module-level ones.
    """
    modules = find_modules(root, package)
    found = {}
    for module, (path, is_package) in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        edges = found.setdefault(module, [])
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if _inside(alias.name, package):
                        target = _longest_module(alias.name, modules)
                        if target:
                            edges.append((target, None, node.lineno))
            elif isinstance(node, ast.ImportFrom):
                base = _resolve(module, is_package, node.level, node.module or "")
                if not _inside(base, package):
                    continue
                for alias in node.names:
                    sub = f"{base}.{alias.name}"
                    if sub in modules:
                        edges.append((sub, None, node.lineno))
                    else:
                        target = _longest_module(base, modules)
                        if target:
                            edges.append((target, alias.name, node.lineno))
    return modules, found


def import_graph(root, package=PACKAGE):
    """``{importer: {imported: first line}}`` between modules of ``package`` (self-imports dropped)."""
    _, found = scan_imports(root, package)
    graph = {m: {} for m in found}
    for importer, edges in found.items():
        for target, _, line in edges:
            if target != importer:
                graph[importer].setdefault(target, line)
    return graph


def import_cycles(graph):
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, on_stack, stack, components = {}, {}, set(), [], []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
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
                components.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(components)


def _cycle_path(graph, component):
    """One closed path through ``component``, as ``a:line -> b:line -> ... -> a``."""
    members = set(component)
    start = component[0]
    path, seen = [start], {start}
    while True:
        nxt = sorted(w for w in graph[path[-1]] if w in members)
        back = [w for w in nxt if w == start]
        new = [w for w in nxt if w not in seen]
        if back and len(path) > 1 or not new:
            step = back[0] if back else nxt[0]
            return " -> ".join(f"{a} (line {graph[a][b]})" for a, b in zip(path, path[1:] + [step])) + \
                f" -> {step}"
        path.append(new[0])
        seen.add(new[0])


def _is_private(name):
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _package_of(module, modules):
    return module if modules[module][1] else module.rpartition(".")[0]


#: packages whose private names every layer may use: the core, and the version module (which
#: holds only ``__version__``, read by setuptools and ``gfgpu --version``)
SHARED = (f"{PACKAGE}._core", f"{PACKAGE}._version")


def private_imports(root, package=PACKAGE, shared=SHARED):
    """Private names (``_x``, not ``__x__``) one module takes from a module of another package.

    A private name may be used within the package that defines it (the modules of one folder)
    and from the ``shared`` modules (``gfgpu._core``); anything else is listed as
    ``"importer:line: what"``.  Checked: ``from X import _y``, ``import X._y``, private
    modules on the way (``from X._y import z``) and attribute access ``X._y`` on a name bound to
    a ``package`` module by an import.
    """
    modules, found = scan_imports(root, package)

    def allowed(importer, owner, name):
        target = f"{owner}.{name}"
        return _package_of(importer, modules) == _package_of(owner, modules) or any(
            t == s or t.startswith(s + ".") for s in shared for t in (owner, target))

    bad = []

    def check(importer, owner, name, line, what):
        if _is_private(name) and not allowed(importer, owner, name):
            bad.append(f"{importer}:{line}: {what}")

    for importer, edges in found.items():
        for target, name, line in edges:
            parts = target.split(".")
            for i in range(1, len(parts)):          # private modules on the way to the target
                check(importer, ".".join(parts[:i]), parts[i], line, f"imports {target}")
            if name is not None:
                check(importer, target, name, line, f"imports {name} from {target}")
        # attribute access X._y on a module X bound by an import
        path, is_package = modules[importer]
        tree = ast.parse(path.read_text(encoding="utf-8"))
        bound = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if _inside(alias.name, package):
                        if alias.asname:
                            bound[alias.asname] = _longest_module(alias.name, modules)
                        else:
                            bound[alias.name.split(".")[0]] = alias.name.split(".")[0]
            elif isinstance(node, ast.ImportFrom):
                base = _resolve(importer, is_package, node.level, node.module or "")
                for alias in node.names:
                    if f"{base}.{alias.name}" in modules:
                        bound[alias.asname or alias.name] = f"{base}.{alias.name}"
        for node in ast.walk(tree):
            if not isinstance(node, ast.Attribute) or not _is_private(node.attr):
                continue
            chain, value = [], node.value
            while isinstance(value, ast.Attribute):
                chain.append(value.attr)
                value = value.value
            if not isinstance(value, ast.Name) or value.id not in bound or bound[value.id] is None:
                continue
            owner = bound[value.id]
            for attr in reversed(chain):
                if f"{owner}.{attr}" not in modules:
                    break                       # an attribute of an object, not a module
                owner = f"{owner}.{attr}"
            else:
                check(importer, owner, node.attr, node.lineno, f"uses {owner}.{node.attr}")
    return sorted(set(bad))


# written in pieces, so that this file does not match itself
OUTSIDE_REFERENCES = re.compile("|".join([
    r"\.\./" + "shared", "DESIGN" + r"\.md", "DESIGN" + r"\s*§", "science" + r"\.md", "science" + r" notes",
]), re.IGNORECASE)


def outside_references(root, places=("gfgpu", "tests", "benchmarks", "docs", "README.md")):
    """``"path:line: text"`` for every line that cites a file outside the repository."""
    hits = []
    for place in places:
        top = Path(root) / place
        files = [top] if top.is_file() else sorted(p for p in top.rglob("*") if p.is_file())
        for path in files:
            if "__pycache__" in path.parts:
                continue
            try:
                text = path.read_bytes().decode("utf-8")
            except UnicodeDecodeError:
                continue                    # images and other binary files
            if "\0" in text:
                continue
            for number, line in enumerate(text.splitlines(), 1):
                if OUTSIDE_REFERENCES.search(line):
                    hits.append(f"{path.relative_to(root)}:{number}: {line.strip()}")
    return hits


def run_import_linter(root):
    """``(exit status, report)`` of ``lint-imports`` on the package and pyproject.toml in ``root``
    (import-linter is in the ``test`` extra: where it is missing, this fails rather than skips)."""
    code = ("import sys; from importlinter.cli import lint_imports; "
            "sys.exit(lint_imports(no_cache=True, no_logo=True))")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    res = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, env=env)
    return res.returncode, res.stdout + res.stderr


# --------------------------------------------------------------------------------------
# the rules, on this repository
# --------------------------------------------------------------------------------------
def test_import_contracts_are_kept():
    status, report = run_import_linter(ROOT)
    assert status == 0, report
    assert "0 broken" in report and " KEPT" in report, report


def test_no_import_cycles():
    graph = import_graph(ROOT)
    assert len(graph) > 50          # the scan sees the package
    cycles = import_cycles(graph)
    assert not cycles, "import cycles:\n" + "\n".join(_cycle_path(graph, c) for c in cycles)


def test_the_scan_and_import_linter_see_the_same_imports():
    # import-linter's graph builder (the test extra installs both): imported here, not at module level,
    # so that a machine without it (the device machine, whose device runs skip host-only tests) still
    # collects this file; where the extra is installed a missing grimp fails, as import-linter does
    import grimp
    code = ("import grimp, json; g = grimp.build_graph('gfgpu', cache_dir=None); "
            "print(json.dumps(sorted([m, i] for m in g.modules for i in g.find_modules_directly_imported_by(m))))")
    res = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    theirs = {tuple(e) for e in json.loads(res.stdout)}
    ours = {(a, b) for a, targets in import_graph(ROOT).items() for b in targets}
    assert ours == theirs, (f"only the scan: {sorted(ours - theirs)}\nonly grimp {grimp.__version__}: "
                            f"{sorted(theirs - ours)}")


def test_no_private_names_across_package_levels():
    bad = private_imports(ROOT)
    assert not bad, "private names used outside their package (share them from gfgpu._core, or make " \
                    "them public):\n" + "\n".join(bad)


#: the applications, whose code (math, numpy specification, device code) lives in their own package
FEATURES = ("stereo", "motion", "edges", "shading")


def engine_share(root, package=PACKAGE):
    """``(lines of gfgpu/backends, lines of the package, files of backends named after a feature)``:
    the backends hold the engine only (.py and .cl files counted)."""
    top = Path(root) / package
    files = [p for p in top.rglob("*") if p.suffix in (".py", ".cl") and "__pycache__" not in p.parts]
    lines = {p: len(p.read_text(encoding="utf-8").splitlines()) for p in files}
    engine = [p for p in files if (top / "backends") in p.parents]
    named = sorted(str(p.relative_to(root)) for p in engine if any(f in p.stem for f in FEATURES))
    return sum(lines[p] for p in engine), sum(lines.values()), named


def test_the_backends_hold_only_the_engine():
    engine, total, named = engine_share(ROOT)
    assert not named, f"feature code in gfgpu/backends (move it into the feature's package): {named}"
    assert engine <= 0.2 * total, f"gfgpu/backends holds {engine} of {total} lines (at most 20 %)"


def documented_paths(text):
    """Paths of the repository that a page names in backticks (``gfgpu/...``, ``tests/...``),
    placeholders like ``gfgpu/<feature>/`` left out."""
    found = re.findall(r"`((?:gfgpu|tests|benchmarks|docs)/[^`\s]*)`", text)
    return sorted({p.rstrip("/") for p in found if "<" not in p and "*" not in p})


def test_the_architecture_page_names_what_exists():
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    missing = [p for p in documented_paths(text) if not (ROOT / p).exists()]
    assert not missing, f"docs/architecture.md names paths that do not exist: {missing}"
    # importing a feature's kernels.py registers its kernels
    import gfgpu.edges.kernels
    import gfgpu.motion.kernels
    import gfgpu.stereo.kernels  # noqa: F401
    from gfgpu.backends import fused
    # the rows of the fused-kernel table: | `feature.name` | feature | ... |
    table = {name for name, feature in re.findall(r"^\| `((\w+)\.\w+)` \| \2 \|", text, re.MULTILINE)}
    assert table == set(fused.registered()), (f"fused-kernel table of docs/architecture.md: missing "
                                             f"{sorted(set(fused.registered()) - table)}, "
                                             f"not registered {sorted(table - set(fused.registered()))}")


def test_documented_paths_are_found():
    text = "see `gfgpu/stereo/spec.py` and `tests/stereo/`, not `gfgpu/<feature>/` or `x/y`"
    assert documented_paths(text) == ["gfgpu/stereo/spec.py", "tests/stereo"]


def test_no_references_to_files_outside_the_repository():
    hits = outside_references(ROOT)
    assert not hits, f"{len(hits)} line(s) cite files that are not in the repository:\n" + "\n".join(hits)


# --------------------------------------------------------------------------------------
# each checker fails where it should: a copy of the package with deliberate faults
# --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def faulty_copy(tmp_path_factory):
    """A copy of gfgpu and pyproject.toml with one fault of each kind."""
    root = tmp_path_factory.mktemp("faulty")
    shutil.copytree(ROOT / PACKAGE, root / PACKAGE, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", root / "pyproject.toml")
    pkg = root / PACKAGE
    # an upward, function-level, relative import from the core into the backends: a cycle
    # _core.lines -> backends.base -> ... and a broken layer
    with open(pkg / "_core" / "lines.py", "a") as f:
        f.write("\n\ndef _upward():\n    from ..backends import base\n    return base\n")
    with open(pkg / "backends" / "base.py", "a") as f:
        f.write("\n\nfrom gfgpu._core import lines as _lines  # noqa: E402\n")
    # a private name across package levels, imported and by attribute
    (pkg / "stereo" / "peek.py").write_text(
        "from ..filters import _private_thing\nfrom .. import greens\n\n\n"
        "def f():\n    return _private_thing, greens._hidden\n")
    # a feature's device module imported directly (not through the registry), and Warp imported
    # by a module that is not device code
    (pkg / "motion" / "eager.py").write_text("from . import _warp\n\n\ndef f():\n    import warp\n    return warp\n")
    (pkg / "notes.md").write_text("see " + "DESIGN" + " § 4\n")
    return root


def test_the_checkers_catch_faults(faulty_copy):
    graph = import_graph(faulty_copy)
    cycles = import_cycles(graph)
    assert any({"gfgpu._core.lines", "gfgpu.backends.base"} <= set(c) for c in cycles), cycles
    bad = private_imports(faulty_copy)
    assert any("gfgpu.stereo.peek" in b and "_private_thing" in b for b in bad), bad
    assert any("gfgpu.greens._hidden" in b for b in bad), bad
    (faulty_copy / PACKAGE / "backends" / "opencl" / "stereo.cl").write_text("__kernel void k() {}\n" * 10**4)
    engine, total, named = engine_share(faulty_copy)
    assert named == [os.path.join(PACKAGE, "backends", "opencl", "stereo.cl")] and engine > 0.2 * total
    hits = outside_references(faulty_copy, places=("gfgpu",))
    assert f"{os.path.join('gfgpu', 'notes.md')}:1: see {'DESIGN'} § 4" in hits, hits


def test_import_linter_catches_faults(faulty_copy):
    status, report = run_import_linter(faulty_copy)
    assert status != 0, report
    assert "BROKEN" in report and "gfgpu._core.lines -> gfgpu.backends.base" in report, report
    assert "gfgpu.motion.eager -> gfgpu.motion._warp" in report, report
    assert "gfgpu.motion.eager -> warp" in report, report


def test_the_scan_resolves_every_kind_of_import(tmp_path):
    pkg = tmp_path / "gfgpu"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("from . import a\n")
    (pkg / "a.py").write_text("import gfgpu.sub.b as bee\nfrom .sub import c\n")
    (pkg / "sub" / "__init__.py").write_text("from .b import x\n")
    (pkg / "sub" / "b.py").write_text("x = 1\n\n\ndef f():\n    from .. import a\n    return a\n")
    (pkg / "sub" / "c.py").write_text("import gfgpu.sub.b.x\nif False:\n    from ..sub import b\n")
    graph = import_graph(tmp_path)
    assert graph == {
        "gfgpu": {"gfgpu.a": 1},
        "gfgpu.a": {"gfgpu.sub.b": 1, "gfgpu.sub.c": 2},
        "gfgpu.sub": {"gfgpu.sub.b": 1},
        "gfgpu.sub.b": {"gfgpu.a": 5},
        "gfgpu.sub.c": {"gfgpu.sub.b": 1},
    }
    assert import_cycles(graph) == [["gfgpu.a", "gfgpu.sub.b", "gfgpu.sub.c"]]

"""Module graphs and their cycles, for tests/test_architecture.py.

:func:`cycles` finds the strongly connected components of more than one module of a
directed graph (Tarjan's algorithm): every group of modules that reach each other through
their imports. :func:`rust_module_graph` reads the module graph of a Rust crate from its
sources, :func:`script_graph` that of a folder of Python scripts (``scripts/``, ``benches/``,
``tests/``, ``examples/``: files that import each other by their bare names, being each
other's ``sys.path`` entry); the package's graph comes from grimp (import-linter's graph
builder).

**What is a use, in Rust.** Module ``a`` uses module ``b`` when ``a``'s code (its file and the
inline ``mod x { ... }`` blocks in it, test modules included; comments and string literals
left out) names a path into ``b``: in a ``use`` declaration (``use crate::b::X;``,
``use super::{b::X, c::Y};``) or in an expression or type (``crate::b::f()``,
``super::X``, ``child::f()`` for a child module it declares). The path is resolved as Rust
does (``crate``, ``self``, ``super``, a declared child) to the deepest module it names, and
``a`` uses that module. When the item is one that module brings in with a ``use`` (a
re-export, ``pub use x::Item;``), ``a`` uses the module it comes from too: a path through a
re-export names both, as ``from p import X`` in Python imports ``p`` whatever ``p`` got
``X`` from. Two things are **not** uses: a parent declaring ``mod child;``, and a module
re-exporting (``pub use``) an item of its own descendant, because neither runs any of the
child's code in the parent. Everything else, including a child using its parent
(``super::X``, an item of the parent's own or one it re-exports) while the parent calls the
child, is.

**What is an import, in a folder of scripts.** Script ``a`` imports script ``b`` (``b.py`` in
the same folder) when ``a`` has ``import b``, ``import b.x``, ``from b import ...`` or
``importlib.import_module("b")`` anywhere: at the top, inside a function (a "lazy" import),
under ``if TYPE_CHECKING:`` or in a ``try``. A file loaded by its path (``runpy.run_path``,
``importlib.util.spec_from_file_location``) is not followed.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterable, Mapping
from pathlib import Path

Module = tuple[str, ...]

_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
# a string literal, or a one-character char literal ('a', '\n'), not a lifetime ('a)
_STRING = re.compile(r'b?"(?:\\.|[^"\\])*"|\'(?:\\.|[^\'\\])\'')
_INLINE_MOD = re.compile(r"\bmod\s+(\w+)\s*\{")
_USE = re.compile(r"\b(pub(?:\([^)]*\))?\s+)?use\s+([^;]+);")
_PATH = re.compile(r"(?<![\w:])(\w+(?:\s*::\s*\w+)+)")


def cycles(graph: Mapping[str, Iterable[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node, each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
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
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


def _file_modules(src: Path) -> dict[Module, Path]:
    mods = {}
    for f in sorted(src.rglob("*.rs")):
        parts = f.relative_to(src).with_suffix("").parts
        if parts in (("lib",), ("main",)):
            parts = ()
        elif parts[-1] == "mod":
            parts = parts[:-1]
        mods[parts] = f
    return mods


def _expand(tree: str) -> list[tuple[str, str]]:
    """The paths of a use tree and the names they bind: ``a::{b, c::{d, e as f}}`` gives
    (a::b, b), (a::c::d, d), (a::c::e, f)."""
    tree = re.sub(r"\s+", " ", tree).strip()
    if "{" not in tree:
        path, _, alias = tree.partition(" as ")
        path = path.strip()
        return [(path, alias.strip() or path.rsplit("::", 1)[-1].strip())]
    i = tree.index("{")
    head, body = tree[:i], tree[i + 1 : tree.rindex("}")]
    items, cur, depth = [], "", 0
    for ch in body:
        if ch == "," and depth == 0:
            items.append(cur)
            cur = ""
            continue
        depth += ch == "{"
        depth -= ch == "}"
        cur += ch
    items.append(cur)
    return [(head + x, b) for it in items if it.strip() for x, b in _expand(it.strip())]


def _inline_blocks(text: str) -> list[tuple[int, int, str]]:
    """(start, end, name) of the inline ``mod name { ... }`` blocks of a file."""
    out = []
    for m in _INLINE_MOD.finditer(text):
        depth, i = 1, m.end()
        while depth and i < len(text):
            depth += text[i] == "{"
            depth -= text[i] == "}"
            i += 1
        out.append((m.start(), i, m.group(1)))
    return out


def rust_module_graph(src: Path) -> dict[str, set[str]]:
    """Module → the modules it uses (module docstring), for the crate whose ``src`` is given.

    Modules are named by path from the crate root (``solve::fast``); the root is ``crate``.
    """
    files = _file_modules(src)
    texts = {
        m: _STRING.sub('""', _COMMENT.sub(" ", f.read_text(encoding="utf-8")))
        for m, f in files.items()
    }
    blocks = {m: _inline_blocks(t) for m, t in texts.items()}
    known = set(files)
    for m, bl in blocks.items():
        for s, e, name in bl:
            known.add(m + tuple(n for s2, e2, n in bl if s2 < s and e <= e2) + (name,))

    def context(m: Module, pos: int) -> Module:
        return m + tuple(n for s, e, n in blocks[m] if s <= pos < e)

    def start(ctx: Module, segs: list[str]) -> tuple[Module | None, list[str]]:
        if segs[0] == "crate":
            return (), segs[1:]
        if segs[0] in ("super", "self"):
            base = ctx
            while segs and segs[0] in ("super", "self"):
                base = base[:-1] if segs[0] == "super" else base
                segs = segs[1:]
            return base, segs
        if (*ctx, segs[0]) in known:  # a child module the code names directly
            return ctx, segs
        return None, segs  # another crate (std::, rayon::) or a name brought in by a use

    reexports: dict[tuple[Module, str], Module] = {}

    def resolve(ctx: Module, segs: list[str]) -> tuple[Module, Module] | None:
        """The module a path names and the module its item comes from (the same module
        unless the item is one that the named module brings in with a ``use``)."""
        base, rest = start(ctx, segs)
        if base is None:
            return None
        while rest and (*base, rest[0]) in known:
            base, rest = (*base, rest[0]), rest[1:]
        if rest and (base, rest[0]) in reexports:
            return base, reexports[(base, rest[0])]
        return base, base

    # (file, context, path, the name a use binds or None, whether it is a pub use)
    uses: list[tuple[Module, Module, list[str], str | None, bool]] = []
    for m, text in texts.items():
        spans = []
        for u in _USE.finditer(text):
            spans.append((u.start(), u.end()))
            for p, bound in _expand(u.group(2)):
                segs = [s.strip() for s in p.split("::") if s.strip()]
                name = None if bound in ("*", "self") else bound
                uses.append((m, context(m, u.start()), segs, name, bool(u.group(1))))
        for p in _PATH.finditer(text):
            if not any(s <= p.start() < e for s, e in spans):
                segs = [s.strip() for s in p.group(1).split("::")]
                uses.append((m, context(m, p.start()), segs, None, False))

    # A name a module brings in with `use` (pub or not: its children see it too) stands for
    # the module the item comes from; imports of imports settle in a few passes.
    for _ in range(3):
        for _m, ctx, segs, name, _pub in uses:
            if name is not None:
                found = resolve(ctx, segs)
                if found is not None:
                    reexports[(ctx, name)] = found[1]

    def file_of(mod: Module) -> Module:
        while mod not in files:
            mod = mod[:-1]
        return mod

    graph: dict[Module, set[Module]] = {m: set() for m in files}
    for m, ctx, segs, _name, pub in uses:
        found = resolve(ctx, segs)
        if found is None:
            continue
        for target in {file_of(t) for t in found}:
            if target == m:
                continue  # itself
            if pub and target[: len(m)] == m:
                continue  # a module re-exporting its own descendant's item
            graph[m].add(target)
    name = {m: "::".join(m) or "crate" for m in files}
    return {name[m]: {name[t] for t in ts} for m, ts in graph.items()}


def script_graph(folder: Path) -> dict[str, set[str]]:
    """Script → the scripts of the same folder it imports (module docstring), by file stem."""
    names = {f.stem for f in folder.glob("*.py")}
    graph: dict[str, set[str]] = {}
    for f in sorted(folder.glob("*.py")):
        found: set[str] = set()
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"), filename=str(f))):
            if isinstance(node, ast.Import):
                found |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found.add(node.module.split(".")[0])
            elif (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute | ast.Name)
                and getattr(node.func, "attr", getattr(node.func, "id", "")) == "import_module"
                and node.args
                and isinstance(node.args[0], ast.Constant)
                and isinstance(node.args[0].value, str)
            ):
                found.add(node.args[0].value.split(".")[0])
        graph[f.stem] = (found & names) - {f.stem}
    return graph

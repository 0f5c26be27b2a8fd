#!/usr/bin/env python3
"""The import graph of src/ (docs/design.md §5), between files and between modules: fails on
a cycle or on an import from a lower layer to a higher one.

Between modules: the files of a module's subtree count as the module. Two sibling modules
(children of one parent, the crate's top-level modules included) that import each other,
directly or around a cycle of siblings, are a cycle, and so is a file that imports the
`mod.rs` (or the root file) of a module it lies in: the parent declares the child, so the
child importing its parent is a loop a reader sees, though no file imports itself.

An edge A -> B is drawn when code in file A names an item that lives in file B: `use` lists
and inline paths starting with `crate::`, `super::`, `self::`, a child module of A's module,
or a module alias A brought in with `use`. Paths are resolved module by module to the file
that defines the item; a `pub use` re-export is followed to the file it re-exports from (the
re-export itself is no edge). Comments, string literals and `#[cfg(test)]` items are not
read: unit tests may use anything.

    python3 .ci/imports.py           # check; exit 1 on a cycle or a layer violation
    python3 .ci/imports.py --edges   # print every edge (files, then modules) as well
"""
import re
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parent.parent / "src"

# Layers, lowest first (docs/design.md §5). A file may import from its own layer or lower
# ones. The first matching prefix (module path as `a::b`) decides a file's layer.
LAYERS = [
    ("support", ["error", "units", "memory", "sparse", "dense", "pool", "lsq", "snapshots",
                 "engine::cluster", "grid", "random"]),
    ("model", ["model", "scene", "coupling", "io::atomic", "io::binary", "io::file",
               "io::matrix_market", "io::npz", "io::import", "io::op4", "io::text", "io"]),
    ("pencil", ["pencil", "proportional", "rigid", "fe", "coupled"]),
    ("factor", ["factor"]),
    ("body", ["body", "io::model_dir", "io::joints"]),
    ("engine", ["sweep", "engine", "frf", "eigen", "shifted_space", "linearized_space"]),
    ("reduce", ["reduce"]),
    ("metrics", ["metrics"]),
    ("output", ["io::rom_dir", "io::exudyn", "io::op4::rom", "io::dmig", "io::mbdyn",
                "io::sid", "report"]),
    ("cli", ["cli", "main", "lib"]),
]


def layer_of(module):
    best = None
    for rank, (_, prefixes) in enumerate(LAYERS):
        for p in prefixes:
            if module == p or module.startswith(p + "::"):
                if best is None or len(p) > best[1]:
                    best = (rank, len(p))
    return None if best is None else best[0]


def strip(text):
    """Source without comments, strings and char literals (kept as blanks, lines kept)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            depth, i = 1, i + 2
            while i < n and depth:
                if text.startswith("/*", i):
                    depth, i = depth + 1, i + 2
                elif text.startswith("*/", i):
                    depth, i = depth - 1, i + 2
                else:
                    out.append("\n" if text[i] == "\n" else "")
                    i += 1
        elif c == "r" and re.match(r'r#*"', text[i:i + 20]) and not (i and (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'r(#*)"', text[i:])
            end = text.find('"' + m.group(1), i + len(m.group(0)))
            out.append('""' + "\n" * text.count("\n", i, end))
            i = end + 1 + len(m.group(1))
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append('""' + "\n" * text.count("\n", i, j))
            i = j + 1
        elif c == "'" and re.match(r"'(\\.|[^\\'])'", text[i:i + 4]) or text.startswith("'\\u{", i):
            j = text.find("'", i + 2 if text[i + 1] != "\\" else i + 3)
            out.append("' '")
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def drop_test_items(code):
    """Removes items marked #[cfg(test)] (a `mod tests { … }` block or one item)."""
    while True:
        m = re.search(r"#\[cfg\(test\)\]", code)
        if not m:
            return code
        j = m.end()
        depth, k = 0, j
        while k < len(code):
            if code[k] == "{":
                depth += 1
            elif code[k] == "}":
                depth -= 1
                if depth == 0:
                    k += 1
                    break
            elif code[k] == ";" and depth == 0:
                k += 1
                break
            k += 1
        code = code[:m.start()] + "\n" * code.count("\n", m.start(), k) + code[k:]


class Module:
    def __init__(self, path, file):
        self.path = path  # ["factor", "ldlt"]
        self.file = file
        self.children = {}
        self.code = drop_test_items(strip(file.read_text()))
        # items re-exported with `pub use` (any visibility): name -> full path segments
        self.reexports = {}
        self.private_uses = []  # (segments, alias) of non-pub use lines

    @property
    def name(self):
        return "::".join(self.path) or "lib"


def module_files():
    modules = {}
    declared = re.compile(r"^\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+(\w+)\s*;", re.M)

    def load(path, file, children_dir, children_path=None):
        """Loads `file` as module `path` and, recursively, the modules it declares; their paths
        start from `children_path` (the binary's modules are named from the root)."""
        mod = Module(path, file)
        modules[tuple(path)] = mod
        base = path if children_path is None else children_path
        for m in declared.finditer(mod.code):
            child = m.group(1)
            for cand in (children_dir / f"{child}.rs", children_dir / child / "mod.rs"):
                if cand.exists():
                    sub_dir = cand.parent if cand.name == "mod.rs" else children_dir / child
                    mod.children[child] = load(base + [child], cand, sub_dir)
                    break
        return mod

    load([], SRC / "lib.rs", SRC)
    if (SRC / "main.rs").exists():
        load(["main"], SRC / "main.rs", SRC, children_path=[])
    return modules


def use_trees(code):
    """Yields (is_pub, [segments..], alias) for every leaf of every `use` declaration."""
    for m in re.finditer(r"(?:^|[;{}\s])((?:pub(?:\([^)]*\))?\s+)?)use\s+([^;]+);", code):
        is_pub = m.group(1).strip().startswith("pub")
        for segs, alias in expand(m.group(2).replace("\n", " ").strip()):
            yield is_pub, segs, alias


def expand(tree, prefix=()):
    tree = tree.strip()
    if tree.startswith("::"):
        tree = tree[2:]
    brace = tree.find("{")
    if brace >= 0:
        head = [s for s in tree[:brace].split("::") if s.strip()]
        inner = tree[brace + 1:tree.rfind("}")]
        parts, depth, cur = [], 0, ""
        for ch in inner:
            if ch == "," and depth == 0:
                parts.append(cur)
                cur = ""
                continue
            depth += ch == "{"
            depth -= ch == "}"
            cur += ch
        parts.append(cur)
        for p in parts:
            if p.strip():
                yield from expand(p, prefix + tuple(s.strip() for s in head))
        return
    alias = None
    if " as " in tree:
        tree, alias = [s.strip() for s in tree.split(" as ")]
    segs = list(prefix) + [s.strip() for s in tree.split("::") if s.strip()]
    if segs and segs[-1] == "self":
        segs = segs[:-1]
    if segs:
        yield segs, alias or segs[-1]


def strongly_connected(nodes, edges):
    """The strongly connected components of more than one node (Tarjan)."""
    index, low, on, stack, sccs, counter = {}, {}, set(), [], [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
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
                sccs.append(comp)

    for v in nodes:
        if v not in index:
            visit(v)
    return sccs


def module_edges(file_edges, path_of):
    """Edges between sibling modules, and the imports of an enclosing module's own file.

    `path_of(file)` is the module path of a file (a `mod.rs` or root file: its module's).
    An edge A -> B between files whose paths first differ at depth d, both deeper than d,
    is an edge between the siblings path_a[:d+1] -> path_b[:d+1]; when B's path is a prefix
    of A's, A imports the file of a module it lies in (returned apart)."""
    siblings, upward = {}, []
    for a, outs in file_edges.items():
        pa = path_of(a)
        for b in outs:
            pb = path_of(b)
            d = 0
            while d < min(len(pa), len(pb)) and pa[d] == pb[d]:
                d += 1
            if d < len(pa) and d < len(pb):
                siblings.setdefault(tuple(pa[:d + 1]), set()).add(tuple(pb[:d + 1]))
            elif d == len(pb) and d < len(pa):
                upward.append((a, b))
    return siblings, upward


def main():
    modules = module_files()
    lib_root = modules[()]
    bin_root = modules.get(("main",))

    def root_of(mod):
        return bin_root if bin_root is not None and (mod is bin_root or mod.path[0] in bin_root.children) else lib_root

    def resolve_module(mod, segs):
        """Start module and remaining segments for a path written in `mod`, or None."""
        if not segs:
            return None
        first = segs[0]
        if first == "crate":
            return root_of(mod), segs[1:]
        if first == "self":
            return mod, segs[1:]
        if first == "super":
            cur, rest = mod, segs
            while rest and rest[0] == "super":
                parent = tuple(cur.path[:-1])
                cur = modules.get(parent, lib_root) if not (bin_root and parent == () and cur.path[0] in bin_root.children) else bin_root
                rest = rest[1:]
            return cur, rest
        if first == "sparsemor" and mod.path[:1] != [] and bin_root is not None:
            return lib_root, segs[1:]
        if first in mod.children:
            return mod, segs
        return None

    def target_file(start, rest, seen=None):
        """File defining the item reached from module `start` by `rest`."""
        seen = seen or set()
        cur = start
        for i, s in enumerate(rest):
            if s in cur.children:
                cur = cur.children[s]
                continue
            if s == "*":
                return cur.file
            key = (cur.file, s)
            if key in seen:
                return cur.file
            seen.add(key)
            if s in cur.reexports:
                full = cur.reexports[s]
                r = resolve_module(cur, full)
                if r is None:
                    return cur.file
                return target_file(r[0], r[1] + rest[i + 1:], seen)
            return cur.file
        return cur.file

    # pass 1: re-exports and aliases
    aliases = {}
    for mod in modules.values():
        aliases[mod.file] = {}
        for is_pub, segs, alias in use_trees(mod.code):
            if is_pub:
                mod.reexports[alias] = segs
            mod.private_uses.append((is_pub, segs, alias))

    # pass 2: edges
    edges = {}
    for mod in modules.values():
        out = edges.setdefault(mod.file, set())
        local_alias = {}
        for is_pub, segs, alias in mod.private_uses:
            r = resolve_module(mod, segs)
            if r is None:
                continue
            start, rest = r
            # a `use` of a module is an alias for later paths; of an item, an edge
            cur, is_module = start, True
            for s in rest:
                if s in cur.children:
                    cur = cur.children[s]
                else:
                    is_module = False
                    break
            if is_module and rest:
                local_alias[alias] = cur
                continue
            if is_pub and rest:
                continue  # a re-export is followed, not drawn
            out.add(target_file(start, rest))
        code_wo_use = re.sub(r"(?:^|(?<=[;{}\s]))(?:pub(?:\([^)]*\))?\s+)?use\s+[^;]+;", " ", mod.code)
        for m in re.finditer(r"(?<![\w:])((?:[A-Za-z_]\w*::)+[A-Za-z_]\w*)", code_wo_use):
            segs = m.group(1).split("::")
            if segs[0] in local_alias:
                out.add(target_file(local_alias[segs[0]], segs[1:]))
                continue
            r = resolve_module(mod, segs)
            if r is None:
                continue
            out.add(target_file(*r))
        out.discard(mod.file)

    names = {m.file: m.name for m in modules.values()}
    rel = lambda f: str(f.relative_to(SRC.parent))
    if "--edges" in sys.argv:
        for f in sorted(edges, key=rel):
            for t in sorted(edges[f], key=rel):
                print(f"{rel(f)} -> {rel(t)}")

    sys.setrecursionlimit(10000)
    sccs = strongly_connected(list(edges), edges)
    failed = False
    for comp in sccs:
        failed = True
        members = set(comp)
        print("import cycle among: " + ", ".join(sorted(rel(f) for f in comp)))
        for f in sorted(comp, key=rel):
            for t in sorted(edges[f] & members, key=rel):
                print(f"    {rel(f)} -> {rel(t)}")
    for f, outs in sorted(edges.items(), key=lambda kv: rel(kv[0])):
        lf = layer_of(names[f])
        if lf is None:
            print(f"{rel(f)}: module {names[f]} has no layer in .ci/imports.py")
            failed = True
            continue
        for t in sorted(outs, key=rel):
            lt = layer_of(names[t])
            if lt is not None and lt > lf:
                print(f"layer violation: {rel(f)} ({LAYERS[lf][0]}) imports {rel(t)} ({LAYERS[lt][0]})")
                failed = True

    # modules: the main binary's modules are the crate root's children like the library's
    path_of = {m.file: (m.path[1:] if m.path[:1] == ["main"] else m.path) for m in modules.values()}
    siblings, upward = module_edges(edges, path_of.get)
    name = lambda path: "::".join(path) or "crate"
    if "--edges" in sys.argv:
        for a in sorted(siblings):
            for b in sorted(siblings[a]):
                print(f"{name(a)} => {name(b)}")
    module_sccs = strongly_connected(sorted(siblings), siblings)
    for comp in module_sccs:
        failed = True
        members = set(comp)
        print("module cycle among: " + ", ".join(sorted(name(m) for m in comp)))
        for a in sorted(comp):
            for b in sorted(siblings[a] & members):
                print(f"    {name(a)} => {name(b)}")
    for a, b in sorted(upward, key=lambda e: (rel(e[0]), rel(e[1]))):
        failed = True
        print(f"module cycle: {rel(a)} imports {rel(b)}, the file of a module it lies in")
    n_edges = sum(len(v) for v in edges.values())
    n_module_edges = sum(len(v) for v in siblings.values())
    print(f"imports: {len(edges)} files, {n_edges} edges, {len(sccs)} cycles; "
          f"{n_module_edges} edges between sibling modules, "
          f"{len(module_sccs) + len(upward)} module cycles"
          + (", layer rules broken" if failed and not sccs and not module_sccs and not upward else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

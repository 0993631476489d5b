"""Import cycles of a Rust crate, read from its `crate::`, `super::` and `self::` paths (text, not the
compiler: a check to run, not a proof). Test modules (`#[cfg(test)]` onwards) are left out.

Run from the repository root:
    python3 ../shared/tools/module_cycles.py src            # cycles between modules (files)
    python3 ../shared/tools/module_cycles.py src --folders  # cycles between the top folders of src/
Each cycle is printed with one import line per edge (file:line), then the count ("0 cycles").

Origin: a copy of the project's shared tool `../shared/tools/module_cycles.py`, text unchanged but
for this paragraph (the lines above name that path; here run `python3 scripts/module_cycles.py src`
and `... src --folders`). `.ci/run` runs both and fails unless each prints "0 cycles".
"""
import os, re, sys
from collections import defaultdict


def files(src):
    out = []
    for d, _, fs in os.walk(src):
        # a module file of tests (`#[cfg(test)] mod tests;`) is test code too
        out += [os.path.join(d, f) for f in fs if f.endswith(".rs") and f != "tests.rs"]
    return sorted(out)


def module_of(path, src):
    rel = os.path.relpath(path, src)[:-3].split(os.sep)
    if rel[-1] in ("mod", "lib", "main"):
        rel = rel[:-1]
    return tuple(rel)


def strip_tests(text):
    i = text.find("#[cfg(test)]")
    return text if i < 0 else text[:i]


USE = re.compile(r"\b(crate|super|self)((?:::[A-Za-z0-9_]+)+)(::\{([^}]*)\})?")


def graph(src):
    """module -> {imported module: 'file:line'}"""
    mods = {module_of(f, src): f for f in files(src)}
    edges = defaultdict(dict)
    for m, f in mods.items():
        text = strip_tests(open(f, encoding="utf-8", errors="replace").read())
        # a `use x::{a, b::{c, d}}` spanning lines: join each use statement onto one line
        for ln, line in enumerate(text.split("\n"), 1):
            code = re.sub(r"//.*", "", line)
            for u in USE.finditer(code):
                root, rest = u.group(1), u.group(2).strip(":").split("::")
                base = [] if root == "crate" else list(m) if root == "self" else list(m[:-1])
                while rest and rest[0] == "super":
                    base, rest = base[:-1], rest[1:]
                parts = [p.strip().split(" as ")[0] for p in u.group(4).split(",")] if u.group(4) else [""]
                for part in parts:
                    p = base + rest + [x for x in part.split("::") if x and x not in ("*", "self")]
                    for k in range(len(p), 0, -1):
                        t = tuple(p[:k])
                        if t in mods:
                            # a child naming its own ancestor module is not an edge
                            if t != m and not (len(m) > len(t) and m[:len(t)] == t):
                                edges[m].setdefault(t, "%s:%d" % (os.path.relpath(f), ln))
                            break
    return mods, edges


def sccs(nodes, edges):
    index, low, onstack, stack, out, counter = {}, {}, set(), [], [], [0]
    sys.setrecursionlimit(100000)

    def strong(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        onstack.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in onstack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                onstack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(nodes):
        if v not in index:
            strong(v)
    return out


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    src = args[0] if args else "src"
    folders = "--folders" in sys.argv
    mods, edges = graph(src)
    if folders:
        # collapse every module to its top folder under src (files at the top stay themselves)
        top = lambda m: m[:1] if m else ("lib",)
        fedges = defaultdict(dict)
        for a, targets in edges.items():
            for b, where in targets.items():
                if top(a) != top(b):
                    fedges[top(a)].setdefault(top(b), where)
        nodes, edges = {top(m) for m in mods}, fedges
    else:
        nodes = set(mods)
    cycles = sccs(nodes, edges)
    name = lambda m: "/".join(m) or "lib"
    for comp in cycles:
        print("cycle: " + " <-> ".join(name(m) for m in comp))
        members = set(comp)
        for a in comp:
            for b, where in sorted(edges.get(a, {}).items()):
                if b in members:
                    print("    %s -> %s  (%s)" % (name(a), name(b), where))
    print("%d cycles" % len(cycles))


if __name__ == "__main__":
    main()

"""Reads the params structs of the C++ headers: each struct's fields (type, name, the comment
on them) and each visit_fields() body (YAML key -> field, nested struct, list of structs).

The params protocol (core/include/lander/core/params_io.h) lists every YAML key in a
visit_fields(V& v, Struct& p) function beside its struct:

    v("exposure_ms", p.exposure_s, 1e-3);   // key, field, optional scale
    v.nested("camera", p.camera);           // a nested params struct
    v.list("waypoints", p.waypoints);       // a list of params structs

and the fields carry their meaning in a trailing `///<` comment (continued on the following
lines by `///<` alone) or in a `///` / `//` comment block just above them. This module parses
only that much C++: it is not a compiler, and anything it cannot attribute is reported as
having no comment, never guessed.
"""

import os
import re

# visit_fields, and the parts a long one is split into (visit_<part>_fields, defined before it in
# the order visit_fields calls them): their calls are the struct's keys in file order.
VISIT_RE = re.compile(r"void\s+visit_(?:\w+_)?fields\s*\(\s*V\s*&\s*v\s*,\s*([\w:]+)\s*&\s*p\s*\)\s*\{")
CALL_RE = re.compile(r'\bv(\.nested|\.list)?\(\s*"([^"]+)"\s*,\s*p\.([\w.]+)\s*(?:,\s*([^)]*))?\)')
# A struct's visit_fields that visits its base first: visit_fields(v, static_cast<Base&>(p)).
BASE_RE = re.compile(r"\bvisit_fields\(\s*v\s*,\s*static_cast<\s*([\w:]+)\s*&\s*>\(\s*p\s*\)\s*\)")
STRUCT_RE = re.compile(r"^\s*struct\s+(\w+)\s*(?:final\s*)?(?::[^{]*)?\{")


def strip_code(line):
    """The code part of a line: string and char literals blanked, comments removed."""
    out = []
    i, n = 0, len(line)
    while i < n:
        c = line[i]
        if line.startswith("//", i):
            break
        if c in "\"'":
            q = c
            out.append(q)
            i += 1
            while i < n and line[i] != q:
                i += 2 if line[i] == "\\" else 1
            out.append(q)
            i += 1
            continue
        out.append(c)
        i += 1
    return "".join(out)


def trailing_doc(line):
    """The text of a trailing `///<` comment, or None."""
    m = re.search(r"///<\s?(.*)$", line)
    return m.group(1).strip() if m else None


class Field:
    def __init__(self, name, ctype, init, doc, file, line):
        self.name, self.ctype, self.init, self.doc, self.file, self.line = name, ctype, init, doc, file, line


class Struct:
    def __init__(self, name, file, line, doc):
        self.name, self.file, self.line, self.doc = name, file, line, doc
        self.fields = {}
        self.visits = []  # (kind, key, field, scale): kind in "value", "nested", "list"
        self.visit_line = None


DECL_RE = re.compile(
    r"^\s*(?:mutable\s+)?((?:const\s+)?[\w:]+(?:\s*<[^;{}()]*>)?)\s+"  # type
    r"(\w+)\s*(\{[^;{}]*(?:\{[^;{}]*\}[^;{}]*)*\}|=[^;,]*)?"               # first declarator
    r"((?:\s*,\s*\w+\s*(?:\{[^;]*?\}|=[^;,]*)?)*)\s*;\s*$")


def _split_declarators(first_name, first_init, rest):
    decls = [(first_name, (first_init or "").strip())]
    for m in re.finditer(r",\s*(\w+)\s*(\{[^,;]*?\}|=[^;,]*)?", rest or ""):
        decls.append((m.group(1), (m.group(2) or "").strip()))
    return decls


def parse_file(path, rel):
    """Returns ({struct name: Struct}, [(struct name, visits, line)]) for one header."""
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    structs = {}
    visits = []
    # visit_fields bodies
    text = "\n".join(lines)
    for m in VISIT_RE.finditer(text):
        name = m.group(1).split("::")[-1]
        start = m.end()
        depth, i = 1, start
        while depth and i < len(text):
            depth += {"{": 1, "}": -1}.get(text[i], 0)
            i += 1
        body = text[start:i - 1]
        found = []
        for c in CALL_RE.finditer(body):
            kind = {None: "value", ".nested": "nested", ".list": "list"}[c.group(1)]
            found.append((c.start(), (kind, c.group(2), c.group(3), (c.group(4) or "").strip() or None)))
        for c in BASE_RE.finditer(body):
            found.append((c.start(), ("base", "", c.group(1).split("::")[-1], None)))
        calls = [call for _, call in sorted(found, key=lambda f: f[0])]
        visits.append((name, calls, text.count("\n", 0, m.start()) + 1))
    # structs and their fields (depth 1 inside the struct body)
    stack = []  # (Struct, depth at which its body lives)
    depth = 0
    pending = []  # comment lines just above the current line (same struct depth)
    group = []  # the comment block above a run of fields (kept until a blank line)
    for idx, raw in enumerate(lines):
        code = strip_code(raw)
        stripped = raw.strip()
        top = stack[-1] if stack else None
        in_body = top is not None and depth == top[1]
        sm = STRUCT_RE.match(code)
        if sm and not code.rstrip().endswith(";"):
            doc = " ".join(pending) if pending else ""
            s = Struct(sm.group(1), rel, idx + 1, doc)
            structs.setdefault(s.name, s)
            depth += code.count("{") - code.count("}")
            stack.append((s, depth))
            pending = []
            continue
        if in_body:
            if stripped.startswith("///<") and top[0].fields:
                # continuation of the previous field's trailing comment
                last = top[0].last_field
                if last is not None and last.doc_from == "trailing" and last.line_end == idx:
                    last.doc += " " + trailing_doc(stripped)
                    last.line_end = idx + 1
                    continue
            if stripped.startswith("//"):
                pending.append(re.sub(r"^/+<?\s?", "", stripped).strip())
            elif not stripped:
                pending = []
                group = []
            else:
                dm = DECL_RE.match(code)
                net = code.count("{") - code.count("}")
                if dm and net == 0 and "(" not in dm.group(1) and not code.lstrip().startswith(("return", "using", "friend", "static_assert")):
                    ctype = dm.group(1)
                    tdoc = trailing_doc(raw)
                    for name, init in _split_declarators(dm.group(2), dm.group(3), dm.group(4)):
                        if tdoc is not None:
                            doc, source = tdoc, "trailing"
                        elif pending:
                            doc, source = " ".join(p for p in pending if p), "above"
                        elif group:
                            doc, source = " ".join(p for p in group if p), "group"
                        else:
                            doc, source = "", "none"
                        fld = Field(name, ctype, init, doc, rel, idx + 1)
                        fld.doc_from, fld.line_end = source, idx + 1
                        fld.static = "static" in code.split(ctype)[0] or "constexpr" in code
                        top[0].fields[name] = fld
                        top[0].last_field = fld
                    if pending:
                        group = pending
                    pending = []
                    continue
                pending = []
                group = []
        depth += code.count("{") - code.count("}")
        while stack and depth < stack[-1][1]:
            stack.pop()
    for s in structs.values():
        if not hasattr(s, "last_field"):
            s.last_field = None
    return structs, visits


def parse_tree(repo, dirs=("core", "estimator", "controller", "flight", "sim", "campaign", "bench")):
    """Every params struct of the headers under <dir>/include of the given folders."""
    structs = {}
    for d in dirs:
        inc = os.path.join(repo, d, "include")
        for root, _, files in os.walk(inc):
            for fn in sorted(files):
                if not fn.endswith(".h"):
                    continue
                path = os.path.join(root, fn)
                rel = os.path.relpath(path, repo)
                ss, vs = parse_file(path, rel)
                for k, s in ss.items():
                    if k not in structs:
                        structs[k] = s
                merged = {}
                for name, calls, line in vs:
                    if name in merged:
                        merged[name][0].extend(calls)
                    else:
                        merged[name] = (list(calls), line)
                for name, (calls, line) in merged.items():
                    if name in structs and not structs[name].visits:
                        structs[name].visits = calls
                        structs[name].visit_line = (rel, line)
                    elif name in ss:
                        ss[name].visits = calls
                        ss[name].visit_line = (rel, line)
    return structs


def element_type(ctype):
    """T of std::vector<T>, or the type itself without namespaces."""
    m = re.match(r"(?:std::)?vector\s*<\s*([\w:]+)\s*>", ctype)
    t = m.group(1) if m else ctype
    return t.split("::")[-1]


class KeyDoc:
    def __init__(self, path, kind, struct, field, scale):
        self.path, self.kind, self.struct, self.field, self.scale = path, kind, struct, field, scale


def walk(structs, root, prefix=""):
    """Every key under the struct `root`: a list of KeyDoc in visit order, with list items
    as 'key[]'. Raises KeyError naming what it cannot resolve."""
    out = []
    s = structs[root]
    if not s.visits:
        raise KeyError("no visit_fields() found for struct %s (%s:%d)" % (root, s.file, s.line))
    for kind, key, field, scale in s.visits:
        if kind == "base":  # the base struct's keys, at this level
            if field not in structs:
                raise KeyError("base struct %s of %s not found in the headers" % (field, root))
            out.extend(walk(structs, field, prefix))
            continue
        fld = s.fields.get(field.split(".")[0])
        path = prefix + key
        if kind == "value":
            out.append(KeyDoc(path, "value", s, fld, scale))
        else:
            if fld is None:
                raise KeyError("field %s of struct %s not found (%s)" % (field, root, s.file))
            t = element_type(fld.ctype)
            if t not in structs:
                raise KeyError("struct %s (field %s.%s) not found in the headers" % (t, root, field))
            sub = path + ("[]" if kind == "list" else "")
            out.append(KeyDoc(sub, kind, s, fld, None))
            out.extend(walk(structs, t, sub + "."))
    return out

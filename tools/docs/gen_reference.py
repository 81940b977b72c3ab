#!/usr/bin/python3
"""Generates docs/reference/ from the code: every scenario key and flight-configuration key
(unit, default, allowed range, meaning), every summary.json field and trace.csv column, every
`lander` command and option.

Usage:
  /usr/bin/python3 tools/docs/gen_reference.py --lander build/lander --out docs/reference
  /usr/bin/python3 tools/docs/gen_reference.py --lander build/lander --check docs/reference

--check generates into a temporary directory and compares with the committed pages: exit 1
with a unified diff when they differ ("regenerate with the first command and commit").

Sources, all from the code or from `lander` run as it is (nothing is written by hand):
- keys and defaults: the resolved YAML that `lander run` writes (scenario.resolved.yaml) for a
  probe scenario that sets only a test hook (faults.diverge_t_s: 0, the run ends at once; a
  second probe with faults.abort_t_s: 0 gives the first one's default back), and
  `lander flight-config --defaults` for the flight configuration's in-class defaults;
- units: the key's suffix (the params protocol names non-SI units in the key: _ms, _deg, ...),
  else a unit in parentheses at the end of the field's comment (marked "from the comment");
- allowed range: `lander docs probe` (tools/lander/cmd_docs.cpp: loads and validates, as
  `lander run` would, a scenario that sets one key) with each numeric key set to -1e9 and to
  +1e9 (not probed again when the first message states both bounds), each string key to a
  nonsense word; the validation messages are quoted, "not checked" when both are accepted;
- meaning: the `///<` comment on the struct field, else the comment block above it
  (tools/docs/cxx_params.py parses the params headers and their visit_fields());
- summary.json and trace.csv: the files of a replayed closed-loop run (the change
  indication's recorded vision, regression/change/replay/), a replayed path-following run and
  a one-second scripted run; each field with the source line that writes it;
- commands: `lander --help`, and in tools/lander/cmd_*.cpp the registration, the usage
  strings and the options each ArgParser accepts.
"""

import argparse
import difflib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.dont_write_bytecode = True  # no __pycache__ left in the source tree by the CTest check
import cxx_params  # noqa: E402

REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
PROBE_TIMEOUT_S = 60  # a probe only loads and validates; a minute means something hangs
RUN_TIMEOUT_S = 300   # the short runs below take seconds; generous for a loaded 2-core machine
LOW, HIGH = -1e9, 1e9
NONSENSE = "docs_probe_not_a_value"
# A validation message that already states both bounds ("must be in [16, 8192]", "within
# +-30 deg"): the second probe (+1e9) adds nothing to it.
TWO_SIDED = re.compile(r"\bin [\[(]|\bwithin\b|\bbetween\b|\+-")
REGEN = "/usr/bin/python3 tools/docs/gen_reference.py --lander build/lander --out docs/reference"

# Key suffix -> unit, longest first (the params protocol: "YAML keys carry a unit suffix where
# it is not SI", and most SI keys carry theirs too).
SUFFIXES = [
    ("_mps3", "m/s^3"), ("_mps2", "m/s^2"), ("_radps2", "rad/s^2"), ("_degps", "deg/s"),
    ("_radps", "rad/s"), ("_mps", "m/s"), ("_kgm2", "kg m^2"), ("_kg", "kg"), ("_ms", "ms"),
    ("_hz", "Hz"), ("_px2", "px^2"), ("_px", "px"), ("_deg", "deg"), ("_rad", "rad"), ("_kpa", "kPa"),
    ("_pa", "Pa"), ("_ut", "uT"), ("_uT", "uT"), ("_dn", "grey levels (8 bit)"), ("_nm", "N m"),
    ("_n", "N"), ("_s", "s"), ("_m", "m"), ("_prob", "probability"),
]
UNIT_IN_COMMENT = re.compile(r"\(((?:1/s(?:\^2)?)|(?:[mskgNPaHzpxrdeguT]+(?:\s*[/^*]\s*\(?[a-zA-Z0-9^]+\)?)*)"
                             r"(?:\s*(?:per|/)\s*[a-zA-Z0-9^()/]+)?)\)\s*[.:;,]?\s*$")


class GenError(Exception):
    pass


def run(cmd, timeout, cwd=None, env=None):
    try:
        return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=cwd, env=env)
    except subprocess.TimeoutExpired:
        raise GenError("timed out after %d s: %s" % (timeout, " ".join(cmd)))


# ---------------------------------------------------------------------------------------------
# values

def flatten(node, prefix=""):
    """Leaves of a YAML mapping as (dotted key, value); lists are leaves."""
    out = []
    if isinstance(node, dict):
        for k, v in node.items():
            p = prefix + str(k)
            if isinstance(v, dict):
                out += flatten(v, p + ".")
            else:
                out.append((p, v))
    return out


def nest(key, value):
    d = value
    for part in reversed(key.split(".")):
        d = {part: d}
    return d


def fmt_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if v != v:
            return "nan"
        r = repr(v)
        return r[:-2] if r.endswith(".0") and abs(v) < 1e15 else r
    if isinstance(v, list):
        if v and all(isinstance(x, dict) for x in v):
            return "(a list of %d item%s)" % (len(v), "" if len(v) == 1 else "s")
        return "[" + ", ".join(fmt_value(x) for x in v) + "]"
    if v is None:
        return "null"
    if isinstance(v, str):
        return '"%s"' % v if v == "" else v
    return str(v)


def md(s):
    """Text safe inside a Markdown table cell."""
    return str(s).replace("|", "\\|").replace("\n", " ").replace("<", "&lt;").replace(">", "&gt;")


def prose(text):
    """A comment line as Markdown prose: < and > outside backquoted spans escaped, so that
    `runs/<id>/` in a comment is not taken for an HTML tag."""
    parts = text.split("`")
    for i in range(0, len(parts), 2):
        parts[i] = parts[i].replace("<", "&lt;").replace(">", "&gt;")
    return "`".join(parts)


def code(s):
    s = str(s).replace("|", "\\|")
    return "`%s`" % s if s else ""


def unit_of(key, doc):
    last = key.split(".")[-1]
    for suf, unit in SUFFIXES:
        if last.endswith(suf) and len(last) > len(suf):
            return unit, "suffix"
    # A unit from the comment only where it plainly belongs to the field: a short first
    # clause that ends with it ("horizontal position gain (1/s)"), and never for a key whose
    # name says it is a ratio (a "(px)" there names what the ratio is of).
    if doc and not re.search(r"_(fraction|ratio|share|factor|frac|sigma|count)$", last):
        first = re.split(r"(?<=[.;:])\s", doc.strip(), maxsplit=1)[0]
        if len(first) <= 90:
            m = UNIT_IN_COMMENT.search(first)
            if m:
                return m.group(1), "comment"
    return "", ""


def one_line(doc, limit=220):
    doc = re.sub(r"\s+", " ", doc or "").strip()
    if not doc:
        return "(no comment in the code)"
    if len(doc) <= limit:
        return doc
    cut = doc[:limit]
    sp = cut.rfind(" ")
    return (cut[:sp] if sp > limit // 2 else cut) + " ..."


# ---------------------------------------------------------------------------------------------
# probes through the command line

class Lander:
    def __init__(self, exe, repo, tmp):
        self.exe, self.repo, self.tmp = exe, repo, tmp
        self.env = dict(os.environ)
        self.env.pop("LANDER_MODELS_DIR", None)
        self.models = os.path.realpath(os.path.join(repo, "models"))

    def sanitize(self, text):
        text = text.replace(os.path.realpath(self.tmp), "<probe>").replace(self.tmp, "<probe>")
        text = re.sub(r"/tmp/lander-docs-probe-[^/\s]+", "<probe>", text)
        text = text.replace(self.models, "models").replace(os.path.realpath(self.repo) + "/", "")
        return text

    def resolved_defaults(self):
        """The scenario defaults as scenario.resolved.yaml gives them (see the module doc)."""
        trees = {}
        for hook in ("diverge_t_s", "abort_t_s"):
            d = os.path.join(self.tmp, "defaults_" + hook)
            os.makedirs(d)
            scen = os.path.join(d, "probe.yaml")
            with open(scen, "w") as f:
                yaml.safe_dump({"faults": {hook: 0.0}}, f)
            out = os.path.join(d, "out")
            r = run([self.exe, "run", scen, "--out", out, "--quiet"], RUN_TIMEOUT_S, cwd=d, env=self.env)
            path = os.path.join(out, "scenario.resolved.yaml")
            if not os.path.exists(path):
                raise GenError("lander run %s wrote no scenario.resolved.yaml (exit %s): %s"
                               % (scen, r.returncode, r.stderr[-2000:]))
            with open(path) as f:
                trees[hook] = yaml.safe_load(self.sanitize(f.read()))
        a, b = trees["diverge_t_s"], trees["abort_t_s"]
        fa, fb = dict(flatten(a)), dict(flatten(b))
        diff = sorted(k for k in set(fa) | set(fb)
                      if fa.get(k) != fb.get(k) and k not in ("faults.diverge_t_s", "faults.abort_t_s"))
        if diff or set(fa) != set(fb):
            raise GenError("the two default probes disagree beyond their test hooks: %s" % diff[:10])
        a["faults"]["diverge_t_s"] = b["faults"]["diverge_t_s"]
        return a

    def visitor_keys(self):
        """{key: {type, unit, allowed, doc}} as the visitors give them (`lander docs keys`)."""
        r = run([self.exe, "docs", "keys"], PROBE_TIMEOUT_S, env=self.env)
        if r.returncode != 0:
            raise GenError("lander docs keys failed (exit %d): %s" % (r.returncode, r.stderr[-2000:]))
        return {k["key"]: k for k in json.loads(r.stdout)}

    def flight_defaults(self):
        r = run([self.exe, "flight-config", "--defaults"], PROBE_TIMEOUT_S, env=self.env)
        if r.returncode != 0:
            raise GenError("lander flight-config --defaults failed: " + r.stderr)
        return yaml.safe_load(self.sanitize(r.stdout))

    def validate_all(self, probes):
        """[(accepted, message)] for [(key, value)]: each a scenario that sets only that key,
        loaded and validated by `lander docs probe` (tools/lander/cmd_docs.cpp) as
        `lander run` would load it."""
        path = os.path.join(self.tmp, "probes.yaml")
        with open(path, "w") as f:
            yaml.safe_dump([{"key": k, "value": v} for k, v in probes], f, default_flow_style=None, width=1000)
        r = run([self.exe, "docs", "probe", path], PROBE_TIMEOUT_S, env=self.env)
        if r.returncode != 0:
            hint = " (this lander has no docs command: rebuild it)" if "unknown command" in r.stderr else ""
            raise GenError("lander docs probe failed (exit %d)%s: %s" % (r.returncode, hint, r.stderr[-2000:]))
        lines = r.stdout.rstrip("\n").split("\n") if r.stdout.strip() else []
        if len(lines) != len(probes):
            raise GenError("lander docs probe answered %d of %d probes" % (len(lines), len(probes)))
        out = []
        for line in lines:
            if line == "ok":
                out.append((True, ""))
                continue
            if not line.startswith("error: "):
                raise GenError("unexpected answer of lander docs probe: %r" % line)
            msg = self.sanitize(line[len("error: "):])
            msg = re.sub(r"^\S*probe\.yaml(?::\d+)?: ", "", msg)
            out.append((False, msg))
        return out

    def text(self, *args):
        r = run([self.exe] + list(args), PROBE_TIMEOUT_S, env=self.env)
        return r


def probe_values(v):
    if isinstance(v, bool) or v is None:
        return []
    if isinstance(v, int):
        return [int(LOW), int(HIGH)]
    if isinstance(v, float):
        return [LOW, HIGH]
    if isinstance(v, str):
        return [NONSENSE]
    if isinstance(v, list) and v and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
        return [[type(x)(LOW) for x in v], [type(x)(HIGH) for x in v]]
    return []


def describe_range(key, results):
    """The allowed range from the probe results [(value, accepted, message)]."""
    if not results:
        return "not probed"
    msgs = []
    for value, ok, msg in results:
        if ok:
            continue
        m = re.match(r"invalid value for '([^']+)': (.*)$", msg)
        if m and m.group(1) == key:
            text = m.group(2)
        elif m:
            text = "%s (reported for `%s`)" % (m.group(2), m.group(1))
        else:
            text = msg
        text = re.sub(r"\s*\(the key itself kept its default[^)]*\)", "", text)
        if text not in msgs:
            msgs.append(text)
    if not msgs:
        return "not checked (%s accepted)" % " and ".join(fmt_value(v) for v, _, _ in results)
    return "; ".join(msgs)


# ---------------------------------------------------------------------------------------------
# the key pages

def key_docs(structs, root, prefix):
    docs = {}
    for k in cxx_params.walk(structs, root):
        docs[prefix + k.path] = k
    return docs


def doc_of(kd):
    if kd is None:
        return "", ""
    if kd.field is not None and kd.field.doc:
        return kd.field.doc, "%s:%d" % (kd.field.file, kd.field.line)
    if kd.kind != "value" and kd.field is not None:
        return "", "%s:%d" % (kd.field.file, kd.field.line)
    return "", ("%s:%d" % (kd.field.file, kd.field.line)) if kd.field else ""


METHOD_KEYS = """The method (tools/docs/gen_reference.py, regenerated by `{regen}`; a CTest
test fails when this page differs from what the code gives):

- **key** and **default**: `scenario.resolved.yaml` as `lander run` writes it for a scenario
  that sets nothing but a test hook{flight_note}; paths are shown relative to the repository;
- **unit**: the unit the key's `visit_fields` call gives (`v("mass_kg", p.mass_kg,
  range::positive, "kg", "total mass")`, core/include/lander/core/field_spec.h; `lander docs
  keys` lists them), of the value as written in YAML (`exposure_ms` is in ms); empty for
  counts, flags, gains and ratios;
- **allowed**: the validation message the scenario loader gives (`lander docs probe`, as
  `lander run` would load the file) with the key set to -1e9 and to 1e9 (the second is left
  out when the first message states both bounds; a string key: a nonsense word), quoted;
  "not checked" when the code accepts both (for a list's items: the range their visitor
  gives);
- **meaning**: the description the `visit_fields` call gives; where the field's `///<`
  comment in the header (else the comment block above it) says more, that comment instead
  when it begins with the description, else both; cut to {limit} characters; each section
  names the struct and the header that declares it.
"""


def key_table(rows):
    out = ["| key | unit | default | allowed | meaning |", "|---|---|---|---|---|"]
    for r in rows:
        out.append("| %s | %s | %s | %s | %s |" % (code(r["key"]), md(r["unit"]), code(r["default"]),
                                                   md(r["allowed"]), md(r["meaning"])))
    return "\n".join(out)


def meaning_of(spec, comment):
    """The visitor's description, then the header's comment where it says more."""
    desc = (spec or {}).get("doc", "")
    if not desc:
        return one_line(comment)
    flat = re.sub(r"\s+", " ", comment or "").strip()
    if len(flat) <= len(desc) + 30:
        return desc
    # the description is usually the comment's first clause: then the comment says it all
    if flat.lower().startswith(desc.lower()):
        return one_line(comment)
    return desc + " &mdash; " + one_line(comment)


def unit_from(key, spec):
    """The unit the key's visitor gives (`lander docs keys` lists every key of the tree)."""
    if spec is None:
        raise GenError("key %s is not in `lander docs keys` (rebuild the lander binary?)" % key)
    return spec["unit"]


def list_row(key, value, docs, specs):
    """The row of a list key (its items' keys are rows of their own), or None."""
    if not isinstance(value, list) or not any(k.startswith(key + "[].") for k in specs):
        return None
    doc, where = doc_of(docs.get(key))
    meaning = "list; each item's keys are the `%s[].` rows" % key
    return {"key": key, "unit": "", "default": fmt_value(value), "allowed": "a list",
            "meaning": meaning + (" &mdash; " + one_line(doc) if doc else ""), "where": where}


def section_rows(leaves, docs, probes, specs, defaults_note=None):
    rows = []
    for key, value in leaves:
        as_list = list_row(key, value, docs, specs)
        if as_list is not None:
            rows.append(as_list)
            continue
        kd = docs.get(key)
        doc, where = doc_of(kd)
        unit = unit_from(key, specs.get(key))
        default = fmt_value(value)
        if defaults_note and key in defaults_note:
            default += " " + defaults_note[key]
        allowed = "true or false" if isinstance(value, bool) else describe_range(key, probes.get(key, []))
        rows.append({"key": key, "unit": unit, "default": default, "allowed": allowed,
                     "meaning": meaning_of(specs.get(key), doc), "where": where})
    return rows


def list_item_rows(docs, list_prefix, specs, probes_note="not probed (list item)"):
    rows = []
    for path, kd in docs.items():
        if not path.startswith(list_prefix + "[]."):
            continue
        if kd.kind != "value":
            continue
        doc, where = doc_of(kd)
        spec = specs.get(path)
        unit = unit_from(path, spec)
        init = kd.field.init if kd.field is not None else ""
        init = re.sub(r"^[{=]\s*|\s*}$", "", init or "")
        allowed = (spec or {}).get("allowed") or probes_note
        rows.append({"key": path, "unit": unit, "default": ("in-class: " + init) if init else "",
                     "allowed": allowed, "meaning": meaning_of(spec, doc), "where": where})
    return rows


def grouped(rows, depth):
    """Rows grouped by the first `depth` components of the key (in order)."""
    groups = []
    for r in rows:
        parts = r["key"].replace("[]", "").split(".")
        g = ".".join(parts[:min(depth, len(parts) - 1)]) if len(parts) > 1 else ""
        if not groups or groups[-1][0] != g:
            groups.append((g, []))
        groups[-1][1].append(r)
    return groups


def header_of(docs, prefix):
    """(struct name, file:line) of the nested struct that a key prefix names."""
    kd = docs.get(prefix) or docs.get(prefix + "[]")
    if kd is None or kd.field is None:
        return None
    t = cxx_params.element_type(kd.field.ctype)
    return t


def write_key_page(path, title, intro, rows, docs, structs, depth, strip=""):
    lines = ["# " + title, "", intro.strip(), ""]
    counts = {"keys": len(rows), "no comment": sum(1 for r in rows if r["meaning"] == "(no comment in the code)"),
              "not checked": sum(1 for r in rows if r["allowed"].startswith("not checked"))}
    lines.append("%(keys)d keys; %(no comment)d without a comment in the code; %(not checked)d whose "
                 "range the code does not check." % counts)
    lines.append("")
    for g, rs in grouped(rows, depth):
        top = not g or g == strip.rstrip(".")
        lines.append("## " + ("Top level" if top else "`%s`" % g))
        lines.append("")
        t = None if top else header_of(docs, g)
        if top:
            t = "Scenario" if not strip else "FlightConfig"
        if t and t in structs:
            s = structs[t]
            lines.append("Struct `%s` in `%s` (line %d)." % (t, s.file, s.line))
            lines.append("")
        lines.append(key_table([dict(r, key=r["key"][len(strip):] if strip and r["key"].startswith(strip) else r["key"])
                                for r in rs]))
        lines.append("")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines).rstrip() + "\n")


# ---------------------------------------------------------------------------------------------
# summary.json and trace.csv

def json_fields(v, prefix="", out=None):
    """Dotted field -> set of JSON types; arrays of objects as 'key[].sub'."""
    if out is None:
        out = {}

    def t(x):
        if x is None:
            return "null"
        if isinstance(x, bool):
            return "boolean"
        if isinstance(x, int):
            return "integer"
        if isinstance(x, float):
            return "number"
        if isinstance(x, str):
            return "string"
        if isinstance(x, list):
            return "array"
        return "object"

    if isinstance(v, dict):
        for k, x in v.items():
            p = prefix + k
            out.setdefault(p, set()).add(t(x))
            if isinstance(x, dict):
                json_fields(x, p + ".", out)
            elif isinstance(x, list):
                for item in x:
                    if isinstance(item, dict):
                        json_fields(item, p + "[].", out)
    return out


_SOURCES = {}


def sources(repo):
    """(relative path, lines) of the C++ sources a summary field may be written in, in the
    order they are searched (the recorder and the loop first); read once."""
    if repo not in _SOURCES:
        found = []
        for base in ("sim/src", "sim/include", "flight", "controller", "estimator"):
            for dirpath, dirs, files in os.walk(os.path.join(repo, base)):
                dirs.sort()
                for fn in sorted(files):
                    if fn.endswith((".cpp", ".h")):
                        p = os.path.join(dirpath, fn)
                        with open(p, encoding="utf-8") as f:
                            found.append((os.path.relpath(p, repo), f.read().split("\n")))
        _SOURCES[repo] = found
    return _SOURCES[repo]


def writer_line(repo, field):
    """Where a summary field's key is written (the first line under sim/src, then elsewhere,
    that holds the quoted name in a JSON assignment) and the comment on or above that line."""
    leaf = field.split(".")[-1].replace("[]", "")
    quoted = '"%s"' % leaf
    for rel, lines in sources(repo):
        for i, line in enumerate(lines):
            if quoted in line and ("summary" in line or '["' in line or '{"' in line):
                m = re.search(r"//\s?(.*)$", line)
                if m:
                    return "%s:%d" % (rel, i + 1), m.group(1)
                j, block = i - 1, []
                while j >= 0 and lines[j].strip().startswith("//"):
                    block.insert(0, lines[j].strip().lstrip("/").strip())
                    j -= 1
                return "%s:%d" % (rel, i + 1), " ".join(block)
    return "", ""


def summary_runs(lander, repo, tmp):
    runs = []
    replay = os.path.join(repo, "regression", "change", "replay")
    for name, scen in (("closed loop (default.yaml, replayed vision)", "default"),
                       ("closed loop with a route (path_to_cart.yaml, replayed vision)", "path_to_cart")):
        out = os.path.join(tmp, "run_" + scen)
        vision = os.path.join(replay, scen, "vision.csv")
        if not os.path.exists(vision):
            raise GenError("missing recorded vision %s" % vision)
        r = run([lander.exe, "run", os.path.join(repo, "scenarios", scen + ".yaml"), "--out", out,
                 "--replay-vision", vision, "--quiet"], RUN_TIMEOUT_S, env=lander.env)
        if not os.path.exists(os.path.join(out, "summary.json")):
            raise GenError("lander run %s wrote no summary.json (exit %d): %s" % (scen, r.returncode, r.stderr[-2000:]))
        runs.append((name, out))
    with open(os.path.join(repo, "scenarios", "flyover.yaml")) as f:
        fly = yaml.safe_load(f)
    fly["duration_s"] = 1
    d = os.path.join(tmp, "run_scripted")
    os.makedirs(d)
    scen = os.path.join(d, "flyover_1s.yaml")
    with open(scen, "w") as f:
        yaml.safe_dump(fly, f)
    out = os.path.join(d, "out")
    r = run([lander.exe, "run", scen, "--out", out, "--quiet"], RUN_TIMEOUT_S, env=lander.env)
    if not os.path.exists(os.path.join(out, "summary.json")):
        raise GenError("the scripted run wrote no summary.json (exit %d): %s" % (r.returncode, r.stderr[-2000:]))
    runs.append(("scripted (flyover.yaml, 1 s)", out))
    return runs


def write_summary_page(path, repo, runs):
    fields = {}
    seen_in = {}
    trace_cols = None
    for i, (name, out) in enumerate(runs):
        with open(os.path.join(out, "summary.json")) as f:
            s = json.load(f)
        for k, ts in json_fields(s).items():
            fields.setdefault(k, set()).update(ts)
            seen_in.setdefault(k, []).append(i)
        tp = os.path.join(out, "trace.csv")
        if trace_cols is None and os.path.exists(tp) and "closed loop" in name:
            with open(tp) as f:
                trace_cols = f.readline().strip().split(",")
    # maps whose keys are data (reasons, sensors), not fields: list the map, not its keys
    lines = ["# summary.json and trace.csv", "",
             "Generated by `tools/docs/gen_reference.py` (regenerate: `%s`; a CTest test fails when this "
             "page differs from what the code gives)." % REGEN, "",
             "The method: the generator runs `lander` on three inputs and lists every field of their "
             "`summary.json` (objects as dotted paths, arrays of objects as `key[].field`) with its JSON "
             "types, the unit from its suffix, and the first source line that writes its name with "
             "the comment there; what each field means in words is in "
             "[Outputs](../guide/outputs.md). The runs:", ""]
    for i, (name, _) in enumerate(runs):
        lines.append("%d. %s" % (i + 1, name))
    lines += ["", "`schema_version` is 2 (`kSummarySchemaVersion` in `sim/include/lander/sim/run.h`). A "
              "number that is NaN in the code (no contact, nothing measured) is written as `null`.", "",
              "## summary.json", "",
              "| field | types | unit | in runs | written at | comment there |", "|---|---|---|---|---|---|"]
    for k in sorted(fields, key=lambda x: (x.split(".")[0], x)):
        unit, _ = unit_of(k, "")
        where, doc = writer_line(repo, k)
        lines.append("| %s | %s | %s | %s | %s | %s |" % (
            code(k), " or ".join(sorted(fields[k])), md(unit), ", ".join(str(i + 1) for i in seen_in[k]),
            code(where) if where else "", md(one_line(doc, 160)) if doc else ""))
    lines += ["", "## trace.csv", "",
              "The header of the closed-loop run's `trace.csv` (one row per `1 / trace_rate_hz`; "
              "columns are listed in order; the unit is the suffix).", "",
              "| column | unit |", "|---|---|"]
    for c in trace_cols or []:
        unit, _ = unit_of(c, "")
        lines.append("| %s | %s |" % (code(c), md(unit)))
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines).rstrip() + "\n")


# ---------------------------------------------------------------------------------------------
# commands

def cpp_strings(expr):
    """The concatenated string literals of a C++ expression."""
    return "".join(re.findall(r'"((?:[^"\\]|\\.)*)"', expr)).replace("\\n", "\n").replace('\\"', '"')


def parse_command_file(path):
    with open(path, encoding="utf-8") as f:
        text = f.read()
    head = []
    for line in text.split("\n"):
        if line.startswith("//"):
            head.append(line[2:].strip())
        else:
            break
    regs = []
    for m in re.finditer(r'LanderCommand\s+\w+\s*\(\s*("(?:[^"\\]|\\.)*")\s*,\s*((?:"(?:[^"\\]|\\.)*"\s*)+|\w+)\s*,\s*Kind::(\w+)',
                         text):
        summary = cpp_strings(m.group(2)) if m.group(2).startswith('"') else None
        if summary is None:
            c = re.search(r"\b%s\b\s*(?:\[\])?\s*=\s*((?:\"(?:[^\"\\]|\\.)*\"\s*)+);" % re.escape(m.group(2)), text)
            summary = cpp_strings(c.group(1)) if c else m.group(2)
        regs.append((cpp_strings(m.group(1)), summary, m.group(3)))
    parsers = []
    for m in re.finditer(r"ArgParser\s+\w+\s*\(\s*\w+\s*,\s*\{([^}]*)\}\s*,\s*\{([^}]*)\}", text):
        values = re.findall(r'"([^"]+)"', m.group(1))
        flags = re.findall(r'"([^"]+)"', m.group(2))
        fn = None
        before = text[:m.start()]
        fm = list(re.finditer(r"^(?:int|static int)\s+(\w+)\s*\(", before, re.M))
        if fm:
            fn = fm[-1].group(1)
        parsers.append((fn, values, flags, text.count("\n", 0, m.start()) + 1))
    usages = []
    for m in re.finditer(r'"(usage:(?:[^"\\]|\\.)*)"((?:\s*"(?:[^"\\]|\\.)*")*)', text):
        u = cpp_strings('"' + m.group(1) + '"' + m.group(2))
        if u not in usages:
            usages.append(u)
    return head, regs, parsers, usages


def write_cli_page(path, lander, repo):
    r = lander.text("--help")
    if r.returncode != 0:
        raise GenError("lander --help failed: " + r.stderr)
    help_text = r.stdout.rstrip()
    files = sorted(f for f in os.listdir(os.path.join(repo, "tools", "lander")) if f.startswith("cmd_") and f.endswith(".cpp"))
    lines = ["# Commands", "",
             "Generated by `tools/docs/gen_reference.py` (regenerate: `%s`; a CTest test fails when this "
             "page differs from what the code gives)." % REGEN, "",
             "The method: `lander --help` as the binary prints it; then, for each command's source "
             "file under `tools/lander/`, the comment at its top, its registration (name and summary), "
             "its usage strings, and the options of each `ArgParser` it builds (`--name VALUE` options "
             "and flags). How to use them: [Getting started](../guide/getting-started.md).", "",
             "```", help_text, "```", ""]
    registered = set()
    for fn in files:
        head, regs, parsers, usages = parse_command_file(os.path.join(repo, "tools", "lander", fn))
        names = ", ".join(("bench " if k == "Bench" else "") + n for n, _, k in regs) or fn
        for n, _, k in regs:
            registered.add((n, k))
        lines += ["## `lander %s`" % names if regs else "## `%s`" % fn, "",
                  "Source: `tools/lander/%s`." % fn, ""]
        if head:
            lines += ["> " + prose(h) if h else ">" for h in head]
            lines.append("")
        for n, s, k in regs:
            lines.append("- summary (`lander --help`): %s" % md(s))
        if usages:
            lines += ["", "Usage strings:", "", "```"] + [u.rstrip() for u in usages] + ["```"]
        if parsers:
            lines += ["", "| options of | takes a value | flags |", "|---|---|---|"]
            for f_, values, flags, line in parsers:
                lines.append("| %s | %s | %s |" % (code(f_ or "line %d" % line),
                                                   ", ".join(code("--" + v) for v in values) or "none",
                                                   ", ".join(code("--" + x) for x in flags) or "none"))
        lines.append("")
    # every command the binary lists must come from a parsed registration
    listed = re.findall(r"^  (\S+)\n      ", help_text + "\n", re.M)
    for name in listed:
        if name != "bench" and (name, "Command") not in registered:
            raise GenError("lander --help lists '%s', which no tools/lander/cmd_*.cpp registers as parsed" % name)
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines).rstrip() + "\n")


def write_transitions_page(path, lander):
    r = lander.text("docs", "transitions")
    if r.returncode != 0:
        raise GenError("lander docs transitions failed (exit %d): %s" % (r.returncode, r.stderr[-2000:]))
    table = json.loads(r.stdout)
    lines = ["# Mode transitions", "",
             "Generated by `tools/docs/gen_reference.py` from `lander docs transitions` (regenerate: `%s`)." % REGEN,
             "", "The landing mode machine's transition table, `ctl::mode_transitions()` "
             "(`controller/src/modes/transitions.cpp`): the machine refuses any switch not listed "
             "here, and a switch back to a mode already left within the same outer step "
             "(`ModeMachineError`, the run ends with both reasons). What each mode does and the "
             "reasons it writes: [Landing modes](../design/landing-modes.md); the diagram there is "
             "drawn from this table (`tools/docs/mode_diagram.py --lander build/lander`).", "",
             "| from | to | trigger |", "|---|---|---|"]
    for row in table:
        lines.append("| `%s` | `%s` | %s |" % (row["from"], row["to"], md(row["trigger"])))
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    return len(table)


# ---------------------------------------------------------------------------------------------

def generate(lander_exe, repo, out):
    structs = cxx_params.parse_tree(repo)
    os.makedirs(out, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="gen-reference-")
    try:
        lander = Lander(os.path.abspath(lander_exe), repo, tmp)
        scen = lander.resolved_defaults()
        flight_in_class = lander.flight_defaults()
        specs = lander.visitor_keys()
        leaves = flatten(scen)
        # probes
        # First pass: every key at its first probe value (-1e9, a nonsense word); second pass:
        # +1e9 for the numeric keys whose first answer did not already state both bounds.
        probes = {key: [] for key, _ in leaves}
        values = {key: probe_values(v) for key, v in leaves}
        first = [(k, vs[0]) for k, vs in values.items() if vs]
        for (key, pv), (ok, msg) in zip(first, lander.validate_all(first)):
            probes[key].append((pv, ok, msg))
        second = [(k, values[k][1]) for k, res in probes.items()
                  if len(values[k]) > 1 and not (not res[0][1] and TWO_SIDED.search(res[0][2]))]
        for (key, pv), (ok, msg) in zip(second, lander.validate_all(second)):
            probes[key].append((pv, ok, msg))
        sdocs = key_docs(structs, "Scenario", "")
        # scenario page: everything but flight
        plant = [(k, v) for k, v in leaves if not k.startswith("flight.")]
        rows = section_rows(plant, sdocs, probes, specs)
        for lst in sorted({k for k, v in plant if isinstance(v, list) and (k + "[]") in sdocs}):
            items = list_item_rows(sdocs, lst, specs)
            idx = max(i for i, r in enumerate(rows) if r["key"] == lst)
            rows[idx + 1:idx + 1] = items
        missing = [k for k, _ in leaves if k not in sdocs and k + "[]" not in sdocs]
        if missing:
            raise GenError("keys of scenario.resolved.yaml that no visit_fields() lists: %s" % missing[:10])
        intro = ("Every key of a scenario file (`scenarios/*.yaml`) outside its `flight:` section: the "
                 "plant's truth. The flight software's keys are on "
                 "[Flight-configuration keys](flight-config-keys.md); how scenarios work is in "
                 "[Scenarios](../guide/scenarios.md).\n\n"
                 + METHOD_KEYS.format(regen=REGEN, flight_note="", limit=220)
                 + "- keys of a list's items (`key[].field`) are listed after the list with the field's "
                 "in-class initializer; they are not probed.\n")
        write_key_page(os.path.join(out, "scenario-keys.md"), "Scenario keys", intro, rows, sdocs, structs, 1)
        # flight page
        fl = [(k, v) for k, v in leaves if k.startswith("flight.")]
        fin = dict(flatten(flight_in_class))
        note = {}
        for k, v in fl:
            rel = k[len("flight."):]
            if rel in fin and fin[rel] != v:
                note[k] = "(in-class default: %s)" % fmt_value(fin[rel])
        extra = sorted(set("flight." + k for k in fin) - set(k for k, _ in fl))
        if extra:
            raise GenError("flight-config --defaults has keys the scenario does not: %s" % extra[:10])
        frows = section_rows(fl, sdocs, probes, specs, note)
        fintro = ("Every key of the flight configuration: what the flight software believes. "
                  "`models/flight.yaml` holds the nominal values, a scenario overrides them under "
                  "`flight:` (so the key `camera.k1` here is `flight.camera.k1` in a scenario), "
                  "`lander flight-config SCENARIO` prints the result and every closed-loop run writes it "
                  "as `flight.resolved.yaml`.\n\n"
                  + METHOD_KEYS.format(regen=REGEN, flight_note=" (its `flight:` section: the values of "
                                       "`models/flight.yaml`; where `lander flight-config --defaults`, the "
                                       "in-class defaults, differs, both are given)", limit=220))
        write_key_page(os.path.join(out, "flight-config-keys.md"), "Flight-configuration keys", fintro, frows,
                       sdocs, structs, 3, strip="flight.")
        # summary and trace
        write_summary_page(os.path.join(out, "summary-json.md"), repo, summary_runs(lander, repo, tmp))
        # commands
        write_cli_page(os.path.join(out, "cli.md"), lander, repo)
        n_transitions = write_transitions_page(os.path.join(out, "mode-transitions.md"), lander)
        # index
        suffixes = "\n".join("| `%s` | %s |" % (s, u) for s, u in SUFFIXES)
        index = f"""# Reference

Generated from the code by `tools/docs/gen_reference.py`; do not edit these pages by hand.
Regenerate them after changing a key, a default, a validation, a summary field or a command,
and commit the result:

```sh
{REGEN}
```

The CTest test `docs_reference_matches_code` regenerates into a temporary directory and fails
when the committed pages differ.

- [Scenario keys](scenario-keys.md): {len(plant)} plant keys (the world, the camera as it
  images, the cart, the vehicle, the sensors, the wind, faults, video).
- [Flight-configuration keys](flight-config-keys.md): {len(fl)} keys of what the flight
  software believes (`flight:` in a scenario, `models/flight.yaml`).
- [summary.json and trace.csv](summary-json.md): every field of a run's summary and every
  trace column.
- [Commands](cli.md): every `lander` command and its options.
- [Mode transitions](mode-transitions.md): the {n_transitions} switches the landing mode machine
  may make, the table it enforces.

Each page states its method at the top. The unit suffixes the key names use:

| suffix | unit |
|---|---|
{suffixes}
"""
        with open(os.path.join(out, "index.md"), "w", encoding="utf-8") as f:
            f.write(index)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


PAGES = ("index.md", "scenario-keys.md", "flight-config-keys.md", "summary-json.md", "cli.md", "mode-transitions.md")


def main():
    ap = argparse.ArgumentParser(description="Generates docs/reference/ from the code.")
    ap.add_argument("--lander", required=True, help="the lander binary (build/lander)")
    ap.add_argument("--repo", default=REPO, help="the source tree the binary was built from")
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--out", help="write the pages into this directory")
    g.add_argument("--check", help="compare the pages in this directory with what the code generates")
    a = ap.parse_args()
    if not os.access(a.lander, os.X_OK):
        sys.stderr.write("gen_reference: %s is not an executable lander binary (build it first)\n" % a.lander)
        return 2
    try:
        if a.out:
            generate(a.lander, os.path.abspath(a.repo), a.out)
            print("gen_reference: wrote %s" % ", ".join(os.path.join(a.out, p) for p in PAGES))
            return 0
        with tempfile.TemporaryDirectory(prefix="reference-") as fresh:
            generate(a.lander, os.path.abspath(a.repo), fresh)
            bad = 0
            for p in PAGES:
                committed = os.path.join(a.check, p)
                new = open(os.path.join(fresh, p), encoding="utf-8").read().splitlines(True)
                old = open(committed, encoding="utf-8").read().splitlines(True) if os.path.exists(committed) else []
                if old != new:
                    bad += 1
                    sys.stdout.writelines(difflib.unified_diff(old, new, committed, "generated/" + p, n=1))
            extra = sorted(set(f for f in os.listdir(a.check) if f.endswith(".md")) - set(PAGES))
            for e in extra:
                bad += 1
                print("gen_reference: %s is not generated (remove it)" % os.path.join(a.check, e))
            if bad:
                print("gen_reference: %d page(s) of %s differ from the code; regenerate with: %s"
                      % (bad, a.check, REGEN))
                return 1
            print("gen_reference: %s matches the code (%d pages)" % (a.check, len(PAGES)))
            return 0
    except GenError as e:
        sys.stderr.write("gen_reference: %s\n" % e)
        return 1


if __name__ == "__main__":
    sys.exit(main())

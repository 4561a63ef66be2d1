#!/usr/bin/python3
"""Generates bounded wire checkers for LCM types from their .lcm definitions.

Usage: lcm_wire_bounds.py OUTPUT.hpp FILE.lcm...

For every struct of every .lcm file the output header has a checker that walks an encoded
message without allocating: each string length and array count is checked against the bytes
that remain (count x the element's minimal encoded size) before the walk goes on, negative
counts and lengths are refused, nested structs are checked field by field. lcm-gen's C++
decode allocates a vector of the claimed count before it finds the message short; a message
the checker accepts decodes with allocations bounded by its own size.

The output also holds a table of every type (name, fingerprint, minimal size, default
encoding and the offsets of its count fields in that encoding) so that tests cover each type,
including types added later, without naming them.

LCM wire format (lcm-proj.github.io, "LCM Type Specification"): 8-byte fingerprint, then the
fields in declaration order, big-endian; string = int32 length including the NUL, the bytes,
the NUL; boolean and byte 1 byte; an array dimension is an integer literal or an earlier
integer field of the same struct.
"""
import os
import re
import sys

PRIMITIVE_SIZE = {
    "int8_t": 1, "int16_t": 2, "int32_t": 4, "int64_t": 8,
    "byte": 1, "boolean": 1, "float": 4, "double": 8,
}
INTEGER_TYPES = {"int8_t", "int16_t", "int32_t", "int64_t"}
STRING_MIN_SIZE = 5  # int32 length + NUL


class LcmError(Exception):
    pass


def strip_comments(text):
    text = re.sub(r"/\*.*?\*/", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


class Field:
    def __init__(self, type_name, name, dims):
        self.type = type_name  # primitive, "string", or qualified struct name "pkg.type"
        self.name = name
        self.dims = dims       # list of int (fixed) or str (earlier field name)


class Struct:
    def __init__(self, package, name, path):
        self.package = package
        self.name = name
        self.path = path
        self.fields = []
        self.consts = {}

    @property
    def full(self):
        return f"{self.package}.{self.name}" if self.package else self.name

    @property
    def cpp(self):
        return f"{self.package}::{self.name}" if self.package else self.name


def parse_file(path):
    text = strip_comments(open(path, encoding="utf-8").read())
    package = ""
    m = re.search(r"\bpackage\s+([\w.]+)\s*;", text)
    if m:
        package = m.group(1)
    structs = []
    for sm in re.finditer(r"\bstruct\s+(\w+)\s*\{(.*?)\}", text, flags=re.S):
        st = Struct(package, sm.group(1), path)
        for stmt in sm.group(2).split(";"):
            stmt = " ".join(stmt.split())
            if not stmt:
                continue
            if stmt.startswith("const "):
                cm = re.fullmatch(r"const\s+(\w+)\s+(.*)", stmt)
                for part in cm.group(2).split(","):
                    name, value = (s.strip() for s in part.split("="))
                    st.consts[name] = value
                continue
            fm = re.fullmatch(r"([\w.]+)\s+(.*)", stmt)
            if not fm:
                raise LcmError(f"{path}: struct {st.name}: cannot parse '{stmt}'")
            type_name = fm.group(1)
            for decl in fm.group(2).split(","):
                decl = decl.strip()
                dm = re.fullmatch(r"(\w+)\s*((?:\[\s*\w+\s*\]\s*)*)", decl)
                if not dm:
                    raise LcmError(f"{path}: struct {st.name}: cannot parse field '{decl}'")
                dims = []
                for d in re.findall(r"\[\s*(\w+)\s*\]", dm.group(2)):
                    dims.append(int(d, 0) if re.fullmatch(r"\d+|0x[0-9a-fA-F]+", d) else d)
                st.fields.append(Field(type_name, dm.group(1), dims))
        structs.append(st)
    if not structs:
        raise LcmError(f"{path}: no struct found")
    return structs


def resolve(structs):
    by_name = {s.full: s for s in structs}
    for s in structs:
        seen = {}
        for f in s.fields:
            if f.type not in PRIMITIVE_SIZE and f.type != "string":
                full = f.type if "." in f.type else (f"{s.package}.{f.type}" if s.package else f.type)
                if full not in by_name:
                    raise LcmError(f"{s.path}: {s.name}.{f.name}: unknown type {f.type}")
                f.type = full
            for i, d in enumerate(f.dims):
                if isinstance(d, str):
                    if d in s.consts:
                        f.dims[i] = int(s.consts[d], 0)
                    elif d not in seen or seen[d] not in INTEGER_TYPES:
                        raise LcmError(f"{s.path}: {s.name}.{f.name}: dimension '{d}' is not an earlier integer field")
            if not f.dims:
                seen[f.name] = f.type
    return by_name


def min_size(type_name, by_name, memo, stack=()):
    if type_name in PRIMITIVE_SIZE:
        return PRIMITIVE_SIZE[type_name]
    if type_name == "string":
        return STRING_MIN_SIZE
    if type_name in memo:
        return memo[type_name]
    if type_name in stack:
        raise LcmError(f"recursive type {type_name}")
    total = 0
    for f in by_name[type_name].fields:
        n = 1
        for d in f.dims:
            n *= d if isinstance(d, int) else 0
        total += n * min_size(f.type, by_name, memo, stack + (type_name,))
    memo[type_name] = total
    return total


def count_fields(st, by_name, memo, base, prefix):
    """(path, offset, width, is_string) of every array count and string length in the default
    encoding of st at `base`."""
    out = []
    pos = base
    dim_fields = {d for f in st.fields for d in f.dims if isinstance(d, str)}
    for f in st.fields:
        if f.name in dim_fields and not f.dims:
            out.append((prefix + f.name, pos, PRIMITIVE_SIZE[f.type], "false"))
        if f.type == "string" and not f.dims:
            out.append((prefix + f.name, pos, 4, "true"))
        n = 1
        for d in f.dims:
            n *= d if isinstance(d, int) else 0
        if f.type in by_name:
            for _ in range(n):
                sub = count_fields(by_name[f.type], by_name, memo, pos, prefix + f.name + ("[]." if f.dims else "."))
                out.extend(sub)
                pos += min_size(f.type, by_name, memo)
        else:
            pos += n * min_size(f.type, by_name, memo)
    return out


def ident(st):
    return st.full.replace(".", "_")


def gen_checker(st, by_name, memo):
    lines = [f"inline bool check_{ident(st)}(WireReader& r) {{"]
    counts = {d for f in st.fields for d in f.dims if isinstance(d, str)}
    for f in st.fields:
        label = f"{st.name}.{f.name}" + "".join(f"[{d}]" for d in f.dims)
        if not f.dims and f.name in counts:
            w = PRIMITIVE_SIZE[f.type]
            lines.append(f"  std::int64_t {f.name} = 0;")
            lines.append(f'  if (!r.integer({w}, "{label}", {f.name})) return false;')
            continue
        elem_min = max(1, min_size(f.type, by_name, memo))
        if f.dims:
            dims = ", ".join(str(d) if isinstance(d, int) else f"{d}" for d in f.dims)
            lines.append("  {")
            lines.append(f"    const std::int64_t dims[] = {{{dims}}};")
            lines.append("    std::int64_t n = 0;")
            lines.append(f'    if (!r.array("{label}", dims, {elem_min}, n)) return false;')
            if f.type in PRIMITIVE_SIZE:
                lines.append(f'    if (!r.skip(static_cast<std::size_t>(n) * {PRIMITIVE_SIZE[f.type]}, "{label}")) return false;')
            elif f.type == "string":
                lines.append(f'    for (std::int64_t i = 0; i < n; ++i) if (!r.string("{label}")) return false;')
            else:
                lines.append(f"    for (std::int64_t i = 0; i < n; ++i) if (!check_{ident(by_name[f.type])}(r)) return false;")
            lines.append("  }")
        elif f.type in PRIMITIVE_SIZE:
            lines.append(f'  if (!r.skip({PRIMITIVE_SIZE[f.type]}, "{label}")) return false;')
        elif f.type == "string":
            lines.append(f'  if (!r.string("{label}")) return false;')
        else:
            lines.append(f"  if (!check_{ident(by_name[f.type])}(r)) return false;")
    lines.append("  return true;")
    lines.append("}")
    return "\n".join(lines)


def main(argv):
    if len(argv) < 3:
        sys.stderr.write("usage: lcm_wire_bounds.py OUTPUT.hpp FILE.lcm...\n")
        return 2
    out_path, files = argv[1], sorted(argv[2:])
    try:
        structs = [s for p in files for s in parse_file(p)]
        by_name = resolve(structs)
        memo = {}
        for s in structs:
            min_size(s.full, by_name, memo)
    except (LcmError, OSError, ValueError) as e:
        sys.stderr.write(f"lcm_wire_bounds.py: {e}\n")
        return 1
    o = []
    o.append("// Generated by services/lcm/gen/lcm_wire_bounds.py from " + ", ".join(os.path.basename(p) for p in files) + ".")
    o.append("// Do not edit. Bounded wire checkers for every LCM type (see motion/lcm/wire_reader.hpp).")
    o.append("#pragma once\n")
    o.append("#include <cstddef>\n#include <cstdint>\n#include <vector>\n")
    for s in structs:
        o.append(f"#include <{s.package.replace('.', '/') + '/' if s.package else ''}{s.name}.hpp>")
    o.append('\n#include "motion/lcm/wire_reader.hpp"\n')
    o.append("namespace motion::lcm::wire {\n")
    for s in structs:
        o.append(f"inline bool check_{ident(s)}(WireReader& r);")
    o.append("")
    for s in structs:
        o.append(gen_checker(s, by_name, memo))
        o.append("")
    for s in structs:
        o.append(f"template <> struct Bounds<{s.cpp}> {{")
        o.append(f'  static constexpr const char* kName = "{s.full}";')
        o.append(f"  static constexpr std::size_t kMinSize = 8 + {memo[s.full]};")
        o.append(f"  static bool check_body(WireReader& r) {{ return check_{ident(s)}(r); }}")
        o.append("};\n")
    o.append("// Every type of the .lcm files, for tests and fuzzers.")
    o.append("inline const std::vector<TypeInfo>& all_types() {")
    o.append("  static const std::vector<TypeInfo> types = {")
    for s in structs:
        cf = count_fields(s, by_name, memo, 8, "")
        cfs = ", ".join(f'{{"{p}", {off}, {w}, {st}}}' for p, off, w, st in cf)
        o.append(f'      {{"{s.full}", "{os.path.basename(s.path)}", &check_message<{s.cpp}>, &decode_to_temporary<{s.cpp}>, &decode_unchecked<{s.cpp}>, &encode_default<{s.cpp}>, {{{cfs}}}}},')
    o.append("  };")
    o.append("  return types;")
    o.append("}\n")
    o.append("}  // namespace motion::lcm::wire")
    text = "\n".join(o) + "\n"
    try:
        if open(out_path, encoding="utf-8").read() == text:
            return 0
    except OSError:
        pass
    os.makedirs(os.path.dirname(out_path) or ".", exist_ok=True)
    with open(out_path, "w", encoding="utf-8") as fh:
        fh.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

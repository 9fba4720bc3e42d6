"""The message contract (lcmtypes/*.lcm) parsed, for the build's code generators.

lib/logtools/gen_reflect.py (field reflection) and lib/runtime/gen_wire_check.py
(the validator every subscription runs before the lcm-gen decoder) both read
the .lcm files through this module, so they agree on what a message is.
Covers the LCM subset the contract uses and fails loudly on anything else.
"""
import re

# Encoded size in bytes of each primitive; a string is a length then bytes.
PRIM_SIZES = {
    "int8_t": 1, "int16_t": 2, "int32_t": 4, "int64_t": 8, "byte": 1,
    "float": 4, "double": 8, "boolean": 1,
}
INT_TYPES = {"int8_t", "int16_t", "int32_t", "int64_t", "byte"}
STRING_MIN_SIZE = 5  # int32 length (which counts the terminating NUL) + the NUL


class Field:
    def __init__(self, ftype, name, dims):
        self.type = ftype   # primitive, "string", or a struct name (package dropped)
        self.name = name
        self.dims = dims    # list of "3" (fixed) or "num_x" (an earlier integer field)

    def __repr__(self):
        return f"Field({self.type} {self.name}{''.join('[' + d + ']' for d in self.dims)})"


class Struct:
    def __init__(self, package, name, fields):
        self.package = package
        self.name = name
        self.fields = fields

    @property
    def cpp(self):
        return f"::{self.package}::{self.name}"

    @property
    def full_name(self):
        return f"{self.package}.{self.name}"


def parse_file(path):
    text = open(path).read()
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    pkg = re.search(r"package\s+(\w+)\s*;", text)
    pkg = pkg.group(1) if pkg else ""
    structs = []
    for m in re.finditer(r"struct\s+(\w+)\s*\{(.*?)\}", text, flags=re.S):
        name, body = m.group(1), m.group(2)
        fields = []
        for stmt in body.split(";"):
            stmt = stmt.strip()
            if not stmt or stmt.startswith("const "):
                continue
            fm = re.match(r"([\w.]+)\s+(\w+)\s*((?:\[\s*\w+\s*\]\s*)*)$", stmt, flags=re.S)
            if not fm:
                raise SystemExit(f"{path}: cannot parse field '{stmt}'")
            ftype, fname, dims = fm.group(1), fm.group(2), fm.group(3)
            dims = re.findall(r"\[\s*(\w+)\s*\]", dims)
            if "." in ftype:
                ftype = ftype.split(".")[-1]
            known = {f.name: f for f in fields}
            for d in dims:
                if d.isdigit():
                    continue
                # LCM requires the count to be an earlier scalar integer field.
                c = known.get(d)
                if c is None or c.type not in INT_TYPES or c.dims:
                    raise SystemExit(f"{path}: {name}.{fname}: dimension '{d}' is not an earlier integer field")
            fields.append(Field(ftype, fname, dims))
        structs.append(Struct(pkg, name, fields))
    return structs


def parse(files):
    """All structs of the given files, ordered so nested types come first."""
    structs = []
    for f in sorted(files):
        structs += parse_file(f)
    by_name = {s.name: s for s in structs}
    ordered, done = [], set()

    def visit(s, stack=()):
        if s.name in done:
            return
        if s.name in stack:
            raise SystemExit(f"recursive message type {s.name}")
        for f in s.fields:
            if f.type in PRIM_SIZES or f.type == "string":
                continue
            if f.type not in by_name:
                raise SystemExit(f"{s.name}.{f.name}: unknown type {f.type}")
            visit(by_name[f.type], stack + (s.name,))
        done.add(s.name)
        ordered.append(s)

    for s in structs:
        visit(s)
    return ordered


def min_encoded_size(ftype, by_name):
    """Fewest bytes one element of ftype takes encoded (no fingerprint)."""
    if ftype in PRIM_SIZES:
        return PRIM_SIZES[ftype]
    if ftype == "string":
        return STRING_MIN_SIZE
    total = 0
    for f in by_name[ftype].fields:
        n = 1
        for d in f.dims:
            n = n * int(d) if d.isdigit() else 0
        total += n * min_encoded_size(f.type, by_name)
    return total

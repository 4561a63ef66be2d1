#!/usr/bin/python3
"""The house naming rules that clang-format cannot see, checked over every file in git.

1. Enumerators: kCamelCase (`enum class Lifecycle { kLoading, kArmed }`), one style everywhere.
2. Test sources under tests/unit and tests/integration: `<topic>_test.cpp`.
3. A drive family's passive stack: class `<Family>Stack` (deriving from gateway::CanStack or
   gateway::SerialStack), declared in `<family>_stack.hpp`, its sources `<family>_stack*.cpp`.

Usage: house_rules.py [--list-enumerators]   exit 1 with one line per violation.
Generated code (LCM types) is not in git and so not checked.
"""
import re
import subprocess
import sys
from pathlib import Path

ENUM_RE = re.compile(r"\benum\s+(?:class|struct)?\s*(\w+)?\s*(?::\s*[\w:\s]+?)?\{([^{}]*)\}", re.S)
ENUMERATOR_RE = re.compile(r"^k[A-Z0-9][A-Za-z0-9]*$")
STACK_RE = re.compile(r"\bclass\s+(\w+)\s+(?:final\s+)?:\s*public\s+(?:gateway::)?(CanStack|SerialStack)\b")


def strip_comments(text: str) -> str:
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return re.sub(r'"(?:\\.|[^"\\\n])*"', '""', text)


def enumerators(body: str):
    for item in body.split(","):
        name = item.split("=")[0].strip()
        if name:
            yield name


def main() -> int:
    root = Path(subprocess.check_output(["git", "rev-parse", "--show-toplevel"], text=True).strip())
    files = subprocess.check_output(["git", "ls-files", "*.cpp", "*.hpp", "*.h"], cwd=root, text=True).split()
    problems = []
    for rel in files:
        text = strip_comments((root / rel).read_text(encoding="utf-8", errors="replace"))
        for m in ENUM_RE.finditer(text):
            line = text.count("\n", 0, m.start()) + 1
            for name in enumerators(m.group(2)):
                if not ENUMERATOR_RE.match(name):
                    problems.append(f"{rel}:{line}: enumerator '{name}' of enum {m.group(1) or '(anonymous)'} is not kCamelCase")
        for m in STACK_RE.finditer(text) if rel.startswith("gateway/") else []:
            cls = m.group(1)
            family = re.sub(r"Stack$", "", cls)
            if not cls.endswith("Stack") or not family:
                problems.append(f"{rel}: drive stack class '{cls}' is not named <Family>Stack")
            elif not rel.endswith(f"/{family.lower()}_stack.hpp"):
                problems.append(f"{rel}: drive stack class '{cls}' belongs in {family.lower()}_stack.hpp")
        if re.match(r"tests/(unit|integration)/", rel) and rel.endswith(".cpp"):
            base = Path(rel).name
            if base.startswith("test_"):
                problems.append(f"{rel}: test sources are named <topic>_test.cpp")
    for p in problems:
        print(p)
    if problems:
        print(f"error: {len(problems)} house-rule violation(s)", file=sys.stderr)
        return 1
    print(f"==> house rules: {len(files)} C++ files (enumerators, test and stack names)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

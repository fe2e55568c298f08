#!/usr/bin/env python3
"""Fails when a function of the project's code (not its tests) is longer than
100 lines from its opening line to its closing brace.

Functions are found as clang-format (Google) lays them out: the body's
opening brace ends the line that closes the parameter list (`) {`,
`) const {`, `) override {`, `... requires ... {`, a constructor's
initializer list). Comments, strings and raw strings are blanked first, so
no brace inside them counts. A block opened inside a function is part of
it; a lambda at namespace scope counts as a function of its own.
"""
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
LIMIT = 100
SKIP = {"build", "build-asan", "build-fuzz", "tests", "third_party", ".git"}
OPENS_BODY = re.compile(
    r"\)\s*(const\s*)?(noexcept\s*)?(override\s*)?(final\s*)?"
    r"(->\s*[\w:<>, ]+\s*)?(requires\b.*)?\{\s*$")
CONTROL = re.compile(r"^\s*(if|for|while|switch|else|do|catch)\b")


def blank(text):
    """The text with comments, strings and character literals blanked (their
    newlines kept)."""
    pattern = re.compile(
        r'R"(?P<d>[^(\s]*)\(.*?\)(?P=d)"'  # raw string
        r'|//[^\n]*'  # line comment
        r'|/\*.*?\*/'  # block comment
        r'|"(?:[^"\\\n]|\\.)*"'  # string
        r"|'(?:[^'\\\n]|\\.)*'",  # character
        re.S)
    return pattern.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)


def long_functions(path):
    lines = blank(path.read_text(errors="replace")).split("\n")
    depth = 0
    start = None
    start_depth = 0
    found = []
    for number, line in enumerate(lines, 1):
        if (start is None and OPENS_BODY.search(line) and
                not CONTROL.match(line)):
            start, start_depth = number, depth
        depth += line.count("{") - line.count("}")
        if start is not None and depth <= start_depth:
            if number - start + 1 > LIMIT:
                found.append((start, number - start + 1))
            start = None
    return found


def main():
    failures = []
    for path in sorted(ROOT.rglob("*")):
        relative = path.relative_to(ROOT)
        if relative.parts[0] in SKIP or path.suffix not in (".cc", ".h"):
            continue
        for line, length in long_functions(path):
            failures.append(f"{relative}:{line}: a function of {length} lines "
                            f"(at most {LIMIT}): split it into named stages")
    for failure in failures:
        print(failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Fails when a function of the project's code (the tracked sources and
headers, tests aside) is longer than 100 lines from the first line of its
signature to its closing brace.

Comments, strings, raw strings and character literals are blanked first, so
no brace inside them counts. A function body is a brace that ends a line
whose statement (the lines since the last one ending in `;`, `{`, `}` or
`:`, or a preprocessor line) has a parameter list: a `(` before it, no
class, struct, union, enum or namespace before that `(`, no `=` before it
but in an operator's name, no control keyword first, and every `(` closed.
Blocks and lambdas inside a function are part of it. A file whose braces do
not balance fails too (the count would be wrong after it).
"""
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
LIMIT = 100
CONTROL = re.compile(r"^\s*(\}\s*)?(if|for|while|switch|else|do|catch|try)\b")
TYPE_KEYWORD = re.compile(r"\b(class|struct|union|enum|namespace)\b")


def blank(text):
    """The text with comments, strings and character literals blanked (their
    newlines kept)."""
    pattern = re.compile(
        r'R"(?P<d>[^(\s]*)\(.*?\)(?P=d)"'  # raw string
        r'|//[^\n]*'  # line comment
        r'|/\*.*?\*/'  # block comment
        r'|"(?:[^"\\\n]|\\.)*"'  # string
        r"|(?<![0-9A-Fa-f])'(?:[^'\\\n]|\\.)*'",  # character, not 1'000
        re.S)
    return pattern.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)


def opens_function(statement):
    if CONTROL.match(statement):
        return False
    paren = statement.find("(")
    if paren < 0 or TYPE_KEYWORD.search(statement[:paren]):
        return False
    if "=" in statement[:paren] and "operator" not in statement[:paren]:
        return False
    return statement.count("(") == statement.count(")")


def long_functions(text):
    """(first line, length) of each function over LIMIT lines, and whether
    the braces balance."""
    found = []
    depth = 0
    start = None  # (first line, depth outside) of the function we are in
    statement, first = "", None
    for number, line in enumerate(blank(text).split("\n"), 1):
        code = line.strip()
        if code.startswith("#"):
            statement, first = "", None
            continue
        if code and first is None:
            first = number
        statement += " " + code
        if start is None and code.endswith("{") and opens_function(
                statement.strip()[:-1]):
            start = (first, depth)
        depth += code.count("{") - code.count("}")
        if start is not None and depth <= start[1]:
            if number - start[0] + 1 > LIMIT:
                found.append((start[0], number - start[0] + 1))
            start = None
        if code.endswith((";", "{", "}", ":")):
            statement, first = "", None
    return found, depth == 0 and start is None


def main():
    files = subprocess.run(["git", "ls-files", "*.cc", "*.h"], cwd=ROOT,
                           capture_output=True, text=True,
                           check=True).stdout.split()
    failures = []
    for name in files:
        if name.startswith("tests/"):
            continue
        found, balanced = long_functions(
            (ROOT / name).read_text(errors="replace"))
        for line, length in found:
            failures.append(f"{name}:{line}: a function of {length} lines "
                            f"(at most {LIMIT}): split it into named stages")
        if not balanced:
            failures.append(f"{name}: its braces do not balance (outside "
                            "comments and strings): cannot measure its "
                            "functions")
    for failure in failures:
        print(failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Fails when a function body in modules/ runs longer than a limit (default 150 lines).

A function body is a brace block whose opening brace follows a parameter list, outside any
other function body; lambdas and local classes count toward the function that holds them.
Comments, string and character literals are blanked first so their braces do not count.
clang-tidy's readability-function-size does the same from a full parse, which costs minutes
per translation unit on PCL's headers; this brace scan costs a second for the whole tree.

usage: check-function-size.py [--max-lines N] [--list N] [paths...]
"""
import argparse
import pathlib
import re
import sys

SOURCE_SUFFIXES = {".h", ".hpp", ".cpp"}
CONTROL = {"if", "for", "while", "switch", "catch", "return", "sizeof", "decltype",
           "alignof", "static_assert", "defined"}
SCOPE = re.compile(r"\b(namespace|class|struct|union|enum)\b|extern\s*\"C\"")
# What may stand between a parameter list and a body: qualifiers, a trailing return type,
# or a constructor's member-initialiser list.
TRAILER = re.compile(r"^\s*(const|noexcept(\s*\([^)]*\))?|override|final|mutable|volatile|&|&&|"
                     r"->\s*[\w:<>,\s*&]+)*\s*$")


def blank_comments_and_literals(text):
    """Replaces comments and literals by spaces, keeping newlines so line numbers hold."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == 'R' and text.startswith('R"', i) and (i == 0 or not text[i - 1].isalnum()):
            k = text.find("(", i)
            delim = ")" + text[i + 2:k] + '"'
            j = text.find(delim, k)
            j = n if j < 0 else j + len(delim)
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                out.append(c)
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + " " * (min(j, n) - i - 1) + (c if j < n else ""))
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def opens_function(head):
    """True when the text before a '{' ends like a function signature."""
    head = head.rstrip()
    if SCOPE.search(head) and not head.endswith(")"):
        return False
    # Strip a constructor's member-initialiser list: ") : a_ (x), b_ {y}".
    depth = 0
    close = -1
    for k in range(len(head) - 1, -1, -1):
        ch = head[k]
        if ch in ")]}>":
            depth += 1
        elif ch in "([{<":
            depth -= 1
        elif ch == ":" and depth == 0 and (k == 0 or head[k - 1] != ":") and \
                (k + 1 >= len(head) or head[k + 1] != ":"):
            before = head[:k].rstrip()
            if before.endswith(")"):
                head = before
            break
    if not TRAILER.match(head[head.rfind(")") + 1:] if ")" in head else "x"):
        return False
    # Find the '(' matching the last ')' and the name before it.
    depth = 0
    for k in range(len(head) - 1, -1, -1):
        if head[k] == ")":
            depth += 1
        elif head[k] == "(":
            depth -= 1
            if depth == 0:
                before = head[:k].rstrip()
                if before.endswith("]"):  # lambda
                    return False
                name = re.search(r"([~\w]+|operator\s*\S+)\s*$", before)
                return bool(name) and name.group(1) not in CONTROL
    return False


def functions(path):
    text = blank_comments_and_literals(path.read_text(encoding="utf-8", errors="replace"))
    # Preprocessor lines never open bodies.
    text = re.sub(r"(?m)^\s*#.*$", lambda m: " " * len(m.group(0)), text)
    stack = []  # entries: "scope", "func", "block"
    head_start = 0
    for i, c in enumerate(text):
        if c == "{":
            inside_function = any(kind == "func" for kind, _ in stack)
            if inside_function:
                stack.append(("block", i))
            else:
                head = text[head_start:i]
                if opens_function(head):
                    stack.append(("func", i))
                elif SCOPE.search(head):
                    stack.append(("scope", i))
                else:
                    stack.append(("block", i))
            head_start = i + 1
        elif c == "}":
            if stack:
                kind, start = stack.pop()
                if kind == "func":
                    first = text.count("\n", 0, start) + 1
                    last = text.count("\n", 0, i) + 1
                    sig = text[text.rfind(";", 0, start) + 1:start]
                    sig = sig[sig.rfind("}") + 1:]
                    name = re.search(r"([~\w:]+)\s*\(", sig)
                    yield first, last - first + 1, name.group(1) if name else "?"
            head_start = i + 1
        elif c == ";":
            head_start = i + 1


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-lines", type=int, default=150)
    parser.add_argument("--list", type=int, default=0, help="print the N longest functions")
    parser.add_argument("paths", nargs="*", default=["modules"])
    args = parser.parse_args()
    root = pathlib.Path(__file__).resolve().parent.parent
    found = []
    for p in args.paths:
        base = pathlib.Path(p) if pathlib.Path(p).is_absolute() else root / p
        files = [base] if base.is_file() else sorted(
            f for f in base.rglob("*") if f.suffix in SOURCE_SUFFIXES)
        for f in files:
            for line, length, name in functions(f):
                found.append((length, f.relative_to(root) if f.is_relative_to(root) else f, line, name))
    found.sort(reverse=True)
    for length, f, line, name in found[:args.list]:
        print(f"{length:5d}  {f}:{line}  {name}")
    over = [x for x in found if x[0] > args.max_lines]
    for length, f, line, name in over:
        print(f"{f}:{line}: {name} is {length} lines (limit {args.max_lines})", file=sys.stderr)
    if over:
        print(f"check-function-size: {len(over)} function(s) over {args.max_lines} lines", file=sys.stderr)
        return 1
    print(f"check-function-size: {len(found)} functions, none over {args.max_lines} lines")
    return 0


if __name__ == "__main__":
    sys.exit(main())

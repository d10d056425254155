#!/usr/bin/python3
"""The house's size limits (issue 29): no function in raster/, vector/ or service/ longer than
--max-function lines (default 120) and no source file longer than --max-file lines (default
1000). Prints every violation and exits 1 if there is one; --report lists the largest
functions and files whatever the limits.

A function is a brace block opened at namespace or class scope whose header (the text since the
previous ';', '{' or '}' at that scope) has a parameter list and is not a class, struct, union,
enum, namespace, or initialiser. Its length runs from the header's first line to the closing
brace, lambdas and local classes inside it included. Comments and string literals (raw ones
too) are skipped when braces are matched.

Exceptions (--exceptions FILE, default tools/size-exceptions.txt): lines "function PATH NAME
LINES" or "file PATH LINES" let an existing violation stand at no more than LINES while the
code is being split; a listed item that grew, or no longer violates (so its line must go), fails
too. The list may only shrink; the house is done when it is empty.

Preprocessor directives are skipped, macro bodies with them: a definition after a macro that
holds braces is measured like any other (--self-test checks it on such a file).

usage: tools/check-sizes.py [--max-function N] [--max-file N] [--exceptions FILE] [--report] [DIR...]
       tools/check-sizes.py --self-test
"""
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SOURCE_EXT = (".cpp", ".hpp", ".h", ".cc")
NOT_FUNCTION = re.compile(r"\b(class|struct|union|enum|namespace)\b|=\s*$|^\s*(extern\s+\"C\")")


def strip_code(text):
    """The text with comments, string/char literals and preprocessor directives blanked (newlines
    kept). A directive runs to the end of its line and on over every line its backslash
    continues: a macro's body (`do { ... } while (0)`) holds braces that are no scope of the file,
    and left in, they made the definitions after it look like other blocks."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c == "#" and text[text.rfind("\n", 0, i) + 1:i].strip() == "":
            j = i
            while True:
                end = text.find("\n", j)
                end = n if end < 0 else end
                if end > 0 and text[end - 1] == "\\" and end < n:
                    j = end + 1
                    continue
                break
            out.append(re.sub(r"[^\n]", " ", text[i:end]))
            i = end
        elif text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "R" and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if not m:
                out.append(c)
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i)
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


MACRO_CALL = re.compile(r"\s*[A-Z][A-Z0-9_]*\s*\(")


def past_closing(text, j, opening, closing):
    """The offset just past the bracket that closes the one at text[j], or len(text) when none
    does; and whether one did."""
    depth = 0
    while j < len(text):
        depth += {opening: 1, closing: -1}.get(text[j], 0)
        j += 1
        if depth == 0:
            return j, True
    return j, False


def leading_macro_calls(header):
    """How many characters of the header are calls of function-like macros at namespace scope
    (`RV_LANE_KERNEL(...)`, which end without a ';') before a definition that follows them."""
    skip = 0
    while True:
        m = MACRO_CALL.match(header, skip)
        if not m:
            return skip
        j, closed = past_closing(header, m.end() - 1, "(", ")")
        if not closed or "(" not in header[j:]:
            return skip  # the macro call is the header itself, or what defines the function
        skip = j


def without_template_heads(header):
    """The header without its `template <...>` parameter lists: `template <class V>` names a
    class keyword, yet what follows may be a function (it was taken for a class)."""
    out, i = [], 0
    for m in re.finditer(r"\btemplate\s*<", header):
        if m.start() < i:
            continue
        out.append(header[i:m.start()])
        i, _ = past_closing(header, m.end() - 1, "<", ">")
    out.append(header[i:])
    return "".join(out)


def functions(path):
    """(name, first line, line count) of every function definition in the file."""
    code = strip_code(open(path, encoding="utf-8", errors="replace").read())
    found = []
    stack = []  # per open brace: True when it is a declaration scope (namespace, class, ...)
    header_start = 0  # offset where the current header begins at a declaration scope
    depth_fn = None  # index into stack of the function being measured
    fn_start = 0
    for i, c in enumerate(code):
        if c in ";{}" and (not stack or stack[-1]):
            pass
        if c == "{":
            in_decl = not stack or stack[-1]
            if in_decl and depth_fn is None:
                header = code[header_start:i]
                skip = leading_macro_calls(header)
                header = header[skip:]
                bare = without_template_heads(header)
                is_fn = "(" in bare and ")" in bare and not NOT_FUNCTION.search(bare.strip())
                if is_fn:
                    stack.append(False)
                    depth_fn = len(stack) - 1
                    fn_start = header_start + skip + (len(header) - len(header.lstrip()))
                    name = re.findall(r"([~\w:]+)\s*\(", header)
                    fn_name = name[0] if name else "?"
                    continue
                stack.append(True)
                header_start = i + 1
            else:
                stack.append(False)
        elif c == "}":
            if not stack:
                continue
            stack.pop()
            if depth_fn is not None and len(stack) == depth_fn:
                first = code.count("\n", 0, fn_start) + 1
                last = code.count("\n", 0, i) + 1
                found.append((fn_name, first, last - first + 1))
                depth_fn = None
            if not stack or stack[-1]:
                header_start = i + 1
        elif c == ";" and (not stack or stack[-1]) and depth_fn is None:
            header_start = i + 1
    return found


SELF_TEST = r'''
#define TAKE(key)  \
  do {             \
    b = (key) < b; \
  } while (0)
#define Q(p) (a0 * (p).q)
template <class V>
INLINE_MACRO void kernel_lanes(const int* p, int n) {
  for (int i = 0; i < n; ++i) {
    TAKE(p[i]);
  }
  // "}" in a comment, '{' in a literal
}
LANE_KERNEL(void, kernel, (const int* p, int n), (p, n))
int after(int x) { return x; }
template <class T>
struct Holder {
  T t;
};
'''


def self_test():
    """The measure on a file that defines macros with braces before a macro-prefixed kernel."""
    import tempfile
    with tempfile.NamedTemporaryFile("w", suffix=".cpp", delete=False) as f:
        f.write(SELF_TEST)
    try:
        found = functions(f.name)
    finally:
        os.unlink(f.name)
    expected = [("kernel_lanes", 7, 7), ("after", 15, 1)]
    if found != expected:
        print(f"check-sizes self-test: found {found}, expected {expected}")
        return 1
    print("check-sizes self-test: macro bodies skipped, the macro-prefixed kernel measured: 2 passed, 0 failed")
    return 0


def main():
    args = sys.argv[1:]
    if args == ["--self-test"]:
        return self_test()
    max_fn, max_file, report = 120, 1000, False
    exceptions_path = os.path.join(ROOT, "tools", "size-exceptions.txt")
    dirs = []
    while args:
        a = args.pop(0)
        if a == "--max-function":
            max_fn = int(args.pop(0))
        elif a == "--max-file":
            max_file = int(args.pop(0))
        elif a == "--exceptions":
            exceptions_path = args.pop(0)
        elif a == "--report":
            report = True
        else:
            dirs.append(a)
    allowed = {}
    if os.path.exists(exceptions_path):
        for line in open(exceptions_path):
            parts = line.split("#", 1)[0].split()
            if parts and parts[0] == "function" and len(parts) == 4:
                allowed[("function", parts[1], parts[2])] = int(parts[3])
            elif parts and parts[0] == "file" and len(parts) == 3:
                allowed[("file", parts[1])] = int(parts[2])
    dirs = dirs or ["raster", "vector", "service"]
    long_files, long_fns = [], []
    for d in dirs:
        for dirpath, _, names in os.walk(os.path.join(ROOT, d)):
            for name in sorted(names):
                if not name.endswith(SOURCE_EXT):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, ROOT)
                lines = open(path, encoding="utf-8", errors="replace").read().count("\n")
                if lines > max_file or report:
                    long_files.append((lines, rel))
                for fn, line, count in functions(path):
                    if count > max_fn or report:
                        long_fns.append((count, f"{rel}:{line}", fn))
    long_files.sort(reverse=True)
    long_fns.sort(reverse=True)
    if report:
        print(f"files over {max_file} lines: {sum(1 for n, _ in long_files if n > max_file)}; "
              f"functions over {max_fn} lines: {sum(1 for n, _, _ in long_fns if n > max_fn)}")
        for n, rel in long_files[:15]:
            print(f"  file {n:5d}  {rel}")
        for n, where, fn in long_fns[:25]:
            print(f"  function {n:4d}  {where}  {fn}")
        return 0
    failures, used = 0, set()
    for n, rel in long_files:
        key = ("file", rel)
        if key in allowed and n <= allowed[key]:
            used.add(key)
            continue
        failures += 1
        print(f"{rel}: {n} lines, over the limit of {max_file}" + (f" and its exception ({allowed[key]})" if key in allowed else ""))
    for n, where, fn in long_fns:
        key = ("function", where.split(":")[0], fn)
        if key in allowed and n <= allowed[key]:
            used.add(key)
            continue
        failures += 1
        print(f"{where}: function {fn} has {n} lines, over the limit of {max_fn}" +
              (f" and its exception ({allowed[key]})" if key in allowed else ""))
    for key in sorted(set(allowed) - used):
        failures += 1
        print(f"{exceptions_path}: '{' '.join(key)}' is within the limits now: remove its line")
    left = len(used)
    print(f"check-sizes: {failures} violation(s), {left} listed exception(s) left")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

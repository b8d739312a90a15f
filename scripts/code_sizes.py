#!/usr/bin/env python3
"""Prints the C++ files over the file limit and the functions over the function limit in the given trees.

    scripts/code_sizes.py TREE... [--max-file-lines N] [--max-function-lines N] [--quiet]

The project keeps every C++ file (.h .hh .hpp .cc .cpp .cxx) under precompute/, meshing/, realtime/,
view/ and mrt/ at most 800 lines long and every function at most 80 lines long: short enough to be read
whole. Each TREE is a folder, relative to the current directory or absolute. Prints one line per file or
function over its limit ("path:line: ..."), then a summary; exits 1 if anything is over, 0 otherwise.
--quiet prints only what is over.

How a function is found, and the limits of that: the source is read without a compiler. Comments,
string and character literals (raw strings included) and preprocessor lines are blanked, then the braces
are matched. A '{' at namespace, class or 'extern' scope opens a function body when the text before it
(since the last ';', '{' or '}') ends with a parameter list ')' and optional qualifiers (const, noexcept,
override, final, a trailing return type) or with a constructor's member initializer list; the braces of
a namespace, class, struct or union are scopes searched further; any other brace there (an enum, an
initializer) is skipped. A function's length counts every line from its signature's first line to its
closing brace, comments and blank lines included. So:
  - a lambda or a local class inside a function counts as part of that function, never on its own;
  - a lambda at namespace scope assigned to a variable counts as a function;
  - macros are not expanded: a function whose signature or braces come from a macro is missed, and a
    macro call without ';' before a definition joins that definition's signature (its name may then be
    reported wrongly; its length is still right);
  - a '{' or '}' produced by a preprocessor branch (#if/#else with a brace in each) unbalances the
    count: the script then reports the file as unreadable (exit 1) rather than guess.
"""
import argparse
import os
import re
import sys

EXTENSIONS = ('.h', '.hh', '.hpp', '.cc', '.cpp', '.cxx')
SCOPE_KEYWORD = re.compile(r'\b(namespace|class|struct|union|extern)\b')
ENUM_KEYWORD = re.compile(r'\benum\b')
QUALIFIERS = r'(?:\s|const\b|volatile\b|noexcept\b(?:\s*\([^()]*\))?|override\b|final\b|mutable\b|&)*'
FUNCTION_END = re.compile(r'\)' + QUALIFIERS + r'(?:->[^;]*)?$', re.S)
INITIALIZER_LIST_END = re.compile(r'\)' + QUALIFIERS + r':[^;]*[)}]$', re.S)


def blank_comments_and_literals(text):
    """The text with comments, literals and preprocessor lines replaced by spaces, newlines kept."""
    out = []
    i, n = 0, len(text)
    at_line_start = True
    while i < n:
        c = text[i]
        if at_line_start and c == '#':
            # A preprocessor line, with its continuations.
            j = i
            while j < n and text[j] != '\n':
                if text[j] == '\\' and j + 1 < n and text[j + 1] == '\n':
                    j += 1
                j += 1
            out.append(re.sub(r'[^\n]', ' ', text[i:j]))
            i = j
            continue
        if c in ' \t':
            out.append(c)
            i += 1
            continue
        at_line_start = c == '\n'
        if text.startswith('//', i):
            j = text.find('\n', i)
            j = n if j < 0 else j
            out.append(' ' * (j - i))
            i = j
        elif text.startswith('/*', i):
            j = text.find('*/', i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r'[^\n]', ' ', text[i:j]))
            i = j
        elif c == 'R' and text.startswith('R"', i) and not (i > 0 and (text[i - 1].isalnum() or text[i - 1] == '_')):
            k = text.find('(', i + 2)
            delimiter = text[i + 2:k]
            j = text.find(')' + delimiter + '"', k)
            j = n if j < 0 else j + len(delimiter) + 2
            out.append(re.sub(r'[^\n]', ' ', text[i:j]))
            i = j
        elif c in '"\'':
            if c == "'" and i > 0 and text[i - 1].isalnum():
                out.append(' ')  # a digit separator (1'000'000)
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != '\n':
                j += 2 if text[j] == '\\' else 1
            j = min(j + 1, n)
            out.append(' ' * (j - i))
            i = j
        else:
            out.append(c)
            i += 1
    return ''.join(out)


def strip_template_parameters(header):
    """The header without its 'template <...>' lists (their 'class' is no class)."""
    result = header
    while True:
        m = re.search(r'\btemplate\s*<', result)
        if not m:
            return result
        depth, j = 0, m.end() - 1
        while j < len(result):
            depth += {'<': 1, '>': -1}.get(result[j], 0)
            if depth == 0:
                break
            j += 1
        result = result[:m.start()] + ' ' + result[j + 1:]


def without_parentheses(text):
    depth, kept = 0, []
    for c in text:
        if c == '(':
            depth += 1
        elif c == ')':
            depth -= 1
        elif depth == 0:
            kept.append(c)
    return ''.join(kept)


def function_name(header):
    header = strip_template_parameters(header)
    m = re.search(r'(operator\s*\(\s*\)|operator\s*[^\s(]+|~?[A-Za-z_]\w*(?:\s*<[^()<>]*>)?(?:\s*::\s*~?[A-Za-z_]\w*)*)\s*\(',
                  header)
    return re.sub(r'\s+', '', m.group(1)) if m else '(unnamed)'


def classify(header):
    """'function', 'scope' or 'other' for a '{' at namespace or class scope preceded by header."""
    h = strip_template_parameters(header).strip()
    outside = without_parentheses(h)
    if ENUM_KEYWORD.search(outside):
        return 'other'
    if SCOPE_KEYWORD.search(outside):
        return 'scope'
    if '(' in h and (FUNCTION_END.search(h) or INITIALIZER_LIST_END.search(h)):
        return 'function'
    return 'other'


class Unbalanced(Exception):
    pass


def functions(text):
    """(name, first line, last line) of every function body found at namespace or class scope."""
    code = blank_comments_and_literals(text)
    line_of = []
    line = 1
    for c in code:
        line_of.append(line)
        line += c == '\n'
    found = []
    header_start = None  # index of the header's first non-blank character
    header = []
    i, n = 0, len(code)

    def matching_brace(open_index):
        depth = 0
        for j in range(open_index, n):
            if code[j] == '{':
                depth += 1
            elif code[j] == '}':
                depth -= 1
                if depth == 0:
                    return j
        raise Unbalanced('no closing brace for the one on line %d' % line_of[open_index])

    scope_depth = 0
    while i < n:
        c = code[i]
        if c == '{':
            kind = classify(''.join(header))
            if kind == 'scope':
                scope_depth += 1
                header, header_start = [], None
                i += 1
                continue
            end = matching_brace(i)
            if kind == 'function':
                start = header_start if header_start is not None else i
                found.append((function_name(''.join(header)), line_of[start], line_of[end]))
                header, header_start = [], None
            else:
                header.append('{}')
            i = end + 1
            continue
        if c == '}':
            scope_depth -= 1
            if scope_depth < 0:
                raise Unbalanced('a closing brace on line %d closes nothing' % line_of[i])
            header, header_start = [], None
        elif c == ';':
            header, header_start = [], None
        else:
            if header_start is None and not c.isspace():
                header_start = i
            header.append(c)
        i += 1
    if scope_depth != 0:
        raise Unbalanced('%d scopes left open at the end' % scope_depth)
    return found


def sources(tree):
    if os.path.isfile(tree):
        yield tree
        return
    for root, dirs, files in os.walk(tree):
        dirs[:] = sorted(d for d in dirs if not d.startswith('.') and d != 'node_modules')
        for name in sorted(files):
            if name.endswith(EXTENSIONS):
                yield os.path.join(root, name)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('trees', nargs='+', metavar='TREE')
    parser.add_argument('--max-file-lines', type=int, default=800)
    parser.add_argument('--max-function-lines', type=int, default=80)
    parser.add_argument('--quiet', action='store_true')
    args = parser.parse_args()
    over, files_read, functions_read = [], 0, 0
    for tree in args.trees:
        if not os.path.exists(tree):
            print('code_sizes.py: no such tree: %s' % tree, file=sys.stderr)
            return 2
        for path in sources(tree):
            with open(path, encoding='utf-8', errors='replace') as f:
                text = f.read()
            files_read += 1
            lines = text.count('\n') + (0 if text.endswith('\n') or not text else 1)
            if lines > args.max_file_lines:
                over.append('%s:1: file of %d lines (at most %d)' % (path, lines, args.max_file_lines))
            try:
                found = functions(text)
            except Unbalanced as e:
                over.append('%s:1: braces not matched (%s): sizes unknown' % (path, e))
                continue
            functions_read += len(found)
            for name, first, last in found:
                length = last - first + 1
                if length > args.max_function_lines:
                    over.append('%s:%d: function %s of %d lines (at most %d)'
                                % (path, first, name, length, args.max_function_lines))
    for line in over:
        print(line)
    if not args.quiet or over:
        print('code_sizes.py: %d files, %d functions read in %s; %d over the limits'
              % (files_read, functions_read, ' '.join(args.trees), len(over)))
    return 1 if over else 0


if __name__ == '__main__':
    sys.exit(main())

#!/usr/bin/env python3
"""Every link and every kcrig command line the manual quotes resolves.

  check_docs.py KCRIG_BINARY SOURCE_DIR

Reads README.md, docs/*.md and each folder's README.md and fails (exit 1,
one line per problem naming file:line) when
  - a relative link's file does not exist, or its #anchor is no heading of
    the Markdown file it points to (GitHub's heading slugs);
  - a command line `kcrig SUBCOMMAND --option ...` (in a code block or in
    inline code) names a subcommand `kcrig --help` does not list, or an
    option `kcrig SUBCOMMAND --help` does not list;
  - a script it quotes (scripts/..., tests/...) or a source file it names
    in inline code (a path under one of the repository's folders) does not
    exist.
Python 3 standard library only.
"""
import pathlib
import re
import subprocess
import sys

LINK = re.compile(r'!?\[[^\]]*\]\(([^)\s]+)\)')
INLINE_CODE = re.compile(r'`([^`\n]+)`')
OPTION = re.compile(r'^--([a-z0-9][a-z0-9-]*)')
SUBCOMMAND = re.compile(r'^[a-z][a-z-]*$')
SCRIPT = re.compile(r'(?:^|(?<=[\s`\'"(=]))(?:\./)?'
                    r'((?:scripts|tests)/[\w./-]+\.(?:sh|py))\b')
SOURCE = re.compile(r'^[\w.-]+(?:/[\w.-]+)+\.(?:h|cc|py|sh|yaml|dbc|md|js)$')
HELP_OPTION = re.compile(r'^\s+(?:-\w,)?--([a-z0-9][a-z0-9-]*)', re.M)
FOLDERS = set()  # the repository's top-level folders, filled by main
SHELL_END = {'|', '||', ';', '&&', '&', '>', '>>', '2>', '2>&1', '<', '#'}


def slug(text, seen):
    s = re.sub(r'[^\w\- ]', '', text.strip().lower()).replace(' ', '-')
    n = seen.get(s, 0)
    seen[s] = n + 1
    return s if n == 0 else f'{s}-{n}'


def read_lines(path):
    """(line number, text, in a code block) of each line."""
    fence = False
    for number, line in enumerate(path.read_text().split('\n'), 1):
        if line.lstrip().startswith('```'):
            fence = not fence
            continue
        yield number, line, fence


def anchors(path, cache={}):
    if path not in cache:
        seen = {}
        cache[path] = {slug(m.group(2), seen)
                       for _, line, fence in read_lines(path)
                       if not fence
                       for m in [re.match(r'^(#+) (.*)$', line)] if m}
    return cache[path]


def check_links(path, root, problems):
    for number, line, fence in read_lines(path):
        if fence:
            continue
        for m in LINK.finditer(line):
            target = m.group(1)
            if re.match(r'^[a-z]+:', target):
                continue
            file_part, _, anchor = target.partition('#')
            dest = (path.parent / file_part).resolve() if file_part else path
            where = f'{path.relative_to(root)}:{number}'
            if not dest.exists():
                problems.append(f'{where}: link to {target}: no such file')
            elif anchor and dest.suffix == '.md' and \
                    anchor not in anchors(dest):
                problems.append(f'{where}: link to {target}: no heading '
                                f'#{anchor} in {dest.relative_to(root)}')


def paragraphs(path):
    """(first line number, text) of each paragraph outside code blocks: an
    inline code span may wrap across its lines."""
    first, lines = None, []
    for number, line, fence in read_lines(path):
        if fence or not line.strip():
            if lines:
                yield first, ' '.join(lines)
            first, lines = None, []
            continue
        if first is None:
            first = number
        lines.append(line.strip())
    if lines:
        yield first, ' '.join(lines)


def code_lines(path):
    """(line number, text) of each line of a code block, a backslash
    continuation joined to the line it continues."""
    pending, start = '', None
    for number, line, fence in read_lines(path):
        if not fence:
            continue
        if start is None:
            start = number
        if line.rstrip().endswith('\\'):
            pending += line.rstrip()[:-1] + ' '
            continue
        yield start, pending + line
        pending, start = '', None


def command_lines(path):
    """(line number, words) of each quoted line that runs something, and
    of each inline code span."""
    for number, text in code_lines(path):
        yield number, text.split()
    for number, text in paragraphs(path):
        for m in INLINE_CODE.finditer(text):
            yield number, m.group(1).split()


class Help:
    def __init__(self, kcrig):
        self.kcrig = kcrig
        self.cache = {}

    def options(self, subcommand):
        """Whether kcrig has the subcommand, and the options it lists."""
        if subcommand not in self.cache:
            run = subprocess.run([self.kcrig, subcommand, '--help'],
                                 capture_output=True, text=True)
            # The options CLI11 lists, not words of their descriptions.
            self.cache[subcommand] = (run.returncode == 0,
                                      set(HELP_OPTION.findall(run.stdout)))
        return self.cache[subcommand]


def check_commands(path, root, help_, problems):
    for number, words in command_lines(path):
        where = f'{path.relative_to(root)}:{number}'
        for m in SCRIPT.finditer(' '.join(words)):
            if not (root / m.group(1)).exists():
                problems.append(f'{where}: {m.group(1)}: no such file')
        if len(words) == 1 and SOURCE.match(words[0]):
            top = words[0].split('/')[0]
            if top in FOLDERS and not (root / words[0]).exists():
                problems.append(f'{where}: {words[0]}: no such file')
        for i, word in enumerate(words[:-1]):
            if word != 'kcrig' and not word.endswith('/kcrig'):
                continue
            if i > 0 and words[i - 1].endswith(('.py', '.sh')):
                continue  # the binary handed to a script, not a command
            subcommand = words[i + 1]
            rest = words[i + 2:]
            if not SUBCOMMAND.match(subcommand) or \
                    (len(rest) == 1 and rest[0].isdigit()):
                continue  # printed output, or a format's name (`kcrig est 1`)
            listed, options = help_.options(subcommand)
            if not listed:
                problems.append(f'{where}: kcrig {subcommand}: not a '
                                'subcommand of kcrig --help')
                continue
            for option in rest:
                if option in SHELL_END or option.startswith('#'):
                    break
                m = OPTION.match(option)
                if m and m.group(1) not in options:
                    problems.append(f'{where}: kcrig {subcommand} '
                                    f'--{m.group(1)}: not in kcrig '
                                    f'{subcommand} --help')


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    kcrig, root = sys.argv[1], pathlib.Path(sys.argv[2]).resolve()
    FOLDERS.update(p.name for p in root.iterdir()
                   if p.is_dir() and not p.name.startswith(('.', 'build')))
    pages = [root / 'README.md'] + sorted((root / 'docs').glob('*.md')) + \
        sorted(p for p in root.glob('*/README.md'))
    help_ = Help(kcrig)
    problems = []
    for page in pages:
        check_links(page, root, problems)
        check_commands(page, root, help_, problems)
    for problem in problems:
        print(problem)
    print(f'{len(pages)} pages, {len(problems)} problems')
    sys.exit(1 if problems else 0)


if __name__ == '__main__':
    main()

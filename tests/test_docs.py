"""The docs say only what is there: README.md and docs/*.md checked against the code.

- Every `towerlink ...` command they show (in a code span or a code block) exists: its
  `towerlink SUB [SUBSUB] --help` exits 0 (once per distinct command); a bare
  word after SUB is a sub-subcommand or a value SUB's help names (a shipped scenario, a
  benchmark); every --flag shown is in the help of the command it is given to. The --help
  calls run in-process in one child process (tools.cli.main), so the check stays fast.
- Every repository path they name (common/..., vehicle/..., examples/..., docs/...) exists; a
  glob matches something.
- Every dotted name of ours (common.tf2_ros, gcs.tower_family.TowerFrames) is a module, and a
  name defined in it (and in its class, one level down).
- Every `make TARGET` is a Makefile target; every relative markdown link (and its #anchor)
  resolves.
- No issue numbers ("issue 11"): they mean nothing to a reader.

The checker is run on planted mistakes too, so it is known to fail when it should.
"""
from __future__ import annotations

import ast
import functools
import glob
import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

# paths are checked when they start with one of these (runs/<run>/..., STATE_DIR/... are not ours)
PATH_ROOTS = ("common", "vehicle", "gcs", "bridge", "tools", "tests", "examples", "docs")
MODULE_ROOTS = ("common", "vehicle", "gcs", "bridge", "tools")
# `bridge.tlog` is a file name, not a module
FILE_SUFFIXES = {"py", "md", "tlog", "log", "json", "toml", "yaml", "png", "pdf", "svg", "gv",
                 "mcap", "parm", "txt", "xml", "csv", "parquet", "waypoints"}
SHELL_STOPS = {"|", "||", "&", "&&", ";", ">", ">>", "2>&1"}

FENCE = re.compile(r"^```([^\n]*)\n(.*?)^```", re.M | re.S)
OUTPUT_BLOCKS = {"text", "output"}      # ```text: what a program printed, not commands to run
SPAN = re.compile(r"(`+)(.+?)\1", re.S)
TOWERLINK = re.compile(r"(?:^|(?<=[\s/(=]))towerlink[ \t]+(.*)")
PATH = re.compile(r"(?<![\w./-])((?:%s)/[\w.*{},/-]*)" % "|".join(PATH_ROOTS))
DOTTED = re.compile(r"(?<![\w./-])((?:%s)(?:\.[A-Za-z_]\w*)+)" % "|".join(MODULE_ROOTS))
MAKE = re.compile(r"(?:^|(?<=\s))make[ \t]+([a-z][\w-]*)")
LINK = re.compile(r"\[[^\]\n]*\]\(([^)\s]+)\)")
ISSUE = re.compile(r"\bissues?\s+#?\d+", re.I)


# ----------------------------------------------------------------------------- the code in a page

def code_of(text: str) -> list[str]:
    """Each line of every fenced block but an output one (```text), and every inline code span
    (newlines made spaces)."""
    out = [line for info, block in FENCE.findall(text) if info.strip() not in OUTPUT_BLOCKS
           for line in block.splitlines()]
    prose = FENCE.sub("\n", text)
    out += [m.group(2).replace("\n", " ") for m in SPAN.finditer(prose) if "\n\n" not in m.group(2)]
    return out


def commands_in(code: str) -> list[list[str]]:
    """The argument lists of the `towerlink ...` commands in one piece of code (shell words,
    up to a comment or a shell operator; [optional] brackets dropped)."""
    out = []
    for m in TOWERLINK.finditer(code):
        rest = m.group(1)
        try:
            words = shlex.split(rest, comments=True)
        except ValueError:                  # an unbalanced quote in prose: plain words will do
            words = rest.split()
        args = []
        for w in words:
            if w in SHELL_STOPS:
                break
            args.append(w.strip("[]"))
        if args:
            out.append(args)
    return out


# ----------------------------------------------------------------------------- towerlink --help

# Run in one child process for all the commands a check needs: each `towerlink ARGS --help`
# in-process there (tools.cli.main), its exit status and output captured.
_HELP_SCRIPT = r"""
import contextlib, io, json, sys
from tools.cli import main
out = []
for args in json.load(sys.stdin):
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
        try:
            status = main([*args, "--help"])
        except SystemExit as exc:
            status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    out.append([status, buf.getvalue()])
json.dump(out, sys.stdout)
"""
_helps: dict[tuple[str, ...], tuple[int, str]] = {}


def _run_helps(wanted) -> None:
    """`towerlink ARGS --help` for every ARGS not yet known, in one child process."""
    todo = sorted(set(wanted) - set(_helps))
    if not todo:
        return
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    p = subprocess.run([sys.executable, "-c", _HELP_SCRIPT], cwd=ROOT, env=env, input=json.dumps(todo),
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    for args, (status, text) in zip(todo, json.loads(p.stdout)):
        _helps[args] = (status, text)


def help_of(args: tuple[str, ...]) -> tuple[int, str]:
    """(exit status, output) of `towerlink *args --help`, run from this tree."""
    _run_helps([args])
    return _helps[args]


def _word(w: str) -> bool:
    return re.fullmatch(r"[a-z][a-z0-9_-]*", w) is not None


def _named(word: str, text: str) -> bool:
    return re.search(r"(?<![\w-])%s(?![\w-])" % re.escape(word), text) is not None


def _warm(commands: list[list[str]]) -> None:
    """Learn the --help of every command (and first bare word after it) these show, at once."""
    wanted = set()
    for args in commands:
        if _word(args[0]):
            wanted.add((args[0],))
            if len(args) > 1 and _word(args[1]):
                wanted.add((args[0], args[1]))
    _run_helps(wanted)


def command_problem(args: list[str]) -> str | None:
    """Why `towerlink *args` as shown is wrong, or None. A SUB in capitals (COMMAND) is a
    placeholder and not checked."""
    sub = args[0]
    if not _word(sub):
        return None
    shown = "towerlink " + " ".join(args)
    status, text = help_of((sub,))
    if status != 0:
        return f"`{shown}`: `towerlink {sub} --help` exits {status}"
    helps = [text]
    if len(args) > 1 and _word(args[1]):
        word = args[1]
        status, sub_text = help_of((sub, word))
        if status != 0:
            return f"`{shown}`: `towerlink {sub} {word} --help` exits {status}"
        if sub_text.startswith(f"usage: towerlink {sub} {word}"):
            helps.append(sub_text)          # a sub-subcommand: its flags count too
        elif not _named(word, text):
            return f"`{shown}`: {word!r} is neither a subcommand of `towerlink {sub}` nor named in its --help"
    for w in args[1:]:
        flag = w.split("=", 1)[0]
        if re.fullmatch(r"--[a-z][\w-]*|-[a-zA-Z]", flag) and not any(_named(flag, h) for h in helps):
            return f"`{shown}`: {flag} is not an option of `towerlink {' '.join(args[:len(helps)])}`"
    return None


# ----------------------------------------------------------------------------- paths, names, links

def _expand_braces(p: str) -> list[str]:
    m = re.search(r"\{([^{}]*)\}", p)
    if not m:
        return [p]
    return [q for alt in m.group(1).split(",") for q in _expand_braces(p[:m.start()] + alt + p[m.end():])]


def path_problem(path: str, root: Path = ROOT) -> str | None:
    path = path.rstrip(".,;:)")
    if "<" in path:
        return None
    for p in _expand_braces(path):
        if "*" in p:
            if not glob.glob(str(root / p)):
                return f"{path}: nothing matches {p}"
        elif not (root / p).exists():
            return f"{path}: no such file or folder"
    return None


def _module_file(parts: list[str], root: Path) -> Path | None:
    base = root.joinpath(*parts)
    if base.with_suffix(".py").is_file():
        return base.with_suffix(".py")
    if (base / "__init__.py").is_file():
        return base / "__init__.py"
    return None


@functools.lru_cache(maxsize=None)
def _definitions(file: Path) -> tuple[set[str], dict[str, set[str]], dict[str, list[str]], dict[str, str]]:
    """What one module defines: its top-level names (defined or imported), per class the names
    its body or its methods (self.NAME = ...) define and its base classes' names, and where
    each name imported with `from X import NAME` comes from (X made absolute)."""
    tree = ast.parse(file.read_text())
    package = file.parent.relative_to(ROOT).parts if file.is_relative_to(ROOT) else ()
    top: set[str] = set()
    classes: dict[str, set[str]] = {}
    bases: dict[str, list[str]] = {}
    imported: dict[str, str] = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            top.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            top |= {n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)}
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            top |= {(a.asname or a.name).split(".")[0] for a in node.names}
            if isinstance(node, ast.ImportFrom):
                mod = node.module or ""
                if node.level:
                    up = package[:len(package) - (node.level - 1)]
                    mod = ".".join([*up, *([mod] if mod else [])])
                imported.update({a.asname or a.name: mod for a in node.names})
        if isinstance(node, ast.ClassDef):
            names = set()
            for sub in ast.walk(node):
                if isinstance(sub, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                    names.add(sub.name)
                elif isinstance(sub, ast.Attribute) and isinstance(sub.ctx, ast.Store):
                    names.add(sub.attr)
                elif isinstance(sub, ast.Name) and isinstance(sub.ctx, ast.Store):
                    names.add(sub.id)
            classes[node.name] = names
            bases[node.name] = [b.id if isinstance(b, ast.Name) else ast.unparse(b) for b in node.bases]
    return top, classes, bases, imported


def _has_member(file: Path, cls: str, member: str, root: Path, depth: int = 0) -> bool:
    """Does class `cls` of `file` define `member`, itself or through a base class of ours? A base
    we cannot read (another package's) gives the benefit of the doubt."""
    _, classes, bases, imported = _definitions(file)
    if member in classes.get(cls, ()):
        return True
    for base in bases.get(cls, ()):
        if depth > 8:
            return True
        if base in classes:
            where = file
        elif base in imported and (where := _module_file(imported[base].split("."), root)) is not None:
            pass
        else:
            return True
        if _has_member(where, base, member, root, depth + 1):
            return True
    return False


def dotted_problem(name: str, root: Path = ROOT) -> str | None:
    """`common.tf2_ros` must be a module; `gcs.tower_family.run_family` a module and a name it
    defines; `gcs.client.Client.connect` a member of that class (or of a base class of ours).
    Deeper parts are not checked."""
    parts = name.split(".")
    if parts[-1] in FILE_SUFFIXES:
        return None
    k, file = 0, None
    for i in range(len(parts), 0, -1):
        if (file := _module_file(parts[:i], root)) is not None:
            k = i
            break
    if file is None:
        return f"{name}: no module {parts[0]}"
    rest = parts[k:]
    if not rest:
        return None
    top, classes, _, imported = _definitions(file)
    if rest[0] not in top:
        return f"{name}: {'.'.join(parts[:k])} defines no {rest[0]!r}"
    if len(rest) > 1:
        where, cls = file, rest[0]
        if cls not in classes and cls in imported:      # a class the module re-exports
            where = _module_file(imported[cls].split("."), root)
        if where is not None and cls in _definitions(where)[1] and not _has_member(where, cls, rest[1], root):
            return f"{name}: class {cls} has no {rest[1]!r}"
    return None


@functools.lru_cache(maxsize=None)
def _makefile_targets(root: Path = ROOT) -> frozenset[str]:
    text = (root / "Makefile").read_text()
    return frozenset(re.findall(r"^([\w-]+)\s*:", text, re.M))


def _slug(heading: str) -> str:
    """GitHub's anchor for a heading."""
    s = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return s.replace(" ", "-")


def _anchors(text: str) -> set[str]:
    return {_slug(h) for h in re.findall(r"^#+\s+(.*)$", FENCE.sub("", text), re.M)}


def link_problem(target: str, page: Path, text: str) -> str | None:
    """A relative link from `page` (whose text is `text`) must reach a file, and its #anchor a
    heading there."""
    if re.match(r"[a-z]+:", target):         # http:, https:, mailto:
        return None
    file, _, anchor = target.partition("#")
    if file:
        dest = (page.parent / file).resolve()
        if not dest.exists():
            return f"link {target}: no such file"
        if dest.suffix != ".md":
            return None
        text = dest.read_text()
    if anchor and anchor not in _anchors(text):
        return f"link {target}: no heading with that anchor"
    return None


# ----------------------------------------------------------------------------- one page

def problems(text: str, page: Path, root: Path = ROOT) -> list[str]:
    """Everything in one page that the code does not bear out."""
    out = []
    code = code_of(text)
    commands = [args for c in code for args in commands_in(c)]
    _warm(commands)
    out += [p for args in commands if (p := command_problem(args))]
    out += [f"make {t}: no such Makefile target" for c in code for t in MAKE.findall(c)
            if t not in _makefile_targets(root)]
    out += [p for m in PATH.finditer(text) if (p := path_problem(m.group(1), root))]
    out += [p for m in DOTTED.finditer(text) if (p := dotted_problem(m.group(1), root))]
    out += [p for m in LINK.finditer(text) if (p := link_problem(m.group(1), page, text))]
    out += [f"{m.group(0)!r}: no issue numbers in user-facing text" for m in ISSUE.finditer(text)]
    return [f"{page.relative_to(root) if page.is_relative_to(root) else page.name}: {p}" for p in out]


# ----------------------------------------------------------------------------- the tests

@pytest.mark.parametrize("page", DOCS, ids=[p.relative_to(ROOT).as_posix() for p in DOCS])
def test_page_says_only_what_is_there(page):
    assert problems(page.read_text(), page) == []


def test_readme_stays_a_newcomers_page():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 130
    assert "make demo" in text and "make test" in text


def test_every_command_is_documented():
    """Each registered `towerlink` subcommand is shown somewhere in the docs."""
    from tools.cli import COMMANDS
    shown = {args[0] for page in DOCS for c in code_of(page.read_text()) for args in commands_in(c)}
    assert sorted(set(COMMANDS) - shown) == []


PLANTED_BAD = """# A page with mistakes

Run `towerlink flyy` or `towerlink frames bogus`, then `towerlink fly --no-such-flag` and
`towerlink fly nowhere-scenario`.

```sh
towerlink sitl --drones 2 --warp-drive    # a flag sitl does not have
make nope
```

The code is in vehicle/autopilot/nope.py and examples/nope/; see common.nope,
gcs.tower_family.NoSuchThing and gcs.client.Client.no_such_method, [this](NOPE.md),
[that](#no-such-heading) and issue 11.
"""

PLANTED_GOOD = """# A page without mistakes

Run `towerlink fly family --speedup max` or `towerlink frames convert --from world --to tower 0 10`
(see `towerlink COMMAND --help`), then `make demo`.

```sh
towerlink sitl --drones 2 --rovers 0 &     # comments and operators end a command
towerlink tf-echo world tower --tlog runs/<run>/bridge.tlog
```

```text
towerlink track plot: what a program printed is not a command
```

The code is in vehicle/autopilot/ and common/mavlink/{signing,ids}.py (tools/sweep*.py); see
common.tf2_ros, gcs.tower_family.TowerFrames, gcs.client.Client.connect and the run's
bridge.tlog; [up](#a-page-without-mistakes).
"""


def test_the_checker_finds_planted_mistakes(tmp_path):
    page = tmp_path / "planted.md"
    found = "\n".join(problems(PLANTED_BAD, page))
    for mistake in ("towerlink flyy", "towerlink frames bogus", "--no-such-flag", "nowhere-scenario",
                    "--warp-drive", "make nope", "vehicle/autopilot/nope.py", "examples/nope/",
                    "common.nope", "NoSuchThing", "no_such_method", "NOPE.md", "#no-such-heading",
                    "issue 11"):
        assert mistake in found, f"the checker missed {mistake!r}:\n{found}"
    assert problems(PLANTED_GOOD, page) == []

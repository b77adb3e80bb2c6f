"""The documentation builds with warnings as errors, and every example in it is true.

- ``docs/`` builds with ``sphinx-build -W`` (the gallery limited to three examples in
  the default set; every bundled example in the slow test).
- Every ``console`` block of the docs and the README runs: each ``$ lamech ...`` or
  ``$ ./run ...`` line is run (in this process, through ``lamech.cli.main``, in a
  fresh folder holding the page's files) and prints what the block shows after it. A
  line ``...`` in a block stands for any lines, ``...`` inside a line for any text.
- Every Python block with ``>>>`` runs as a doctest, the blocks of a page in order in
  one namespace.
- A file a page shows as ```` ```{code-block} toml ```` with ``:caption: NAME`` is written
  to that folder first; every whole problem file shown (a ``title =``) loads.
- The ``lamech`` paths that docstrings cross-reference (``:func:`lamech.x.y```) exist
  (and the Sphinx build is nitpicky: every reference resolves to a documented name).
- Every name of ``lamech.__all__`` is in the API reference, and every name there has a
  docstring whose ``>>>`` examples run (with those of the module that defines it).
"""

from __future__ import annotations

import contextlib
import doctest
import importlib
import io
import os
import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

import lamech
from lamech.cli import main as lamech_main

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
QUICK_GALLERY = "pendulum,cylinder,atwood"
# Examples that ask for the compiled engine: they share the run's cache of compiled
# systems (the conftest's ``shared_cache``) instead of compiling again in their own.
COMPILED = re.compile(r"--engine compiled|--jit\b|jit=True")
# Examples that start a Dask cluster, write an animation or solve a mechanism (5-6 s
# each): slow.
SLOW = re.compile(
    r"LocalCluster|scheduler=|--animate"
    r"|lamech (solve|simulate) (four_bar|andrews_squeezer)"
)


def _pages() -> list[Path]:
    pages = [p for p in sorted(DOCS.rglob("*.md")) if not {"_generated", "_build"} & set(p.parts)]
    return [ROOT / "README.md", *pages]


@dataclass(frozen=True)
class Block:
    page: Path
    kind: str  # the fence's language: console, python, toml, text, {code-block}, ...
    options: dict
    body: str
    line: int

    @property
    def language(self) -> str:
        if self.kind.startswith("{code-block}"):
            return self.kind.split(maxsplit=1)[1] if " " in self.kind else ""
        return self.kind

    @property
    def id(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


FENCE = re.compile(r"^```([^\n]*)\n(.*?)^```[ \t]*$", re.M | re.S)


def _blocks(page: Path) -> list[Block]:
    text = page.read_text(encoding="utf-8")
    out = []
    for match in FENCE.finditer(text):
        kind, body = match.group(1).strip(), match.group(2)
        options = {}
        if kind.startswith("{"):
            lines = body.split("\n")
            while lines and lines[0].startswith(":"):
                key, _, value = lines.pop(0)[1:].partition(":")
                options[key.strip()] = value.strip()
            body = "\n".join(lines).lstrip("\n")
        out.append(Block(page, kind, options, body, text[: match.start()].count("\n") + 1))
    return out


def _all(language: str) -> list[Block]:
    return [b for p in _pages() for b in _blocks(p) if b.language == language]


def _files(page: Path, folder: Path) -> None:
    """Write the files the page shows with a caption into ``folder``."""
    for block in _blocks(page):
        name = block.options.get("caption")
        if name and "/" not in name:
            (folder / name).write_text(block.body, encoding="utf-8")


def _pattern(expected: str) -> re.Pattern:
    parts = []
    for line in expected.rstrip("\n").split("\n"):
        if line.strip() == "...":
            parts.append(r"(?:[^\n]*\n)*?")
        else:
            parts.append(".*?".join(re.escape(p) for p in line.rstrip().split("...")) + r"\n")
    return re.compile("".join(parts))


def _commands(block: Block) -> list[tuple[list[str], str]]:
    """[(argv for lamech, expected output)] of a console block."""
    steps: list[tuple[list[str], list[str]]] = []
    for line in block.body.rstrip("\n").split("\n"):
        if line.startswith("$ "):
            words = shlex.split(line[2:], comments=True)
            if words[0] not in ("lamech", "./run"):
                raise AssertionError(f"{block.id}: not a lamech command: {line}")
            steps.append((words[1:], []))
        else:
            assert steps, f"{block.id}: output before any command"
            steps[-1][1].append(line)
    return [(argv, "\n".join(lines)) for argv, lines in steps]


def _run(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = lamech_main(argv)
    return status, out.getvalue(), err.getvalue()


def _marks(block: Block) -> list:
    marks = [pytest.mark.slow] if SLOW.search(block.body) else []
    return marks + ([pytest.mark.shared_cache] if COMPILED.search(block.body) else [])


@pytest.mark.parametrize(
    "block", [pytest.param(b, id=b.id, marks=_marks(b)) for b in _all("console")]
)
def test_console_example_prints_what_it_shows(block, tmp_path, monkeypatch):
    _files(block.page, tmp_path)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "88")
    for argv, expected in _commands(block):
        status, out, err = _run(argv)
        assert status == 0, f"lamech {shlex.join(argv)}: exit {status}\n{err}"
        if expected.strip():
            text = "\n".join(line.rstrip() for line in out.rstrip("\n").split("\n")) + "\n"
            assert _pattern(expected).fullmatch(text), (
                f"{block.id}: lamech {shlex.join(argv)} printed\n{out}"
            )


def _python_pages() -> list:
    out = []
    for page in _pages():
        blocks = [b for b in _blocks(page) if b.language in ("python", "pycon")]
        blocks = [b for b in blocks if ">>>" in b.body]
        if blocks:
            slow = any(SLOW.search(b.body) for b in blocks)
            rel = str(page.relative_to(ROOT))
            out.append(pytest.param(page, False, id=rel))
            if slow:
                marks = [pytest.mark.slow]
                if any(COMPILED.search(b.body) for b in blocks):
                    marks.append(pytest.mark.shared_cache)
                out.append(pytest.param(page, True, id=rel + ":all", marks=marks))
    return out


@pytest.mark.parametrize(("page", "everything"), _python_pages())
def test_python_examples_run(page, everything, tmp_path, monkeypatch):
    """The page's doctest blocks in order, in one namespace; the default set leaves out
    the blocks that start Dask or animate (run by the slow case)."""
    _files(page, tmp_path)
    monkeypatch.chdir(tmp_path)
    parser = doctest.DocTestParser()
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    globs: dict = {}
    ran = 0
    for block in _blocks(page):
        if block.language not in ("python", "pycon") or ">>>" not in block.body:
            continue
        if SLOW.search(block.body) and not everything:
            continue
        test = parser.get_doctest(block.body, globs, block.id, str(page), block.line)
        out = io.StringIO()
        result = runner.run(test, out=out.write, clear_globs=False)
        assert result.failed == 0, out.getvalue()
        globs = test.globs  # the next block goes on in this namespace
        ran += result.attempted
    assert ran > 0


@pytest.mark.parametrize(
    "block",
    [pytest.param(b, id=b.id) for b in _all("toml") if re.search(r"^title\s*=", b.body, re.M)],
)
def test_whole_problem_files_shown_load(block):
    system = lamech.loads(block.body, name=block.id)
    assert system.coordinates


def _build(tmp_path: Path, gallery: str) -> tuple[subprocess.CompletedProcess, Path]:
    """Build a copy of docs/ (the gallery and CLI pages are written into the source
    folder while it builds) with warnings as errors."""
    src = tmp_path / "docs"
    shutil.copytree(DOCS, src, ignore=shutil.ignore_patterns("_build", "_generated"))
    shutil.copy(ROOT / "CHANGELOG.md", tmp_path / "CHANGELOG.md")
    html = tmp_path / "html"
    env = dict(os.environ, LAMECH_DOCS_GALLERY=gallery)
    argv = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html"]
    done = subprocess.run(
        [*argv, str(src), str(html)], capture_output=True, text=True, env=env, timeout=1200
    )
    return done, html


@pytest.fixture(scope="module")
def quick_build(tmp_path_factory) -> tuple[subprocess.CompletedProcess, Path]:
    return _build(tmp_path_factory.mktemp("docs"), QUICK_GALLERY)


@pytest.mark.slow
def test_docs_build_with_warnings_as_errors(quick_build):
    done, html = quick_build
    assert done.returncode == 0, done.stderr + done.stdout
    assert (html / "index.html").exists()
    page = (html / "_generated" / "gallery" / "cylinder.html").read_text(encoding="utf-8")
    assert "cos(theta1) = 4/7" in page  # written by lamech while the docs built
    cli = (html / "reference" / "cli.html").read_text(encoding="utf-8")
    assert "--initial" in cli and "--measure" in cli
    api = (html / "reference" / "api.html").read_text(encoding="utf-8")
    for name in ("lamech.load", "lamech.solve", "lamech.simulate", "lamech.sweep"):
        assert f'id="{name}"' in api, name


@pytest.mark.slow
def test_docs_math_is_rendered_offline_by_the_vendored_katex(quick_build, chromium):
    done, html = quick_build
    assert done.returncode == 0, done.stderr + done.stdout
    built = "".join(p.read_text(encoding="utf-8") for p in html.rglob("*.html"))
    assert not re.search(r"<script[^>]*src=\"(?:https?:)?//", built)  # nothing from the web
    assert "mathjax" not in " ".join(re.findall(r"<script[^>]*>", built)).lower()
    assert (html / "_static" / "katex" / "katex.min.js").exists()
    requested: list[str] = []
    errors: list[str] = []
    page = chromium.new_page()

    def refuse(route):
        if route.request.url.startswith(("file:", "data:")):
            route.continue_()
        else:
            requested.append(route.request.url)
            route.abort()

    page.route("**/*", refuse)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto((html / "tutorials" / "student.html").as_uri())
    page.wait_for_selector("div.math .katex-display", timeout=30_000)
    # every formula rendered, none left as LaTeX source or as a KaTeX parse error
    assert page.locator(".math[data-tex]").count() == page.locator(".math .katex").count() > 0
    assert page.locator(".katex-error").count() == 0
    assert not requested and not errors
    page.close()


@pytest.mark.slow
def test_docs_build_with_every_example_in_the_gallery(tmp_path):
    done, html = _build(tmp_path, "all")
    assert done.returncode == 0, done.stderr + done.stdout
    for name in lamech.example_names():
        assert (html / "_generated" / "gallery" / f"{name}.html").exists(), name


ROLE = re.compile(r":(?:py:)?(?:mod|func|class|meth|attr|data|exc|obj):`([^`]+)`")


def _resolves(target: str) -> bool:
    parts = target.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            fields = getattr(obj, "__dataclass_fields__", {})
            if hasattr(obj, attr):
                obj = getattr(obj, attr)
            elif attr in fields:  # a dataclass field without a default
                return True
            else:
                return False
        return True
    return False


def test_docstring_cross_references_name_what_exists():
    """A ``:func:`lamech.x.y``` or a relative ``:mod:`._x``` in a docstring names a
    module or object that exists (five named modules that had been renamed)."""
    missing = []
    for path in sorted((ROOT / "lamech").rglob("*.py")):
        module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
        package = module.removesuffix(".__init__")
        if path.name != "__init__.py":
            package = module.rsplit(".", 1)[0]
        text = path.read_text(encoding="utf-8")
        for match in ROLE.finditer(text):
            target = match.group(1).split("<")[-1].rstrip(">").lstrip("~!").removesuffix("()")
            if target.startswith("."):
                dots = len(target) - len(target.lstrip("."))
                base = package.rsplit(".", dots - 1)[0] if dots > 1 else package
                target = f"{base}.{target.lstrip('.')}"
            elif not target.startswith("lamech"):
                continue
            if not _resolves(target):
                line = text[: match.start()].count("\n") + 1
                missing.append(f"{path.relative_to(ROOT)}:{line}: {match.group(0)}")
    assert not missing, "\n".join(missing)


# ----- the API reference: every public name, and its docstring's examples ------------
API = DOCS / "reference" / "api.md"
AUTO = re.compile(r"^\.\. (?:auto(?:function|class|exception|data)|py:data):: (\S+)", re.M)


def _api_names() -> list[str]:
    """The names docs/reference/api.md documents, in order."""
    return AUTO.findall(API.read_text(encoding="utf-8"))


def _object(path: str):
    module, _, name = path.rpartition(".")
    return getattr(importlib.import_module(module), name)


def test_every_public_name_is_in_the_api_reference_with_a_docstring():
    documented = set(_api_names())
    missing = [n for n in lamech.__all__ if f"lamech.{n}" not in documented]
    assert not missing, f"not in {API.relative_to(ROOT)}: {missing}"
    bare = [n for n in _api_names() if n != "lamech.__version__" and not _object(n).__doc__]
    assert not bare, f"no docstring: {bare}"


def _homes() -> list[str]:
    """The modules that define the names the API reference documents."""
    names = [n for n in _api_names() if n != "lamech.__version__"]
    return sorted({getattr(_object(n), "__module__", "lamech") for n in names})


@pytest.mark.parametrize("path", ["lamech", *_api_names(), *_homes()])
def test_public_docstring_examples_run(path, tmp_path, monkeypatch):
    """Each ``>>>`` example in the docstring of a name the API reference documents (and
    of its methods), and of the module that defines it, runs and prints what it shows."""
    monkeypatch.chdir(tmp_path)
    try:
        obj = importlib.import_module(path)
    except ImportError:
        obj = _object(path)
    finder = doctest.DocTestFinder(recurse=not isinstance(obj, type(lamech)))
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    out = io.StringIO()
    for test in finder.find(obj, path, globs={}):
        runner.run(test, out=out.write)
    assert runner.failures == 0, out.getvalue()

"""The documentation site: it builds strictly, its tutorials' output is real, it works in a browser.

Tutorials (docs/tutorials/*.md) show commands in fenced ``console`` blocks: a line
``$ vsw ARGS`` is a command, the lines after it up to the next ``$`` line are its standard
output as shown. Each command is run (``python -m vsw ARGS``, this interpreter) in a
temporary directory holding a copy of the tutorials' model files and an empty ``img/``, in
the order of the page, and its output must match what is shown, line by line (trailing
spaces aside; standard error, where a model file's derivation prints its "done in N s",
is not compared, so no line needs a tolerance for timing), with two ways to leave output
out:

- a line that is ``...`` alone stands for any number of lines (none too);
- ``...`` inside a line stands for any text there (used for round-off-sized numbers, which
  are not the point and need not be the same on another machine).

Every figure a command writes into ``img/`` must be byte-identical to the committed
docs/tutorials/img/ file of that name: the figures cannot go stale either (to update one,
run its command in docs/tutorials/). A tutorial whose output changes fails here.

The browser test serves the built site on 127.0.0.1, blocks every other address (the site
must work offline), and at 360 and 1280 px width loads pages with no console error, runs a
search and screenshots the page (kept in the test's temporary directory); then opens the
site from the disk (file://), where the search must work too.
"""

from __future__ import annotations

import functools
import http.server
import importlib.util
import os
import re
import shlex
import shutil
import subprocess
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.conftest import chromium_path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
TUTORIALS = DOCS / "tutorials"
FENCE = re.compile(r"^(?P<fence>```+|~~~+)\s*(?P<info>[\w-]*)")
ELLIPSIS = "..."
# The headless Chromium of these tests: no network of its own, no GPU, no first-run work.
BROWSER_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update",
                "--disable-sync"]  # fmt: skip
# Tutorials in the slow tier: with them the default tier's share of this file would pass a
# minute (each takes 8 to 18 s here: a continuation to period 8, IPOPT designs and an
# optimisation, a 100 x 100 basin with its simulator compiled on first use; analyze and
# own-model about 10 s of CPU each: a vsw process per command, a gait search, a user's
# model derived). The simulate tutorial runs in the default tier.
SLOW_TUTORIALS = {"analyze", "basin", "continuation", "design", "own-model", "powered"}


@dataclass
class Command:
    """One ``$ vsw ...`` line of a tutorial and the output shown under it."""

    line: int  # 1-based line number in the page
    args: list[str]
    shown: list[str]


def fenced_blocks(text: str, info: str) -> Iterator[tuple[int, list[str]]]:
    """The fenced blocks of ``text`` whose info string is ``info``: (first line, lines)."""
    lines = text.split("\n")
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i].strip())
        if not m:
            i += 1
            continue
        fence, start, body = m["fence"], i + 1, []
        i += 1
        while i < len(lines) and not lines[i].strip().startswith(fence):
            body.append(lines[i])
            i += 1
        i += 1
        if m["info"] == info:
            yield start + 1, body


def commands(page: Path) -> list[Command]:
    """Every command of a tutorial's ``console`` blocks, with its shown output."""
    found: list[Command] = []
    for first, body in fenced_blocks(page.read_text(encoding="utf-8"), "console"):
        for offset, text in enumerate(body):
            if text.startswith("$ "):
                words = shlex.split(text[2:])
                assert words[:1] == ["vsw"], (
                    f"{page.name}:{first + offset}: a console command must be 'vsw ...': {text}"
                )
                found.append(Command(first + offset, words[1:], []))
            else:
                assert found and found[-1].line >= first, (
                    f"{page.name}:{first + offset}: output before any '$ vsw' line"
                )
                found[-1].shown.append(text.rstrip())
    return found


def line_matches(shown: str, actual: str) -> bool:
    """Whether an output line matches its shown form (``...`` inside it: any text)."""
    if ELLIPSIS not in shown:
        return shown == actual
    pattern = ".*".join(re.escape(part) for part in shown.split(ELLIPSIS))
    return re.fullmatch(pattern, actual) is not None


@functools.cache
def _match(shown: tuple[str, ...], actual: tuple[str, ...]) -> bool:
    if not shown:
        return not actual
    if shown[0] == ELLIPSIS:
        return any(_match(shown[1:], actual[k:]) for k in range(len(actual) + 1))
    return bool(actual) and line_matches(shown[0], actual[0]) and _match(shown[1:], actual[1:])


def output_matches(shown: list[str], actual: list[str]) -> bool:
    """Whether the output ``actual`` is what ``shown`` shows (its ``...`` lines skipping any)."""
    return _match(tuple(shown), tuple(line.rstrip() for line in actual))


def run_vsw(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``python -m vsw ARGS`` in ``cwd`` with this interpreter and a fixed terminal width."""
    env = {**os.environ, "COLUMNS": "80"}
    return subprocess.run([sys.executable, "-m", "vsw", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)  # fmt: skip


def tutorial_workspace(tmp_path: Path) -> Path:
    """A directory as the tutorials' commands expect: the model files, an empty img/."""
    for path in TUTORIALS.glob("*.py"):
        shutil.copy(path, tmp_path / path.name)
    (tmp_path / "img").mkdir()
    return tmp_path


def tutorial_params() -> list:
    pages = sorted(TUTORIALS.glob("*.md"))
    return [
        pytest.param(p, id=p.stem, marks=[pytest.mark.slow] if p.stem in SLOW_TUTORIALS else [])
        for p in pages
    ]


# --- the conventions themselves ---------------------------------------------------------------


def test_output_matching_convention():
    assert output_matches(["a", "b"], ["a", "b  "])
    assert not output_matches(["a", "b"], ["a", "c"])
    assert not output_matches(["a"], ["a", "b"])  # nothing left unshown without "..."
    assert output_matches(["a", ELLIPSIS, "d"], ["a", "b", "c", "d"])
    assert output_matches(["a", ELLIPSIS, "b"], ["a", "b"])
    assert output_matches([ELLIPSIS], [])
    assert not output_matches(["a", ELLIPSIS, "d"], ["a", "b", "c"])
    assert output_matches(["balance ... J"], ["balance 7.47846e-13 J"])
    assert not output_matches(["balance ... J"], ["balance 7.47846e-13 J/kg"])


def test_commands_are_read_from_console_blocks(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "Text\n\n```console\n$ vsw analyze --model 'compass-gait'\nline one\n\n"
        "$ vsw models\n```\n\n```bash\n$ vsw not-this-one\n```\n"
    )
    found = commands(page)
    assert [(c.line, c.args, c.shown) for c in found] == [
        (4, ["analyze", "--model", "compass-gait"], ["line one", ""]),
        (7, ["models"], []),
    ]


def test_every_tutorial_is_in_the_nav_and_runs_something():
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    pages = sorted(TUTORIALS.glob("*.md"))
    assert len(pages) >= 7
    for page in pages:
        assert f"tutorials/{page.name}" in nav, f"{page.name} is not in mkdocs.yml's nav"
        assert commands(page), f"{page.name} shows no '$ vsw' command in a console block"


def test_every_page_is_in_the_nav():
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    for page in DOCS.rglob("*.md"):
        name = page.relative_to(DOCS).as_posix()
        assert re.search(rf"(^|\s){re.escape(name)}$", nav, re.MULTILINE), (
            f"docs/{name} is not in mkdocs.yml's nav"
        )


def _hooks():
    spec = importlib.util.spec_from_file_location("docs_hooks", DOCS / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_links_that_leave_the_site_become_text():
    hooks = _hooks()
    page_dir = DOCS / "guide"
    text = (
        "[the runtime](../../vsw/dynamics/hybrid.py), [a page](commands.md), "
        "[gone](../../no/such/file.py), [web](https://example.org/x.py)\n"
        "```text\n[code](../../vsw/dynamics/hybrid.py)\n```"
    )
    assert hooks._outside_links(text, page_dir) == (
        "the runtime, [a page](commands.md), "
        "[gone](../../no/such/file.py), [web](https://example.org/x.py)\n"
        "```text\n[code](../../vsw/dynamics/hybrid.py)\n```"
    )


def test_an_included_files_links_are_reaimed_at_the_page():
    hooks = _hooks()
    # What benchmarks/results.md links to, seen from docs/benchmarks.md.
    text = "[basins](../docs/guide/basins.md#dask), [run](run.py), [web](https://example.org)"
    assert hooks.reaim_links(text, ROOT / "benchmarks", DOCS) == (
        "[basins](guide/basins.md#dask), [run](../benchmarks/run.py), [web](https://example.org)"
    )
    with pytest.raises(FileNotFoundError):
        hooks._included("no/such/file.md", DOCS)


# --- the tutorials ------------------------------------------------------------------------------


@pytest.mark.parametrize("page", tutorial_params())
def test_tutorial_output_is_real(page: Path, tmp_path):
    work = tutorial_workspace(tmp_path)
    for command in commands(page):
        result = run_vsw(command.args, work)
        where = f"{page.relative_to(ROOT)}:{command.line}: vsw {shlex.join(command.args)}"
        assert result.returncode == 0, f"{where} exited {result.returncode}: {result.stderr}"
        actual = result.stdout.rstrip("\n").split("\n")
        assert output_matches(command.shown, actual), (
            f"{where}: the output differs from the page's.\n--- shown\n"
            + "\n".join(command.shown)
            + "\n--- now\n"
            + "\n".join(actual)
        )
    for figure in sorted((work / "img").iterdir()):
        committed = TUTORIALS / "img" / figure.name
        assert committed.is_file(), f"{page.name} writes img/{figure.name}, not committed"
        assert committed.read_bytes() == figure.read_bytes(), (
            f"docs/tutorials/img/{figure.name} is not what {page.name}'s command writes now: "
            "run that command in docs/tutorials/ and commit the figure"
        )


def test_api_reference_example_prints_what_it_shows(tmp_path):
    page = DOCS / "reference" / "api.md"
    text = page.read_text(encoding="utf-8")
    ((_, program),) = list(fenced_blocks(text, "python"))
    ((_, shown),) = list(fenced_blocks(text, "text"))
    result = subprocess.run([sys.executable, "-c", "\n".join(program)], cwd=tmp_path,
                            capture_output=True, text=True, timeout=300)  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert output_matches(shown, result.stdout.rstrip("\n").split("\n")), result.stdout


# --- the site -----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site built with ``mkdocs build --strict`` (any warning fails it)."""
    pytest.importorskip("mkdocs", reason="mkdocs is not installed (pip install -e '.[test]')")
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert result.returncode == 0, f"mkdocs build --strict failed:\n{result.stderr}"
    assert "WARNING" not in result.stderr, result.stderr
    return out


def test_site_builds_strictly_with_generated_pages(site: Path):
    cli = (site / "reference" / "cli.html").read_text(encoding="utf-8")
    from vsw.cli.app import COMMANDS

    for name in COMMANDS:  # every command has its section, with its options
        assert f'id="vsw-{name}"' in cli, f"vsw {name} is missing from the CLI reference"
    assert "--max-period" in cli and "VSW_MAX_SECONDS" in cli
    assert "vsw:cli-reference" not in cli and "vsw:include" not in cli
    benchmarks = (site / "benchmarks.html").read_text(encoding="utf-8")
    first_heading = (ROOT / "benchmarks" / "results.md").read_text().split("\n")[0].lstrip("# ")
    assert first_heading in benchmarks
    api = (site / "reference" / "api.html").read_text(encoding="utf-8")
    assert 'id="vsw.models.load"' in api and 'id="vsw.dynamics.hybrid"' in api
    assert ":func:<code>" not in api and ":class:<code>" not in api  # reST roles dropped
    for tutorial in TUTORIALS.glob("*.md"):
        assert (site / "tutorials" / f"{tutorial.stem}.html").is_file()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: object) -> None:
        pass


@pytest.fixture(scope="module")
def served(site: Path) -> Iterator[str]:
    """The built site on an HTTP server at 127.0.0.1 (a free port)."""
    handler = functools.partial(_QuietHandler, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


def _not_blank(png: Path) -> bool:
    """Whether a screenshot shows something: many colours, not one flat page."""
    from PIL import Image

    with Image.open(png) as image:
        colours = image.convert("RGB").getcolors(maxcolors=1 << 20)
    return colours is None or len(colours) > 20


@pytest.mark.parametrize("width", [360, 1280])
def test_site_in_headless_chromium(site: Path, served: str, width: int, tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    browser_path = chromium_path()
    if browser_path is None:
        pytest.skip("no Chromium found (apt-get install chromium; .ci/run tries it)")
    errors: list[str] = []
    outside: list[str] = []

    def only_local(route, request) -> None:
        if request.url.startswith((served, "file://", "data:", "blob:", "about:")):
            route.continue_()
        else:  # offline: nothing beyond the local server and the files may be fetched
            outside.append(request.url)
            route.abort()

    def search(page, query: str) -> str:
        """The first result of a query typed into the search ('/' opens it at any width)."""
        page.keyboard.press("/")
        page.keyboard.type(query)
        result = page.locator(".md-search-result__item").first
        result.wait_for(state="visible", timeout=15000)
        return result.inner_text().lower()

    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=browser_path, headless=True,
                                    args=BROWSER_ARGS)  # fmt: skip
        try:
            page = browser.new_page(viewport={"width": width, "height": 800})
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.route("**/*", only_local)
            for path in ("index.html", "reference/cli.html", "tutorials/basin.html"):
                response = page.goto(f"{served}/{path}", wait_until="load")
                assert response is not None and response.ok, path
                assert page.locator("article h1").count() >= 1, path
                assert page.evaluate(
                    "Array.from(document.images).every(i => i.complete && i.naturalWidth > 0)"
                ), f"{path}: an image did not load"
                # Wide tables and code scroll in their boxes; the page itself never sideways.
                assert page.evaluate("document.documentElement.scrollWidth") <= width, path
            page.goto(f"{served}/index.html", wait_until="load")
            assert "basin" in search(page, "basin of attraction")
            shot = tmp_path / f"site-{width}.png"
            page.screenshot(path=str(shot), full_page=False)
            # The same site opened from the disk, without a server: its search still works.
            page.goto((site / "index.html").as_uri(), wait_until="load")
            assert "continu" in search(page, "continuation")
        finally:
            browser.close()
    assert not errors, f"console errors at {width} px: {errors}"
    assert not outside, f"the site fetched beyond the local server: {outside}"
    assert _not_blank(shot), f"the screenshot at {width} px is blank"


def test_the_model_languages_worked_examples_are_their_files_text():
    """Each worked example of docs/model-language.md is its model file's own text (a `...`
    line stands for what the page leaves out), so the page cannot drift from the file."""
    page = (DOCS / "model-language.md").read_text(encoding="utf-8")
    examples = re.findall(r"## Worked example: [^\n]*\n\n`(derive/models/\w+\.py)`.*?```python\n"
                          r"(.*?)\n```", page, re.DOTALL)  # fmt: skip
    assert [path for path, _ in examples] == [
        "derive/models/rimless_wheel.py",
        "derive/models/kneed_walker.py",
    ]
    for path, block in examples:
        source = (ROOT / path).read_text(encoding="utf-8")
        pieces = re.split(r"\n *\.\.\.,?\n", block)
        for piece in pieces:
            assert piece.strip() and piece in source, (
                f"{path}: the page's excerpt is not the file's text"
            )

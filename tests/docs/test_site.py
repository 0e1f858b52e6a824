"""The documentation site: it builds strictly, names every id, and its pages hold together."""

from __future__ import annotations

import re
import subprocess
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np
import pytest
from browser_measure import PROBE_PREFIX, measure
from PIL import Image
from train_extra import chromium

from fluids_bench.registration import ENV_SPECS, PARALLEL_ENV_SPECS

ROOT = Path(__file__).resolve().parents[2]


class _Refs(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.images: list[str] = []
        self.links: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(a["id"])
        if tag == "img" and a.get("src"):
            self.images.append(a["src"])
        if tag == "a" and a.get("href"):
            self.links.append(a["href"])


def _pages(site: Path) -> list[Path]:
    """The built pages, without the 404 page and without the copies a browser test writes
    beside a page for a moment (`browser_measure.PROBE_PREFIX`; another xdist worker may be
    measuring one while this one reads the site)."""
    return [
        p for p in site.rglob("*.html")
        if p.name != "404.html" and not p.name.startswith(PROBE_PREFIX)
    ]  # fmt: skip


def _parse(page: Path) -> _Refs:
    refs = _Refs()
    refs.feed(page.read_text(encoding="utf-8"))
    return refs


def _local(page: Path, ref: str) -> tuple[Path, str] | None:
    url = urlparse(ref)
    if url.scheme or url.netloc or ref.startswith(("mailto:", "data:")):
        return None
    target = page.parent / unquote(url.path) if url.path else page
    if target.is_dir():
        target = target / "index.html"
    return target, url.fragment


def test_every_registered_id_is_named_on_a_page(site):
    text = "\n".join(p.read_text(encoding="utf-8") for p in _pages(site))
    missing = [i for i in [*ENV_SPECS, *PARALLEL_ENV_SPECS] if i not in text]
    assert not missing, f"ids named on no docs page: {missing}"


def test_no_missing_image_or_broken_internal_link(site):
    problems = []
    for page in _pages(site):
        refs = _parse(page)
        for src in refs.images:
            hit = _local(page, src)
            if hit and not hit[0].is_file():
                problems.append(f"{page.relative_to(site)}: missing image {src}")
        for href in refs.links:
            hit = _local(page, href)
            if hit is None:
                continue
            target, fragment = hit
            if not target.exists():
                problems.append(f"{page.relative_to(site)}: broken link {href}")
            elif fragment and target.suffix == ".html" and fragment not in _parse(target).ids:
                problems.append(f"{page.relative_to(site)}: no anchor #{fragment} in {href}")
    assert not problems, "\n".join(problems[:40])


def test_every_results_file_is_shown_on_a_page():
    used, optional = set(), set()
    for md in (ROOT / "docs").rglob("*.md"):
        for name, rest in re.findall(
            r"(?<!')\{\{\s*table\(\s*\"([\w.-]+)\"([^}]*)\}\}", md.read_text(encoding="utf-8")
        ):
            (optional if re.search(r"optional\s*=\s*True", rest) else used).add(name)
    files = {p.stem for p in (ROOT / "docs" / "results").glob("*.json")}
    shown = used | optional
    assert files - shown == set(), f"results files no page shows: {sorted(files - shown)}"
    assert used - files == set(), (
        f"pages read results files that do not exist: {sorted(used - files)}"
    )


# skipped without Debian's chromium; CI installs it (.ci/run) and sets
# FLUIDS_BENCH_BROWSER_TESTS=1, so there it must run (tests/train_extra.py)
@pytest.mark.browser
@pytest.mark.parametrize("page", ["index.html", "tasks/fluids/index.html"])
def test_a_real_browser_renders_the_page(site, page, tmp_path):
    shot = tmp_path / "page.png"
    subprocess.run(
        [
            chromium(),
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            f"--user-data-dir={tmp_path / 'profile'}",
            f"--screenshot={shot}",
            "--window-size=1280,900",
            "--hide-scrollbars",
            (site / page).as_uri(),
        ],
        capture_output=True,
        timeout=120,
        check=False,
    )
    assert shot.is_file(), f"chromium wrote no screenshot of {page}"
    pixels = np.asarray(Image.open(shot).convert("L"), dtype=float)
    assert pixels.shape == (900, 1280)
    # a rendered page has text and a coloured header, not one flat colour
    assert pixels.std() > 10, f"{page} rendered blank"
    assert (pixels < 100).mean() > 0.01, f"{page} shows almost no dark pixels (no text?)"


HISTORY = re.compile(r"\bissue #?\d+|\(#\d+\)|\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}\b")


def test_the_readme_is_a_front_page():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 250
    assert not HISTORY.findall(text), HISTORY.findall(text)


def test_pages_hold_no_history():
    """Pages describe the project as it is: no commit hashes, no issue numbers (git and the
    changelog hold the history)."""
    found = []
    for md in (ROOT / "docs").rglob("*.md"):
        found += [
            f"{md.relative_to(ROOT)}: {m}" for m in HISTORY.findall(md.read_text(encoding="utf-8"))
        ]
    assert not found, found


def test_env_cards_hold_no_history():
    import sys

    sys.path.insert(0, str(ROOT / "docs" / "_gen"))
    import reference

    found = []
    for f in reference.FAMILIES:
        for env_id in f.ids + f.parallel_ids:
            found += [f"{env_id}: {m}" for m in HISTORY.findall(reference._card_text(env_id))]  # noqa: SLF001
    assert not found, found


def _tables(page: Path) -> str:
    return "\n".join(re.findall(r"<table>.*?</table>", page.read_text(encoding="utf-8"), re.S))


@pytest.mark.parametrize("page", ["index.html", "tasks/index.html", "api/registration/index.html"])
def test_every_registered_id_is_in_the_id_tables(site, page):
    tables = _tables(site / page)
    missing = [i for i in [*ENV_SPECS, *PARALLEL_ENV_SPECS] if f"<code>{i}</code>" not in tables]
    assert not missing, f"{page}: ids in none of its tables: {missing}"


def test_every_family_page_lists_its_registered_ids():
    import sys

    sys.path.insert(0, str(ROOT / "docs" / "_gen"))
    import reference

    missing = []
    for f in reference.FAMILIES:
        md = (ROOT / "docs" / "tasks" / f"{f.slug}.md").read_text(encoding="utf-8")
        if f'ids_table("{f.slug}")' not in md:
            missing.append(f.slug)
    assert not missing, f"family pages without their generated ids table: {missing}"


RST_ROLE = re.compile(r":(?:class|data|mod|func|meth|attr|obj|exc|const|ref):(?:<code>|`)")


def test_no_page_shows_a_raw_rest_role(site):
    found = []
    for page in _pages(site):
        hits = RST_ROLE.findall(page.read_text(encoding="utf-8"))
        if hits:
            found.append(f"{page.relative_to(site)}: {len(hits)}")
    assert not found, f"raw reST roles (write Markdown code spans instead): {found}"


def test_no_docstring_uses_rest_markup():
    """Docstrings are Google style with Markdown: the API pages and env cards render them."""
    import ast

    role = re.compile(r":(?:class|data|mod|func|meth|attr|obj|exc|const|ref):`")
    found = []
    for path in sorted((ROOT / "fluids_bench").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant):
                text = node.value.value if isinstance(node.value.value, str) else ""
                rest = role.search(text) or re.search(r"\S::\n|(?<!`)``(?!`)", text)
                if rest:
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not found, f"reST in docstrings: {found}"


MACHINE_PATH = re.compile(r"(?<![\w.~-])/(?:work|tmp|home|root|Users|mnt|scratch)/[\w./-]*")


def test_no_page_or_results_file_holds_a_machine_path():
    """Provenance is relative: commands rerun from a checkout anywhere (absolute paths of the
    machine that ran them tell a reader nothing)."""
    found = []
    for path in [*(ROOT / "docs").rglob("*.md"), *(ROOT / "docs" / "results").glob("*.json")]:
        if path.name == "changelog.md":
            continue
        found += [f"{path.relative_to(ROOT)}: {m}" for m in MACHINE_PATH.findall(path.read_text())]
    assert not found, found


def test_no_built_page_holds_a_machine_path(site):
    found = []
    for page in _pages(site):
        text = re.sub(r"<[^>]+>", " ", page.read_text(encoding="utf-8"))
        found += [f"{page.relative_to(site)}: {m}" for m in MACHINE_PATH.findall(text)]
    assert not [f for f in found if not f.startswith("changelog/")], found


# the pages with the widest tables and the CLI help; measured at a laptop's 1280 px
WIDE_PAGES = [
    "reproductions/fig-3-3/index.html",
    "tasks/fluids-rl/index.html",
    "tasks/fluids-v1/index.html",
    "tasks/locomotion/index.html",
    "tasks/details/fluids-rl-experiments/index.html",
    "tasks/details/fluids-v1-measurements/index.html",
    "tasks/details/locomotion-training/index.html",
    "benchmarks/index.html",
    "cli/index.html",
]
_MEASURE = """<script>
window.addEventListener("load", () => {
  const column = document.querySelector("article.md-content__inner");
  const wide = [];
  column.querySelectorAll("table").forEach((t) => {
    if (t.scrollWidth > column.clientWidth + 1) wide.push(["table", t.scrollWidth]);
  });
  column.querySelectorAll(".wrap-code pre > code").forEach((c) => {
    if (c.scrollWidth > c.clientWidth + 1) wide.push(["help text", c.scrollWidth]);
  });
  const bare = [...column.querySelectorAll("img")].filter((i) => !i.closest("a")).length;
  const out = document.createElement("pre");
  out.id = "measured";
  out.textContent = JSON.stringify({column: column.clientWidth, wide: wide, bare: bare});
  document.body.appendChild(out);
});
</script>"""


@pytest.mark.browser
@pytest.mark.parametrize("page", WIDE_PAGES)
def test_tables_fit_their_column_and_figures_open_full_size(site, page, tmp_path):

    measured = measure(site, page, tmp_path, _MEASURE, "measured")
    assert measured["column"] > 500, measured
    assert not measured["wide"], f"{page}: wider than the {measured['column']} px column"
    assert measured["bare"] == 0, f"{page}: {measured['bare']} figures link to no full image"

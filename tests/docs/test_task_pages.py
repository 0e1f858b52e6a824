"""The task pages as a newcomer meets them: a one-screen summary with a moving picture on top,
readable gallery thumbnails, pages short enough to read, and the performance page's peers."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest
from browser_measure import measure
from PIL import Image

ROOT = Path(__file__).resolve().parents[2]
TASKS = ROOT / "docs" / "tasks"
sys.path.insert(0, str(ROOT / "docs" / "_gen"))

import reference  # noqa: E402

# every page of docs/tasks/ but the index; docs/tasks/details/ holds their long material
TASK_PAGES = sorted(p.stem for p in TASKS.glob("*.md") if p.stem != "index")
DETAIL_PAGES = sorted(p.stem for p in (TASKS / "details").glob("*.md"))
MAX_WORDS = 2000  # prose words of a page (tables, code and env cards are reference: not counted)
MAX_GIF_BYTES = 400_000
SUMMARY = re.compile(r'\{\{\s*task_summary\("([\w-]+)",\s*"(\w+)",\s*"([\w-]+)"\)\s*\}\}')


def test_every_task_page_leads_with_its_summary():
    for stem in TASK_PAGES:
        lines = (TASKS / f"{stem}.md").read_text(encoding="utf-8").splitlines()
        assert lines[0].startswith("# "), f"{stem}.md starts with {lines[0]!r}"
        first = next(line for line in lines[1:] if line.strip())
        assert SUMMARY.fullmatch(first.strip()), f"{stem}.md: no task_summary under its title"


def test_every_summary_gif_is_made_by_the_script_and_small():
    sys.path.insert(0, str(ROOT / "scripts" / "figures"))
    import make_task_gifs

    for stem in TASK_PAGES:
        text = (TASKS / f"{stem}.md").read_text(encoding="utf-8")
        slug, gif, env_id = SUMMARY.search(text).groups()
        assert gif in make_task_gifs.MOVIES, f"{stem}.md: anim_{gif}.gif is no movie of the script"
        assert env_id in reference.family(slug).ids + reference.family(slug).parallel_ids
        path = ROOT / "docs" / "images" / f"anim_{gif}.gif"
        assert path.is_file(), f"{path} is missing: python scripts/figures/make_task_gifs.py"
        assert path.stat().st_size < MAX_GIF_BYTES, f"{path.name}: {path.stat().st_size} bytes"
        with Image.open(path) as image:
            assert image.n_frames > 1, f"{path.name} does not move"


def test_gallery_thumbnails_are_one_readable_frame():
    for f in reference.FAMILIES:
        with Image.open(ROOT / "docs" / f.image) as image:
            width, height = image.size
        # shown 160 px wide: at least 120 px tall (the filmstrips were 26)
        assert width >= 160 and height * 160 / width >= 120, f"{f.image}: {image.size}"


def test_the_peers_results_file_names_every_peer():
    data = json.loads((ROOT / "docs" / "results" / "bench_peers.json").read_text())
    results = data["results"]
    for name in ("FLUIDS-v1", "FLUIDS-v4", "highway-env intersection-v0", "original FLUIDS"):
        assert name in results, f"bench_peers.json lacks {name}"
    assert results["highway-env intersection-v0"]["kwargs"]["config"]["policy_frequency"] == 10
    for name, r in results.items():  # a rate per round, or the reason there is none
        assert "unavailable" in r or len(r["steps_per_cpu_s"]) == r["rounds"] >= 3, name


_PROBE = """<script>
window.addEventListener("load", () => {
  const column = document.querySelector("article.md-content__inner");
  const gifs = [...column.querySelectorAll("img")].filter((i) => /\\.gif$/.test(i.src))
    .map((i) => ({top: i.getBoundingClientRect().top + window.scrollY, shown: i.naturalWidth}));
  const thumbs = [...column.querySelectorAll("img.thumb")]
    .map((i) => i.getBoundingClientRect().height);
  const prose = column.cloneNode(true);
  prose.querySelectorAll("table, pre, .md-source-file").forEach((n) => n.remove());
  // an env card (a generated reference) runs from its h2 to the next h2
  let skip = false;
  [...prose.children].forEach((n) => {
    if (n.tagName === "H2") skip = /^env-card/.test(n.id);
    if (skip) n.remove();
  });
  const tables = [...column.querySelectorAll("table")].map((t) => t.innerText);
  const out = document.createElement("pre");
  out.id = "probed";
  out.textContent = JSON.stringify({
    screen: window.innerHeight, gifs: gifs, thumbs: thumbs, tables: tables,
    words: prose.innerText.split(/\\s+/).filter((w) => w).length,
  });
  document.body.appendChild(out);
});
</script>"""


def _probe(site: Path, page: str, tmp_path: Path) -> dict:
    """What Chromium at a laptop's 1280 x 900 measures on `page` of the built site."""
    return measure(site, page, tmp_path, _PROBE, "probed")


@pytest.mark.browser
@pytest.mark.parametrize("stem", TASK_PAGES)
def test_a_task_page_shows_its_moving_picture_in_the_first_screen(site, stem, tmp_path):
    measured = _probe(site, f"tasks/{stem}/index.html", tmp_path)
    first = [g for g in measured["gifs"] if g["top"] < measured["screen"]]
    assert first, f"{stem}: no GIF in the first {measured['screen']} px: {measured['gifs']}"
    assert all(g["shown"] > 0 for g in first), f"{stem}: a GIF did not load"
    assert measured["words"] <= MAX_WORDS, f"{stem}: {measured['words']} words of prose"


@pytest.mark.browser
@pytest.mark.parametrize("stem", DETAIL_PAGES)
def test_a_detail_page_is_short_enough_to_read(site, stem, tmp_path):
    measured = _probe(site, f"tasks/details/{stem}/index.html", tmp_path)
    assert measured["words"] <= MAX_WORDS, f"details/{stem}: {measured['words']} words of prose"


@pytest.mark.browser
def test_gallery_thumbnails_render_at_least_120_px_tall(site, tmp_path):
    measured = _probe(site, "tasks/index.html", tmp_path)
    assert len(measured["thumbs"]) == len(reference.FAMILIES), measured["thumbs"]
    assert min(measured["thumbs"]) >= 120, measured["thumbs"]


@pytest.mark.browser
def test_the_performance_page_shows_the_peers_table(site, tmp_path):
    measured = _probe(site, "benchmarks/performance/index.html", tmp_path)
    peers = [t for t in measured["tables"] if "intersection-v0" in t]
    assert len(peers) == 1, "no peers table on the performance page"
    for name in ("FLUIDS-v1", "FLUIDS-v4", "CarRacing-v3", "PushT"):
        assert name in peers[0], f"the peers table lacks {name}"

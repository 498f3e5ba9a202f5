"""Check a built documentation site: no broken internal link, and the pages a reader lands on render in a browser.

Run by ``.ci/run`` after ``sphinx-build``: ``python docs/sitecheck.py SITE [--shots DIR]``.

- every ``href``/``src`` of every page that points inside the site (no scheme, not ``mailto:``)
  names a file that exists, and an anchor ``#x`` names an ``id`` on that page;
- with headless Chromium on the machine (Debian's ``chromium``), the front page, the figures
  page (Fig. 3C) and the command-line reference are rendered: their DOM after scripts ran
  holds the images and the link to Fig. 3C from the front page; ``--shots`` keeps a
  screenshot of each to look at. Without Chromium that part says so and is skipped.

Exit 0 when all holds, 1 with one line per problem otherwise.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

PAGES = ("index.html", "figures.html", "cli/index.html")
"""The pages a reader lands on first: rendered in the browser."""


class _Links(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []
        self.ids: set[str] = set()
        self.imgs = 0

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        for k, v in attrs:
            if k == "id" and v:
                self.ids.add(v)
            if k in ("href", "src") and v:
                self.links.append(v)
        self.imgs += tag == "img"


def _parse(text: str) -> _Links:
    p = _Links()
    p.feed(text)
    return p


def broken_links(site: Path) -> list[str]:
    """One line per internal link of the site that names no file or no anchor."""
    pages = {p: _parse(p.read_text(encoding="utf-8", errors="replace")) for p in site.rglob("*.html")}
    problems = []
    for page, parsed in pages.items():
        for link in parsed.links:
            parts = urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith(("mailto:", "javascript:", "data:")):
                continue
            target = (page.parent / unquote(parts.path)).resolve() if parts.path else page
            if target.is_dir():
                target = target / "index.html"
            if not target.exists():
                problems.append(f"{page.relative_to(site)}: broken link {link}")
            elif parts.fragment and target in pages and parts.fragment not in pages[target].ids:
                problems.append(f"{page.relative_to(site)}: no anchor #{parts.fragment} in {target.relative_to(site)}")
    return problems


def rendered(site: Path, shots: Path | None) -> list[str]:
    """Problems with the landing pages as headless Chromium renders them (none without Chromium)."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("sitecheck: no headless Chromium here; the pages were not rendered")
        return []
    problems = []
    # offline: no first-run, sync, component or background fetches (this machine has no network)
    flags = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             "--window-size=1280,1600"]
    for name in PAGES:
        page = site / name
        if not page.exists():
            problems.append(f"{name}: not built")
            continue
        dom = subprocess.run([*flags, "--dump-dom", page.as_uri()], capture_output=True, text=True, timeout=120)
        parsed = _parse(dom.stdout)
        if dom.returncode != 0 or not parsed.links:
            problems.append(f"{name}: Chromium rendered nothing (exit {dom.returncode})")
        elif name == "index.html" and not any(link.startswith("figures.html") for link in parsed.links):
            problems.append("index.html: no link to the figures page (Fig. 3C) on the front page")
        elif name == "figures.html" and parsed.imgs < 3:
            problems.append(f"figures.html: {parsed.imgs} images rendered, expected Fig. 3C and the others")
        if shots is not None:
            shots.mkdir(parents=True, exist_ok=True)
            out = shots / (name.replace("/", "_").removesuffix(".html") + ".png")
            subprocess.run([*flags, f"--screenshot={out}", page.as_uri()], capture_output=True, timeout=120)
    print(f"sitecheck: {len(PAGES)} landing pages rendered by headless Chromium ({chromium})")
    return problems


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("site", type=Path)
    ap.add_argument("--shots", type=Path, default=None, help="keep a screenshot of each landing page here")
    a = ap.parse_args(argv)
    problems = broken_links(a.site) + rendered(a.site, a.shots)
    for p in problems:
        print(f"sitecheck: {p}")
    if not problems:
        print(f"sitecheck: {sum(1 for _ in a.site.rglob('*.html'))} pages, no broken internal link")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())

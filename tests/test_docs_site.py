"""The built documentation site: every internal link and image resolves; headless-Chromium screenshots.

The site is built once for this module with ``-W`` (``python -m sphinx -W --keep-going -b html
docs docs/_build/html``, incremental when that folder holds an earlier build), or an existing
build is reused as it is: set ``FEMB_DOCS_BUILD`` to its folder (``.ci/run`` does, right after
its own build). Building needs the ``docs`` extra; the screenshots need
Chromium (``apt-get install chromium``) and are skipped with a reason without it. Equations are
typeset by MathJax, which the site loads from its CDN; offline, the screenshot test serves a
copy of the site whose MathJax script points at a local MathJax (Debian's ``libjs-mathjax``,
or ``FEMB_MATHJAX_DIR``) and skips the equation check with a reason when there is none.
"""
from __future__ import annotations

import functools
import http.server
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import numpy as np
import pytest

for _mod in ("sphinx", "myst_parser", "sphinx_gallery", "pydata_sphinx_theme", "numpydoc"):
    pytest.importorskip(_mod, reason=f"the docs extra is not installed ({_mod} missing): pip install -e '.[docs]'")

ROOT = Path(__file__).resolve().parents[1]
EXTERNAL = ("http:", "https:", "mailto:", "data:", "javascript:", "ftp:", "tel:")
SCREENSHOTS = [("index.html", "front page"), ("method.html", "theory page"),
               ("auto_gallery/index.html", "gallery"), ("catalogue.html", "element catalogue")]


# ---------------------------------------------------------------------------
# the build
# ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The folder of the built HTML site (reused from FEMB_DOCS_BUILD, or built here with -W)."""
    given = os.environ.get("FEMB_DOCS_BUILD")
    if given:
        out = Path(given)
        if not (out / "index.html").is_file():
            pytest.fail(f"FEMB_DOCS_BUILD={given}: no index.html there (build the site first)")
        return out
    out = ROOT / "docs" / "_build" / "html"          # the README's build folder: later builds are incremental
    env = dict(os.environ, FEMB_BACKGROUND_BUILD="0", MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           str(ROOT / "docs"), str(out)], cwd=ROOT, env=env, capture_output=True, text=True)
    assert proc.returncode == 0, f"sphinx -W failed:\n{proc.stderr[-4000:]}"
    return out


class _Refs(HTMLParser):
    """Links (href), images and scripts (src) and element ids of one HTML page."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.refs, self.ids = [], set()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(a["id"])
        if tag == "a" and a.get("name"):
            self.ids.add(a["name"])
        for key in ("href", "src"):
            if a.get(key) is not None and tag in ("a", "link", "img", "script", "source", "iframe"):
                self.refs.append((tag, key, a[key]))
        if tag == "img" and a.get("srcset"):
            for part in a["srcset"].split(","):
                if part.strip():
                    self.refs.append((tag, "srcset", part.strip().split()[0]))


@functools.lru_cache(maxsize=None)
def _parse(path):
    p = _Refs()
    p.feed(Path(path).read_text(encoding="utf-8", errors="replace"))
    return p


def _article(page):
    """The main content of a page (without the navigation bars and sidebars), HTML tags removed
    except links."""
    html = Path(page).read_text(encoding="utf-8")
    body = html[html.index("<article"):html.index("</article>")]
    return re.sub(r"<(?!a\b|/a>)[^>]+>", "", body)


def broken_links(site):
    """Every internal href/src of every HTML page that does not resolve: (page, target, why)."""
    site = Path(site)
    bad = []
    for page in sorted(site.rglob("*.html")):
        if page.relative_to(site).parts[0] in ("_static", "_sources"):     # theme templates, not pages
            continue
        for tag, key, ref in _parse(page).refs:
            if not ref or ref.startswith(EXTERNAL) or ref.startswith("//"):
                continue
            parts = urlsplit(ref)
            target = page if not parts.path else (page.parent / unquote(parts.path)).resolve()
            if parts.path.endswith("/"):
                target = target / "index.html"
            rel = page.relative_to(site).as_posix()
            if site.resolve() not in (target.resolve(), *target.resolve().parents):
                bad.append((rel, ref, "outside the site"))
            elif not target.exists():
                bad.append((rel, ref, "missing file"))
            elif parts.fragment and target.suffix == ".html" and tag == "a":
                if unquote(parts.fragment) not in _parse(target).ids:
                    bad.append((rel, ref, "missing anchor"))
    return bad


# ---------------------------------------------------------------------------
# links, images, pages
# ---------------------------------------------------------------------------
def test_link_checker_finds_broken_links(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "index.html").write_text('<a href="sub/a.html#x">a</a><a href="gone.html">g</a>'
                                         '<img src="pic.png"><a href="https://example.org/">e</a>'
                                         '<a href="sub/a.html#nope">n</a><a href="#top">t</a><p id="top"></p>')
    (tmp_path / "sub" / "a.html").write_text('<h1 id="x">x</h1><a href="../index.html">up</a>')
    bad = broken_links(tmp_path)
    assert sorted((r, why) for _, r, why in bad) == [("gone.html", "missing file"), ("pic.png", "missing file"),
                                                      ("sub/a.html#nope", "missing anchor")]


def test_every_internal_link_and_image_resolves(site):
    bad = broken_links(site)
    assert not bad, f"{len(bad)} broken internal links or images, e.g.:\n" + "\n".join(
        f"  {page}: {ref} ({why})" for page, ref, why in bad[:40])


def test_the_site_has_its_sections_and_pages(site):
    for page in ("index.html", "start/index.html", "start/install.html", "start/planar.html",
                 "start/spatial.html", "start/notebook.html", "start/paraview.html", "guide/index.html",
                 "guide/viewer.html", "sweep.html", "kernels.html", "theory/index.html", "method.html",
                 "spatial.html", "beams.html", "stepsize.html", "theory/statics.html", "linearize.html",
                 "contact.html", "engine.html", "bench/index.html", "auto_gallery/index.html",
                 "catalogue.html", "api/index.html", "api/internal.html", "api/benchmarks.html"):
        assert (site / page).is_file(), page
    front = " ".join(_article(site / "index.html").split())
    assert "beams, planar and spatial" in front and "planar and spatial" in front
    assert "../shared" not in front


def test_no_page_points_outside_the_repository(site):
    stale = [p.relative_to(site).as_posix() for p in site.rglob("*.html")
             if "../shared/" in p.read_text(encoding="utf-8", errors="replace")]
    assert not stale, stale


def test_api_reference_public_first_benchmarks_apart(site):
    public = _article(site / "api" / "index.html")
    for mod in ("femb.system.mechanism", "femb.solve.solver", "femb.results.result", "femb.analysis.static", "femb.analysis.modal", "femb.analysis.linearize",
                "femb.study.sweep", "femb.contact", "femb.elements.spatial_beam"):
        assert f"_generated/api/{mod}.html" in public, mod
    for internal in ("femb.base.jit", "femb.console.cli_common", "femb.engine.loop", "femb.benchmarks"):
        assert f"_generated/api/{internal}.html" not in public, internal
    assert "_generated/api/femb.base.jit.html" in _article(site / "api" / "internal.html")
    assert "_generated/api/femb.benchmarks.scenes.planar.andrews.html" in _article(site / "api" / "benchmarks.html")


def test_gallery_examples_have_thumbnails_and_downloads(site):
    gallery = site / "auto_gallery"
    examples = sorted(p.stem for p in (ROOT / "docs" / "gallery").glob("*.py"))
    assert 8 <= len(examples) <= 12, examples
    index = (gallery / "index.html").read_text(encoding="utf-8")
    for name in examples:
        thumb = site / "_images" / f"sphx_glr_{name}_thumb.png"
        assert thumb.is_file() and f"sphx_glr_{name}_thumb.png" in index, name
        page = (gallery / f"{name}.html").read_text(encoding="utf-8")
        assert f"{name}.py" in page and f"{name}.ipynb" in page, name      # downloadable script and notebook
        assert f"sphx_glr_{name}_001.png" in page, name                     # its figure is on its page


def test_catalogue_pictures_every_entry(site):
    page = (site / "catalogue.html").read_text(encoding="utf-8")
    sys.path.insert(0, str(ROOT / "docs" / "_ext"))
    import femb_catalogue

    for entry in femb_catalogue.ENTRIES:
        assert f"{entry.key}.png" in page, entry.key
    for name in ("SpatialBeam", "RollingDisc", "SphereOnPlane", "PinInHole", "Bushing", "ReissnerBeam"):
        assert name in page, name


# ---------------------------------------------------------------------------
# screenshots in headless Chromium
# ---------------------------------------------------------------------------
def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


def _mathjax_dir():
    d = os.environ.get("FEMB_MATHJAX_DIR", "/usr/share/javascript/mathjax")
    return Path(d) if (Path(d) / "MathJax.js").is_file() else None


# MathJax 2 typesets what Sphinx marks as math (class "math"); MyST marks the rest of a page
# "tex2jax_ignore mathjax_ignore", as the site's own MathJax configuration expects.
_LOCAL_MATHJAX = ('<script type="text/x-mathjax-config">MathJax.Hub.Config({tex2jax: {processClass: "math", '
                  'ignoreClass: "tex2jax_ignore|mathjax_ignore"}});</script>'
                  '<script src="/mathjax/MathJax.js?config=TeX-AMS_CHTML"></script>')


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


@pytest.fixture(scope="module")
def served(site, tmp_path_factory):
    """(base URL, has local MathJax): a copy of the site on a local http.server."""
    if _chromium() is None:
        pytest.skip("chromium is not installed (apt-get install chromium): no screenshots")
    root = tmp_path_factory.mktemp("served")
    shutil.copytree(site, root / "site", symlinks=True)
    mj = _mathjax_dir()
    if mj is not None:                          # the CDN is not reachable offline: point the pages at MathJax 2
        (root / "mathjax").symlink_to(mj)
        cdn = re.compile(r'<script[^>]*src="https://cdn\.jsdelivr\.net/npm/mathjax@[^"]*"[^>]*></script>')
        for page in (root / "site").rglob("*.html"):
            text = page.read_text(encoding="utf-8")
            new = cdn.sub(_LOCAL_MATHJAX, text)
            if new != text:
                page.write_text(new, encoding="utf-8")
    handler = functools.partial(_Quiet, directory=str(root))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/site/", mj is not None
    server.shutdown()
    server.server_close()


def _browser(url, *extra, timeout=120):
    with tempfile.TemporaryDirectory() as profile:
        cmd = [_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
               "--disable-background-networking", "--disable-component-update", "--disable-sync",
               "--hide-scrollbars", f"--user-data-dir={profile}", "--virtual-time-budget=15000", *extra, url]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    return proc


def _out_dir():
    out = ROOT / "docs" / "_build" / "screenshots"
    out.mkdir(parents=True, exist_ok=True)
    return out


@pytest.mark.parametrize("page,what", SCREENSHOTS)
def test_screenshot_is_not_blank(served, page, what):
    import matplotlib.image as mpimg

    url, _ = served
    png = _out_dir() / (page.replace("/", "_").replace(".html", ".png"))
    png.unlink(missing_ok=True)
    proc = _browser(url + page, f"--screenshot={png}", "--window-size=1280,1600")
    assert png.is_file(), f"no screenshot of the {what}: {proc.stderr[-2000:]}"
    img = mpimg.imread(png)[..., :3]
    assert img.shape[0] >= 1000 and img.shape[1] >= 1200, img.shape
    grey = img.mean(axis=2)
    assert grey.std() > 0.05, f"the {what} looks blank (pixel std {grey.std():.3f})"
    assert (grey < 0.5).mean() > 0.002, f"the {what} has almost no dark pixels (text)"


def test_equations_are_rendered(served):
    url, has_mathjax = served
    if not has_mathjax:
        pytest.skip("no local MathJax (apt-get install libjs-mathjax, or FEMB_MATHJAX_DIR): the CDN is offline")
    dom = _browser(url + "method.html", "--dump-dom").stdout
    assert "math notranslate" in dom                        # Sphinx's math markup is on the page
    rendered = len(re.findall(r"<mjx-container|class=\"mjx-chtml|class=\"MathJax_CHTML", dom))
    assert rendered >= 10, f"only {rendered} equations typeset by MathJax on method.html"


def test_gallery_page_shows_its_thumbnails(served):
    url, _ = served
    dom = _browser(url + "auto_gallery/index.html", "--dump-dom").stdout
    thumbs = re.findall(r'<img[^>]+src="[^"]*_images/sphx_glr_[^"]+_thumb\.png"', dom)
    n = len(list((ROOT / "docs" / "gallery").glob("*.py")))
    assert len(thumbs) >= n, f"{len(thumbs)} thumbnails for {n} examples"

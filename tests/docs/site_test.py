#!/usr/bin/python3
"""Checks of the documentation site (docs/, mkdocs.yml), for CTest (tests/docs/CMakeLists.txt).

Usage: /usr/bin/python3 tests/docs/site_test.py build   [--repo DIR] [--keep DIR]
       /usr/bin/python3 tests/docs/site_test.py browser [--repo DIR] [--keep DIR]

build: `mkdocs build --strict` into a temporary directory (MkDocs 1.4 fails there on a link
  to a missing page or image); then, because MkDocs 1.4 only logs them: every page under
  docs/ must be in the nav, every internal link of every built page must reach a built file
  and, with a #fragment, an element with that id; every <img> must resolve to a file that
  decodes as a PNG or JPEG image of its stated size.
browser: the same build, then headless Chromium loads the home page and a results page:
  every <img> there must be complete with its natural size (the browser decoded it), and a
  screenshot of each page must not be blank: more ink than a blank page's, and the page's
  images visible in it (ink where the browser laid them out).

Missing tools (mkdocs, chromium, python3-pil) make the test fail with the package to install,
never skip.
"""

import argparse
import html.parser
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import urllib.parse

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
BUILD_TIMEOUT_S = 120
CHROMIUM_TIMEOUT_S = 60
WINDOW = (1280, 2200)
PAGES = ("index.html", "results/landing-envelope.html")  # the home page and a results page with plots


class Failure(Exception):
    pass


def need_pil():
    try:
        from PIL import Image  # noqa: F401
        return Image
    except ImportError:
        raise Failure("python3-pil is missing (apt-get install python3-pil; tools/install_deps.sh)")


def build_site(repo, out):
    try:
        import mkdocs  # noqa: F401
    except ImportError:
        raise Failure("mkdocs is missing (apt-get install mkdocs; tools/install_deps.sh)")
    cmd = [sys.executable, "-m", "mkdocs", "build", "--strict", "--clean", "--config-file",
           os.path.join(repo, "mkdocs.yml"), "--site-dir", out]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=BUILD_TIMEOUT_S, cwd=repo)
    sys.stderr.write(p.stderr)
    if p.returncode != 0:
        raise Failure("mkdocs build --strict failed (exit %d):\n%s" % (p.returncode, p.stderr[-4000:]))
    return p.stderr


def nav_pages(nav):
    out = []
    for item in nav or []:
        if isinstance(item, str):
            out.append(item)
        elif isinstance(item, dict):
            for v in item.values():
                out += nav_pages(v) if isinstance(v, list) else [v]
    return out


def check_nav(repo):
    import yaml
    with open(os.path.join(repo, "mkdocs.yml")) as f:
        cfg = yaml.safe_load(f)
    docs = os.path.join(repo, cfg.get("docs_dir", "docs"))
    pages = set()
    for root, dirs, files in os.walk(docs):
        dirs[:] = [d for d in dirs if not os.path.islink(os.path.join(root, d))]
        for fn in files:
            if fn.endswith(".md"):
                pages.add(os.path.relpath(os.path.join(root, fn), docs))
    in_nav = nav_pages(cfg.get("nav"))
    missing = sorted(pages - set(in_nav))
    dangling = sorted(set(p for p in in_nav if not re.match(r"^[a-z]+://", p)) - pages)
    dup = sorted(set(p for p in in_nav if in_nav.count(p) > 1))
    problems = []
    if missing:
        problems.append("pages not in mkdocs.yml's nav: %s" % ", ".join(missing))
    if dangling:
        problems.append("nav entries without a page: %s" % ", ".join(dangling))
    if dup:
        problems.append("pages twice in the nav: %s" % ", ".join(dup))
    if problems:
        raise Failure("; ".join(problems))
    return len(pages)


class Page(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.ids, self.links, self.imgs = set(), [], []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(a["id"])
        if tag == "a" and a.get("name"):
            self.ids.add(a["name"])
        if tag == "a" and a.get("href"):
            self.links.append(a["href"])
        if tag == "img":
            self.imgs.append(a)


def parse(path):
    p = Page()
    with open(path, encoding="utf-8") as f:
        p.feed(f.read())
    return p


def image_size(path, Image):
    with Image.open(path) as im:
        if im.format not in ("PNG", "JPEG"):
            raise Failure("%s is a %s image, not PNG or JPEG" % (path, im.format))
        im.load()  # decodes every pixel: a truncated file fails here
        return im.size


def check_site(site):
    Image = need_pil()
    pages = {}
    for root, _, files in os.walk(site):
        for fn in files:
            if fn.endswith(".html"):
                p = os.path.join(root, fn)
                pages[os.path.relpath(p, site)] = parse(p)
    problems, n_links, n_imgs = [], 0, 0
    for rel, page in sorted(pages.items()):
        if rel.startswith(("search", "404")):
            continue
        base = os.path.dirname(rel)
        for href in page.links:
            u = urllib.parse.urlparse(href)
            if u.scheme or href.startswith("//") or href.startswith("mailto:"):
                continue
            target = os.path.normpath(os.path.join(base, urllib.parse.unquote(u.path))) if u.path else rel
            if target.endswith("/") or os.path.isdir(os.path.join(site, target)):
                target = os.path.join(target, "index.html")
            n_links += 1
            if not os.path.exists(os.path.join(site, target)):
                problems.append("%s: link %s: no such file in the site" % (rel, href))
                continue
            if u.fragment and target.endswith(".html"):
                if target not in pages:
                    pages[target] = parse(os.path.join(site, target))
                if urllib.parse.unquote(u.fragment) not in pages[target].ids:
                    problems.append("%s: link %s: %s has no id '%s'" % (rel, href, target, u.fragment))
        for img in page.imgs:
            src = img.get("src", "")
            n_imgs += 1
            if not src or urllib.parse.urlparse(src).scheme:
                problems.append("%s: <img src=%r> is not a file of the site" % (rel, src))
                continue
            path = os.path.join(site, os.path.normpath(os.path.join(base, urllib.parse.unquote(src))))
            if not os.path.isfile(path):
                problems.append("%s: <img src=%r>: no such file" % (rel, src))
                continue
            try:
                image_size(path, Image)
            except Exception as e:  # noqa: BLE001 - any decoding error is the finding
                problems.append("%s: <img src=%r> does not decode: %s" % (rel, src, e))
    if problems:
        raise Failure("the built site has %d problem(s):\n  %s" % (len(problems), "\n  ".join(problems)))
    if n_imgs == 0:
        raise Failure("the built site has no image at all (the sample frames and plots are missing)")
    return len(pages), n_links, n_imgs


# ---------------------------------------------------------------------------------------------
# the browser

def find_chromium():
    for c in [os.environ.get("CHROMIUM"), "chromium", "chromium-browser", "google-chrome"]:
        if c and shutil.which(c):
            return shutil.which(c)
    raise Failure("chromium not found in PATH (apt-get install chromium; tools/install_deps.sh, or set CHROMIUM=)")


def run_chromium(args, tmp):
    exe = find_chromium()
    profile = tempfile.mkdtemp(prefix="profile-", dir=tmp)
    cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
           "--no-default-browser-check", "--disable-extensions", "--hide-scrollbars", "--mute-audio",
           "--allow-file-access-from-files", "--user-data-dir=" + profile] + args
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=CHROMIUM_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        raise Failure("chromium did not finish within %d s: %s" % (CHROMIUM_TIMEOUT_S, " ".join(cmd)))
    if proc.returncode != 0:
        raise Failure("chromium exited with %d: %s\n%s" % (proc.returncode, " ".join(cmd), err.decode(errors="replace")[-3000:]))
    return out


PROBE = ("<script>window.addEventListener('load',function(){setTimeout(function(){var r=[];"
         "document.querySelectorAll('img').forEach(function(i){var b=i.getBoundingClientRect();"
         "var c=getComputedStyle(i),f=function(k){return parseFloat(c[k])||0;};"
         "var l=f('paddingLeft')+f('borderLeftWidth'),t=f('paddingTop')+f('borderTopWidth');"
         "r.push([i.getAttribute('src'),i.complete,i.naturalWidth,i.naturalHeight,"
         "b.left+window.scrollX+l,b.top+window.scrollY+t,"
         "b.width-l-f('paddingRight')-f('borderRightWidth'),b.height-t-f('paddingBottom')-f('borderBottomWidth')]);});"
         "var e=document.createElement('pre');e.id='docs-probe';e.textContent=JSON.stringify(r);"
         "document.body.appendChild(e);},1000);});</script>")


def probe_images(site, rel, tmp):
    """[src, complete, naturalWidth, naturalHeight, left, top, width, height] per <img> (its
    content box in page pixels), as Chromium laid out the page (a copy with a probe script
    beside the original, measured 1 s after load: the theme's script moves the layout then)."""
    src = os.path.join(site, rel)
    with open(src, encoding="utf-8") as f:
        raw = f.read()
    probed = os.path.join(os.path.dirname(src), "docs-probe-" + os.path.basename(src))
    with open(probed, "w", encoding="utf-8") as f:
        f.write(raw.replace("</body>", PROBE + "</body>"))
    try:
        dom = run_chromium(["--window-size=%d,%d" % WINDOW, "--virtual-time-budget=5000", "--dump-dom",
                            "file://" + probed], tmp).decode("utf-8", errors="replace")
    finally:
        os.remove(probed)
    m = re.search(r'<pre id="docs-probe">(.*?)</pre>', dom, re.S)
    if m is None:
        raise Failure("the probe script did not run in chromium on %s" % rel)
    import html as htmlmod
    return json.loads(htmlmod.unescape(m.group(1)))


def screenshot(page, png, tmp, Image):
    run_chromium(["--window-size=%d,%d" % WINDOW, "--virtual-time-budget=3000", "--screenshot=" + png,
                  "file://" + page], tmp)
    if not os.path.isfile(png):
        raise Failure("chromium wrote no screenshot %s" % png)
    with Image.open(png) as im:
        if im.format != "PNG":
            raise Failure("the screenshot %s is not a PNG" % png)
        return im.convert("RGB")


def darkest_channel(img):
    """Per pixel, the smallest of R, G, B (an 'L' image)."""
    from PIL import ImageChops
    r, g, b = img.convert("RGB").split()
    return ImageChops.darker(r, ImageChops.darker(g, b))


def ink(img, box=None):
    """Share of pixels with any channel below 235 (not white), optionally inside a box."""
    if box:
        img = img.crop(box)
    hist = darkest_channel(img).histogram()
    n = sum(hist)
    return sum(hist[:235]) / float(n) if n else 0.0


def ink_match(shot, ref, box, Image):
    """Share of the reference image's ink pixels (scaled to the box) that are ink in the
    screenshot there. The box is the <img> element's content box (inside the frame and padding
    the theme draws); the browser's scaling and rounding move edges by a pixel or two, so the
    screenshot's ink is dilated by 5 px before the match (text that happens to lie there
    matches only by chance: a few tenths at most)."""
    from PIL import ImageChops, ImageFilter
    w, h = box[2] - box[0], box[3] - box[1]
    r_ink = darkest_channel(ref.resize((w, h))).point(lambda v: 255 if v < 200 else 0)
    c_ink = darkest_channel(shot.crop(box)).point(lambda v: 255 if v < 235 else 0).filter(ImageFilter.MaxFilter(5))
    n = r_ink.histogram()[255]
    if n == 0:
        return 1.0
    both = ImageChops.multiply(r_ink, c_ink).histogram()[255]
    return both / float(n)


def check_browser(site, tmp, keep):
    Image = need_pil()
    blank = os.path.join(tmp, "blank.html")
    with open(blank, "w") as f:
        f.write("<!DOCTYPE html><html><body></body></html>")
    blank_img = screenshot(blank, os.path.join(tmp, "blank.png"), tmp, Image)
    blank_ink = ink(blank_img)
    if blank_ink > 0.001:
        raise Failure("a blank page's screenshot is not white (%.4f ink): the check cannot tell" % blank_ink)
    report = []
    for rel in PAGES:
        imgs = probe_images(site, rel, tmp)
        if not imgs:
            raise Failure("%s has no <img> in chromium's DOM" % rel)
        for src, complete, nw, nh, left, top, w, h in imgs:
            if not complete or nw == 0 or nh == 0:
                raise Failure("%s: chromium did not decode <img src=%r> (complete %s, %dx%d)" % (rel, src, complete, nw, nh))
            path = os.path.join(site, os.path.normpath(os.path.join(os.path.dirname(rel), src)))
            with Image.open(path) as im:
                if (nw, nh) != im.size:
                    raise Failure("%s: chromium decoded %s at %dx%d, the file is %dx%d" % (rel, src, nw, nh, *im.size))
            if w * h <= 0:
                raise Failure("%s: <img src=%r> is not laid out" % (rel, src))
        png = os.path.join(tmp, rel.replace("/", "_") + ".png")
        shot = screenshot(os.path.join(site, rel), png, tmp, Image)
        if keep:
            shutil.copy(png, keep)
        if shot.size != WINDOW:
            raise Failure("%s: screenshot is %dx%d, not the window %dx%d" % (rel, *shot.size, *WINDOW))
        page_ink = ink(shot)
        # The page's text and navigation bar alone give a few percent of ink; a blank or
        # unstyled error page gives none. 0.02 is well below what either page shows.
        if page_ink < 0.02:
            raise Failure("%s: the screenshot is nearly blank (%.4f of its pixels not white)" % (rel, page_ink))
        seen = 0
        for src, _, nw, nh, left, top, w, h in imgs:
            if top + h > WINDOW[1] or left + w > WINDOW[0] or w < 20 or h < 20:
                continue  # below the fold or too small to judge
            box = (int(left), int(top), int(left + w), int(top + h))
            path = os.path.join(site, os.path.normpath(os.path.join(os.path.dirname(rel), src)))
            with Image.open(path) as im:
                got = ink_match(shot, im.convert("RGB"), box, Image)
            # 0.9: the image's own ink is all there but for its anti-aliased fringe; an absent
            # or other image leaves most of it unmatched.
            if got < 0.9:
                raise Failure("%s: image %s is not on the screenshot where the browser laid it out "
                              "(%.2f of its ink found there)" % (rel, src, got))
            seen += 1
        if seen == 0:
            raise Failure("%s: no image within the screenshot's window to check" % rel)
        report.append("%s: %d images decoded, %d seen on the screenshot, ink %.3f" % (rel, len(imgs), seen, page_ink))
    return report


def main():
    ap = argparse.ArgumentParser(description="Checks of the documentation site.")
    ap.add_argument("what", choices=["build", "browser"])
    ap.add_argument("--repo", default=REPO)
    ap.add_argument("--keep", help="copy the screenshots here")
    a = ap.parse_args()
    repo = os.path.abspath(a.repo)
    tmp = tempfile.mkdtemp(prefix="docs-site-")
    try:
        site = os.path.join(tmp, "site")
        build_site(repo, site)
        n_pages = check_nav(repo)
        n_html, n_links, n_imgs = check_site(site)
        print("site_test: mkdocs build --strict passed; %d pages all in the nav; %d links and %d images in %d "
              "built pages resolve" % (n_pages, n_links, n_imgs, n_html))
        if a.what == "browser":
            if a.keep:
                os.makedirs(a.keep, exist_ok=True)
            for line in check_browser(site, tmp, a.keep):
                print("site_test: " + line)
        return 0
    except Failure as e:
        print("site_test: FAIL: %s" % e)
        return 1
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())

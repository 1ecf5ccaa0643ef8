"""The report as a person first sees it: headless Chromium at 1400×2000 must show the title and the
scorecard summary on the first screen.

Snakemake's report centres its landing text vertically in a container as high as the window: a
landing text taller than the window starts above its top, out of reach of the scroll bar. So the
landing text must stay short (the long lists are report items of their own).

The layout comes from the browser itself: a copy of report.html gets a small script that, once the
report's React app has rendered the landing page, writes the bounding boxes of the title and of the
summary table into the DOM, and `chromium --headless --dump-dom` prints that DOM. A screenshot of
the same view is saved beside it (tmp dir) for a person to look at.

Chromium is Debian's `chromium`; where it is missing the test installs it with apt-get if it can
(root, apt-get on the PATH), as tests/workflow/test_slurm.py brings up SLURM, and skips saying why
if not.
"""

import html
import json
import os
import re
import shutil
import subprocess

import pytest

pytestmark = pytest.mark.slow

WIDTH, HEIGHT = 1400, 2000

# Polls until the landing page's title and summary table exist (the app renders after load), lets
# the rest (the rule graph) render for 3 s of virtual time, then writes their boxes, relative to the
# window, into <pre id="layout-probe">.
PROBE = """
<script>
(function probe(tries, settled) {
  const title = [...document.querySelectorAll("h1")]
    .find(h => h.textContent.includes("reproduced"));
  const table = [...document.querySelectorAll("table")]
    .find(t => t.textContent.includes("within band"));
  if ((!title || !table) && tries < 200) { setTimeout(() => probe(tries + 1, false), 50); return; }
  if (!settled) { setTimeout(() => probe(tries, true), 3000); return; }
  const box = el => { if (!el) return null; const r = el.getBoundingClientRect();
                      return {top: r.top, bottom: r.bottom, left: r.left, right: r.right}; };
  const out = document.createElement("pre");
  out.id = "layout-probe";
  out.textContent = JSON.stringify({title: box(title), table: box(table),
                                    titleText: title && title.textContent,
                                    width: window.innerWidth, height: window.innerHeight});
  document.body.appendChild(out);
})(0, false);
</script>
"""


def find_chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if path := shutil.which(name):
            return path
    return None


@pytest.fixture(scope="module")
def chromium():
    """Chromium's executable; installed with apt-get where missing and possible, else a skip."""
    if path := find_chromium():
        return path
    if os.geteuid() != 0 or not shutil.which("apt-get"):
        pytest.skip(
            "Chromium not available: not on the PATH, and installing it needs root and apt-get"
        )
    env = os.environ | {"DEBIAN_FRONTEND": "noninteractive"}
    # the SLURM test may be installing its packages at the same time: wait for dpkg's lock
    wait = ["-o", "DPkg::Lock::Timeout=900"]
    for step in (
        ["apt-get", *wait, "update"],
        ["apt-get", *wait, "install", "-y", "--no-install-recommends", "chromium"],
    ):
        try:
            done = subprocess.run(step, capture_output=True, text=True, timeout=1200, env=env)
        except subprocess.TimeoutExpired:
            pytest.skip(f"Chromium not available: `{' '.join(step)}` timed out")
        if done.returncode != 0:
            pytest.skip(
                f"Chromium not available: `{' '.join(step)}` failed: "
                f"{(done.stderr.strip().splitlines() or ['?'])[-1]}"
            )
    return find_chromium() or pytest.skip(
        "Chromium not available: apt-get installed no chromium executable"
    )


def headless(chromium, profile, *args):
    """Chromium headless at WIDTH×HEIGHT, with enough virtual time for the report's app to
    render."""
    return subprocess.run(
        [
            chromium,
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--hide-scrollbars",
            f"--user-data-dir={profile}",
            f"--window-size={WIDTH},{HEIGHT}",
            "--virtual-time-budget=15000",
            *args,
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_title_and_scorecard_summary_are_on_the_first_screen(chromium, smoke_report, tmp_path):
    built_report = smoke_report[0]  # the smoke run's report (tests/conftest.py)
    page = built_report.read_text(encoding="utf-8")
    probed = tmp_path / "probed.html"
    head, body_end, tail = page.rpartition("</body>")
    probed.write_text(
        head + PROBE + body_end + tail if body_end else page + PROBE, encoding="utf-8"
    )
    dump = headless(chromium, tmp_path / "profile", "--dump-dom", probed.as_uri())
    found = re.search(r'<pre id="layout-probe">(.*?)</pre>', dump.stdout, re.S)
    assert found, f"no layout from Chromium: {dump.stderr[-2000:]}"
    layout = json.loads(html.unescape(found[1]))
    # what a person sees: the same view as a PNG, kept in the test's tmp dir
    shot = tmp_path / "first_screen.png"
    headless(chromium, tmp_path / "profile", f"--screenshot={shot}", built_report.as_uri())
    print(f"screenshot: {shot}\nlayout: {layout}")
    assert layout["title"] and layout["table"], layout
    # --dump-dom's viewport is the window less a (virtual) browser frame: 1400×1857 for 1400×2000
    screen = layout["height"]
    assert 0.9 * HEIGHT <= screen <= HEIGHT and layout["width"] == WIDTH, layout
    assert 0 <= layout["title"]["top"] < screen, layout  # the title is on the first screen ...
    assert 0 <= layout["table"]["top"] and layout["table"]["bottom"] <= screen, (
        layout
    )  # ... and the whole summary
    assert layout["title"]["bottom"] <= layout["table"]["top"], layout

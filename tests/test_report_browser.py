"""The validation report in a real browser: headless Chromium loads every figure, no section is empty.

Chromium (Debian package ``chromium``) is driven with ``--dump-dom``: a copy of the report gets
a script that, on the page's load event, writes each image's decoded size and each section's
content into a ``<pre>`` that the dumped DOM carries back. Skips, saying why, where Chromium
is not installed.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import pytest

from mjtrack.demo import DEMO_ROBOT, demo_commands
from mjtrack.validate import validate

CHROMIUM = next((p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="headless Chromium not installed (apt-get install chromium)")

PROBE = """<script>
window.addEventListener("load", function () {
  var imgs = [], sections = [];
  document.querySelectorAll("img").forEach(function (i) {
    imgs.push({complete: i.complete, w: i.naturalWidth, h: i.naturalHeight});
  });
  document.querySelectorAll("section").forEach(function (s) {
    var h = s.querySelector("h2");
    sections.push({title: h ? h.innerText : "", parts: s.children.length - 1,
                   text: s.innerText.length - (h ? h.innerText.length : 0)});
  });
  var pre = document.createElement("pre");
  pre.id = "mjtrack-probe";
  pre.textContent = JSON.stringify({imgs: imgs, sections: sections});
  document.body.appendChild(pre);
});
</script>"""


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    from mjtrack.sim.rollout import drive_log

    drive = drive_log(DEMO_ROBOT, demo_commands(DEMO_ROBOT, duration=10.0, seed=0), duration=10.0)
    return validate(drive, DEMO_ROBOT, tmp_path_factory.mktemp("report"), source="browser test", quiet=True)


def _probe(html_path, tmp_path) -> dict:
    probed = tmp_path / "probed.html"
    probed.write_text(html_path.read_text().replace("</body>", PROBE + "</body>"))
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={tmp_path / 'profile'}",
           "--virtual-time-budget=10000", "--dump-dom", probed.as_uri()]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    match = re.search(r'<pre id="mjtrack-probe">(.*?)</pre>', proc.stdout, re.S)
    assert match, f"no probe output (rc {proc.returncode}); stderr tail: {proc.stderr[-500:]}"
    return json.loads(match.group(1).replace("&quot;", '"').replace("&amp;", "&"))


def test_every_figure_loads_and_no_section_is_empty(report, tmp_path):
    html = report.report_path.read_text()
    assert "http://" not in html and "https://" not in html  # self-contained: nothing fetched
    probe = _probe(report.report_path, tmp_path)
    assert len(probe["imgs"]) == html.count("<img")
    assert len(probe["imgs"]) >= 6
    for img in probe["imgs"]:
        assert img["complete"] and img["w"] > 300 and img["h"] > 200, img
    titles = [s["title"] for s in probe["sections"]]
    for wanted in ("Verdicts", "Setup", "Definitions", "Prediction error against horizon", "Filters"):
        assert wanted in titles
    for s in probe["sections"]:
        assert s["parts"] >= 1 and s["text"] > 50, s

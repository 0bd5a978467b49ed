import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import pytest

from mjtrack.report import Report


def test_report_is_self_contained(tmp_path):
    rep = Report("Validation <test>", intro="a & b")
    sec = rep.section("Numbers")
    sec.paragraph("x < y").table(["model", "err [m]"], [["MPP", 0.0123456], ["nominal", float("nan")]])
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    rep.section("Figure").figure(fig, "a line")
    out = tmp_path / "r.html"
    rep.write(out)
    text = out.read_text()
    assert "Validation &lt;test&gt;" in text and "x &lt; y" in text
    assert len(re.findall(r'src="data:image/png;base64,[A-Za-z0-9+/=]{100,}"', text)) == 1
    assert "0.01235" in text and "–" in text
    assert "http://" not in text and "https://" not in text


def test_empty_section_refused(tmp_path):
    rep = Report("r")
    rep.section("empty")
    with pytest.raises(ValueError, match="empty"):
        rep.write(tmp_path / "r.html")
    assert not (tmp_path / "r.html").exists()

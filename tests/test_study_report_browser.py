"""A real browser opens a study's HTML report: every figure loads and is drawn where the page puts it.

Headless Chromium (as in tests/test_browser.py) renders report.html of a small study with budget
curves; a script appended to a copy of the page logs each image's load state and box, and the page's
height. The page is then shot at its full height, and each image's box in the screenshot is compared
with the PNG embedded in the page, both averaged over 8 x 8 pixel blocks: the mean difference must be
under a quarter of the PNG's difference from a blank (white) box, so each figure is drawn, and drawn
where the page says (measured: 0-1.1 against blanks at 6.8-46 and other figures at 9-48). The
screenshot stays in tests/artifacts/study_report.png to look at.
"""

from __future__ import annotations

import base64
import io
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from wbik.cli import main
from wbik.viz.browser import render

ARTIFACTS = Path(__file__).resolve().parent / "artifacts"
STUDY = """
name: report_page
robot: ur5
chain: arm
poses: 30
seed: 3
chunk_size: 30
baseline: analytic
budget_curves: {poses: 10, budgets_ms: [0.2, 2, 20]}
methods: [analytic, dls, bounded_lm, kdl]
"""
PROBE = """<script>
window.addEventListener('load', () => {
  Array.from(document.images).forEach((img, i) => {
    const box = img.getBoundingClientRect();
    console.log(`wbik-report-image ${i} ${img.complete && img.naturalWidth > 0 ? 1 : 0} `
      + `${Math.round(box.left + window.scrollX)} ${Math.round(box.top + window.scrollY)} `
      + `${Math.round(box.width)} ${Math.round(box.height)}`);
  });
  console.log(`wbik-report-height ${document.documentElement.scrollHeight}`);
});
</script></body>"""
IMAGE_LINE = re.compile(r"^wbik-report-image (\d+) ([01]) (-?\d+) (-?\d+) (\d+) (\d+)$")
WIDTH = 1200


pytestmark = pytest.mark.usefixtures("require_chromium")  # a missing Chromium fails, it does not skip


def _shoot(page: Path, height: int):
    result = render(page, ARTIFACTS / "study_report.png", width=WIDTH, height=height, wait_ms=2000)
    assert result.errors == [], f"errors in the report page: {result.errors}"
    boxes = [tuple(int(v) for v in match.groups()) for line in result.console
             if (match := IMAGE_LINE.match(line))]
    heights = [int(line.split()[1]) for line in result.console if line.startswith("wbik-report-height ")]
    assert heights, f"the probe script did not run; console: {result.console}"
    return result, boxes, heights[0]


def _blocks(image: Image.Image, width: int, height: int) -> np.ndarray:
    """``image`` scaled to width x height / 8 by averaging (8 x 8 pixel blocks)."""
    return np.asarray(image.resize((width // 8, height // 8), Image.BOX), dtype=float)


def test_the_report_renders_with_its_figures(tmp_path):
    (tmp_path / "study.yaml").write_text(STUDY)
    assert main(["study", str(tmp_path / "study.yaml"), "-o", str(tmp_path / "out"), "--backend",
                 "sequential", "--no-progress"]) == 0
    html = (tmp_path / "out" / "report.html").read_text()
    embedded = re.findall(r"src='data:image/png;base64,([^']+)'", html)
    assert len(embedded) == 8  # solved, time, histogram, ECDF, throughput, budget curves, errors, error hists
    ARTIFACTS.mkdir(exist_ok=True)
    page = ARTIFACTS / "study_report.html"
    page.write_text(html.replace("</body>", PROBE))

    _, _, full_height = _shoot(page, 800)
    result, boxes, _ = _shoot(page, min(full_height, 16000))
    assert len(boxes) == len(embedded)
    screenshot = Image.open(result.screenshot).convert("RGB")
    shot = np.asarray(screenshot, dtype=float)
    for (index, loaded, left, top, width, height), data in zip(boxes, embedded, strict=True):
        assert loaded == 1, f"figure {index} did not load"
        assert width > 300 and height > 150, f"figure {index} is drawn {width} x {height} px"
        assert top + height <= shot.shape[0] and left + width <= shot.shape[1]
        drawn = shot[top:top + height, left:left + width]
        assert np.mean(drawn.min(axis=2) < 200) > 0.02, f"figure {index} is blank in the screenshot"
        on_screen = _blocks(screenshot.crop((left, top, left + width, top + height)), width, height)
        source = _blocks(Image.open(io.BytesIO(base64.b64decode(data))).convert("RGB"), width, height)
        difference, blank = np.abs(on_screen - source).mean(), np.abs(255.0 - source).mean()
        assert difference < 0.25 * blank, (f"figure {index} on screen is not its PNG: mean |diff| "
                                           f"{difference:.2f}, a blank box {blank:.2f}")
    # the page's text is drawn too: the head of the report (title, tables) has dark pixels
    assert np.mean(shot[:boxes[0][3]].min(axis=2) < 100) > 0.01

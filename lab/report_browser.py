"""Issue 69's bar: ``d2sr recover`` on a real folder writes report.html whose images load in a headless
browser. Recovers the real Kinect v2 interference (``kinect2_multicam/cam0/interf``), renders the page in
Debian's Chromium (``apt-get install chromium``; not a dependency of d2sr) and checks the screenshot: the
page's images drew (coloured pixels, which the page's text and table do not have).

Run:  python -m lab.report_browser --data ../shared/data --png out/report.png
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    ap.add_argument("--png", type=Path, required=True, help="the screenshot (new file)")
    a = ap.parse_args(argv)
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        raise SystemExit("no chromium: apt-get install chromium")
    if a.png.exists():
        raise SystemExit(f"{a.png} exists")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        src = a.data / "kinect2_multicam" / "cam0" / "interf"
        subprocess.run([sys.executable, "-m", "d2sr", "recover", str(src), "--out", str(out)], check=True)
        page = out / "report.html"
        images = page.read_text().count("data:image/png;base64,")
        shot = Path(tmp) / "shot.png"
        subprocess.run(
            [browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
             "--window-size=1280,2400", f"--screenshot={shot}", page.as_uri()],
            check=True, capture_output=True,
        )  # fmt: skip
        img = cv2.imread(str(shot), cv2.IMREAD_COLOR)
        a.png.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(shot, a.png)
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    coloured = int(np.count_nonzero(hsv[..., 1] > 60))  # saturated: the colour maps, not text or lines
    print(
        f"report.html: {images} images inline; screenshot {img.shape[1]}x{img.shape[0]}, {coloured} coloured pixels"
    )
    return 0 if images and coloured > 1000 * images else 1


if __name__ == "__main__":
    raise SystemExit(main())

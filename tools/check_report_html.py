"""Open report.html in a real headless browser with no network, and check that the 3D view draws.

    python tools/check_report_html.py out/oncentra/report.html
    python tools/check_report_html.py out/oncentra/report.html --screenshot shot.png

Debian's chromium (``apt-get install chromium``) is started headless with every network request
refused (a proxy on a closed port, every host name unresolvable), so the page can only use what
it carries. The check passes when the DOM chromium leaves after running the page's scripts holds
plotly's drawn plot (``class="plot-container plotly"``, the 3D scene's WebGL ``<canvas>`` and
the legend entries of the simulated path), and the screenshot is not blank (its 3D view region
has more than a handful of colours). Prints what it found; exit status 0 when it passes.

This is a tool, not a test: the test suite does not depend on a browser
(tests/report/test_report_html.py checks the page's text: plotly.js inlined, no network
reference, the numbers).
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

NO_NETWORK = [
    "--proxy-server=127.0.0.1:9",  # a closed port: any request fails
    "--host-resolver-rules=MAP * ~NOTFOUND",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
HEADLESS = [
    "--headless=new",
    "--no-sandbox",
    "--disable-dev-shm-usage",
    "--use-angle=swiftshader",  # WebGL in software (no GPU in CI)
    "--enable-unsafe-swiftshader",
    "--hide-scrollbars",
    "--window-size=1400,1600",
    "--virtual-time-budget=20000",
]


def browser() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    raise SystemExit("no chromium found: apt-get install -y chromium")


def run(args: list[str], timeout: float = 120.0) -> subprocess.CompletedProcess:
    return subprocess.run(args, capture_output=True, text=True, timeout=timeout, check=False)


def check(page: Path, screenshot: Path | None) -> bool:
    url = page.resolve().as_uri()
    exe = browser()
    dom = run([exe, *HEADLESS, *NO_NETWORK, "--dump-dom", url]).stdout
    found = {
        "plotly drew the plot (plot-container)": 'class="plot-container plotly"' in dom,
        "a WebGL canvas (3D scene)": bool(re.search(r"<canvas\b", dom)),
        "legend: simulated path": "simulated" in dom and 'class="legend"' in dom,
        "verdict table": "<h2>Verdicts</h2>" in dom,
    }
    with tempfile.TemporaryDirectory() as tmp:
        shot = Path(tmp) / "shot.png"
        run([exe, *HEADLESS, *NO_NETWORK, f"--screenshot={shot}", url])
        if shot.is_file():
            from PIL import Image

            img = Image.open(shot).convert("RGB")
            w, h = img.size
            colours = img.crop((0, int(0.25 * h), w, int(0.75 * h))).getcolors(maxcolors=1 << 20)
            found["screenshot not blank (colours in the view region)"] = len(colours or []) > 50
            if screenshot is not None:
                screenshot.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(shot, screenshot)
        else:
            found["screenshot taken"] = False
    for what, ok in found.items():
        print(f"{'ok  ' if ok else 'FAIL'} {what}")
    return all(found.values())


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("page", type=Path, help="report.html")
    p.add_argument("--screenshot", type=Path, default=None, help="also save the screenshot")
    args = p.parse_args()
    sys.exit(0 if check(args.page, args.screenshot) else 1)


if __name__ == "__main__":
    main()

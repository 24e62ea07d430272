"""The README's screenshot of the live page: ``python docs/live_figure.py`` writes docs/figures/live.png.

The simulated arm (rig 1) through a calibration of the same rig with the
robot file's dynamic term, as ``make live`` runs it, shown in Debian's
Chromium after 12 s (one loop of 8 reaches fills the 10 s plots).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from click.testing import CliRunner

from sailforce.cli import cli
from sailforce.live import browser_page, live_process

OUT = Path(__file__).resolve().parent / "figures" / "live.png"


def main() -> int:
    with tempfile.TemporaryDirectory() as directory:
        d = Path(directory)
        run = lambda *args: CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)
        run("simulate-motion", "--session", "static", "--rig", "1", "-o", d / "static.csv")
        run("calibrate", d / "static.csv", "--model", "matrix", "-q", "--dynamics", "prior", "-o", d / "calibration.json")
        with live_process(["--calibration", d / "calibration.json", "--simulate", "--record-dir", d / "rec"]) as live:
            with browser_page(live.url, width=1200, height=920) as page:
                page.wait_for_timeout(12_000)
                page.screenshot(path=str(OUT), full_page=True)
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

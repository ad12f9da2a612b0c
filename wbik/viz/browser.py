"""The screenshot and console messages of an exported page in headless Chromium (software WebGL, offline)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from wbik.errors import MissingDependencyError
from wbik.viz.scene import ERROR_MESSAGE, READY_MESSAGE

CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
INSTALL_HINT = ("install it with 'bash scripts/setup.sh' (Debian packages chromium and chromium-driver), "
                "or set WBIK_CHROMIUM to a Chromium/Chrome executable")
CONSOLE_LINE = re.compile(r':CONSOLE(?:\(\d+\))?(?::\d+)?\] "(?P<message>.*)", source: (?P<source>.*)$')


@dataclass
class RenderResult:
    """What headless Chromium did with a page."""

    screenshot: Path
    console: list[str] = field(default_factory=list)

    @property
    def ready(self) -> bool:
        return any(line.startswith(READY_MESSAGE) for line in self.console)

    @property
    def errors(self) -> list[str]:
        """Uncaught errors and messages that say error, apart from GPU performance notes."""
        return [line for line in self.console if line.startswith((ERROR_MESSAGE, "Uncaught"))
                or ("error" in line.lower() and "GL Driver Message" not in line)]


def find_chromium() -> str:
    """Path of a Chromium executable, or MissingDependencyError saying how to install one."""
    if override := os.environ.get("WBIK_CHROMIUM"):
        if shutil.which(override) or Path(override).is_file():
            return shutil.which(override) or override
        raise MissingDependencyError(f"WBIK_CHROMIUM={override!r} is not an executable; {INSTALL_HINT}")
    if path := next(filter(None, map(shutil.which, CANDIDATES)), None):
        return path
    raise MissingDependencyError(f"no Chromium browser found (looked for {', '.join(CANDIDATES)}); "
                                 f"{INSTALL_HINT}")


def render(page: str | Path, screenshot: str | Path, width: int = 1000, height: int = 750,
           wait_ms: int = 4000, timeout_s: float = 90.0) -> RenderResult:
    """Screenshot a local HTML ``page`` (PNG) after ``wait_ms`` of virtual time in headless Chromium."""
    executable = find_chromium()
    page = Path(page).resolve()
    screenshot = Path(screenshot).resolve()
    screenshot.parent.mkdir(parents=True, exist_ok=True)
    screenshot.unlink(missing_ok=True)
    with tempfile.TemporaryDirectory(prefix="wbik-chromium-") as profile:
        command = [
            executable, "--headless", "--no-sandbox", "--disable-gpu", "--use-gl=swiftshader",
            "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync",
            "--disable-extensions", "--hide-scrollbars", "--mute-audio", f"--user-data-dir={profile}",
            "--enable-logging=stderr", "--v=0", f"--virtual-time-budget={wait_ms}",
            f"--window-size={width},{height}", f"--screenshot={screenshot}", page.as_uri(),
        ]
        completed = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s,
                                   stdin=subprocess.DEVNULL)
    console = [match.group("message") for line in completed.stderr.splitlines()
               if (match := CONSOLE_LINE.search(line))]
    if not screenshot.is_file():
        raise RuntimeError(f"Chromium made no screenshot of {page} (exit {completed.returncode}); "
                           f"its last messages:\n{completed.stderr[-2000:]}")
    return RenderResult(screenshot, console)

"""A headless Chromium driven over the DevTools protocol (``--remote-debugging-pipe``), stdlib only.

The report's browser test (tests/test_browser.py) loads report.html in a real
browser: images must decode, the table of contents must resolve, nothing may
overflow at 1000 px and no raw LaTeX may reach the page. This module is the
smallest client that can ask those questions: it starts Chromium with the
DevTools pipe on file descriptors 3 (commands in) and 4 (replies out), each
message JSON ending in a NUL byte, attaches to one page and offers
``evaluate`` and ``screenshot``.

Run as a script it writes screenshots of a report::

    python tests/chromium.py REPORT.html OUTDIR
"""

from __future__ import annotations

import base64
import contextlib
import fcntl
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", "--hide-scrollbars",
         "--mute-audio", "--remote-debugging-pipe")


def find_chromium() -> str | None:
    """The Chromium binary: ``$CHROMIUM`` if set, else the first of :data:`CANDIDATES` on PATH."""
    explicit = os.environ.get("CHROMIUM")
    if explicit:
        return explicit
    return next((path for name in CANDIDATES if (path := shutil.which(name))), None)


class Browser:
    """One headless Chromium with one page; use as a context manager."""

    def __init__(self, binary: str, *, width: int = 1000, height: int = 900) -> None:
        self._profile = tempfile.TemporaryDirectory(prefix="mjharness-chromium-")
        to_child, self._commands = os.pipe()
        self._replies, from_child = os.pipe()

        def place_pipes() -> None:  # the child's fd 3 reads commands, fd 4 writes replies
            high = [fcntl.fcntl(fd, fcntl.F_DUPFD, 10) for fd in (to_child, from_child)]  # clear of 3 and 4
            os.dup2(high[0], 3)
            os.dup2(high[1], 4)

        self._proc = subprocess.Popen(
            [binary, *FLAGS, f"--user-data-dir={self._profile.name}", f"--window-size={width},{height}",
             "about:blank"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            pass_fds=(3, 4), preexec_fn=place_pipes)  # kept open in the child after place_pipes
        os.close(to_child)
        os.close(from_child)
        self._buffer = b""
        self._next_id = 0
        self._events: list[dict] = []
        target = self._call("Target.createTarget", url="about:blank")["targetId"]
        self._session = self._call("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]
        self.width = width
        self.call("Page.enable")
        self.call("Runtime.enable")

    # -- protocol
    def _send(self, message: dict) -> None:
        os.write(self._commands, json.dumps(message).encode() + b"\0")

    def _receive(self) -> dict:
        while b"\0" not in self._buffer:
            chunk = os.read(self._replies, 1 << 20)
            if not chunk:
                raise RuntimeError("Chromium closed the DevTools pipe")
            self._buffer += chunk
        raw, _, self._buffer = self._buffer.partition(b"\0")
        return json.loads(raw)

    def _call(self, method: str, session: str | None = None, **params) -> dict:
        self._next_id += 1
        message = {"id": self._next_id, "method": method, "params": params}
        if session:
            message["sessionId"] = session
        self._send(message)
        while True:
            reply = self._receive()
            if reply.get("id") == self._next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error'].get('message')}")
                return reply.get("result", {})
            if "method" in reply:
                self._events.append(reply)

    def call(self, method: str, **params) -> dict:
        """A DevTools command on the page's session."""
        return self._call(method, self._session, **params)

    def wait_for(self, event: str) -> dict:
        """Block until the page emits ``event`` (already-seen events count)."""
        while True:
            for k, seen in enumerate(self._events):
                if seen.get("method") == event:
                    return self._events.pop(k)
            self._events.append(self._receive())

    # -- what the tests use
    def open(self, url: str) -> None:
        """Navigate and wait for the load event (every embedded image is then decoded or broken)."""
        self._events.clear()
        self.call("Emulation.setDeviceMetricsOverride", width=self.width, height=900, deviceScaleFactor=1,
                  mobile=False)
        self.call("Page.navigate", url=url)
        self.wait_for("Page.loadEventFired")

    def evaluate(self, expression: str):
        """The JSON value of a JavaScript expression in the page (promises awaited)."""
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in result:
            raise RuntimeError(f"page script failed: {result['exceptionDetails'].get('text')}: "
                               f"{result['exceptionDetails'].get('exception', {}).get('description')}")
        return result["result"].get("value")

    def screenshot(self, path: Path, *, top: float = 0.0, height: float | None = None) -> Path:
        """A PNG of the page from ``top`` (CSS px), ``height`` tall (to the end of the page if None)."""
        total = float(self.evaluate("document.documentElement.scrollHeight"))
        height = total - top if height is None else min(height, total - top)
        shot = self.call("Page.captureScreenshot", format="png", captureBeyondViewport=True,
                         clip={"x": 0, "y": top, "width": self.width, "height": height, "scale": 1})
        path.write_bytes(base64.b64decode(shot["data"]))
        return path

    def close(self) -> None:
        with contextlib.suppress(RuntimeError, OSError):
            self._call("Browser.close")
        for fd in (self._commands, self._replies):
            with contextlib.suppress(OSError):
                os.close(fd)
        try:
            self._proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        self._profile.cleanup()

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def section_screenshots(browser: Browser, out: Path, *, slice_px: int = 3000) -> list[Path]:
    """The top of the page and the start of every top-level section (a case, the studies, the audit), each
    at most ``slice_px`` tall, as ``NN-ID.png`` in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    anchors = browser.evaluate(
        "[['top', 0]].concat(Array.from(document.querySelectorAll('section[id]'))"
        ".filter(s => !s.parentElement.closest('section'))"
        ".map(s => [s.id, s.getBoundingClientRect().top + window.scrollY]))")
    return [browser.screenshot(out / f"{k:02d}-{name}.png", top=top, height=slice_px)
            for k, (name, top) in enumerate(anchors)]


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: python tests/chromium.py REPORT.html OUTDIR", file=sys.stderr)
        return 2
    binary = find_chromium()
    if binary is None:
        print("chromium not found (install Debian's chromium or set CHROMIUM)", file=sys.stderr)
        return 2
    with Browser(binary) as browser:
        browser.open(Path(argv[0]).resolve().as_uri())
        for path in section_screenshots(browser, Path(argv[1])):
            print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Open a page in headless Chromium: its DOM after the scripts ran, a screenshot, console errors, requests.

One Chromium run per page (``--dump-dom`` and ``--screenshot`` together, after a virtual-time budget
that lets plotly draw), with a network log (``--log-net-log``): the requests the page made are those
whose initiator is the page's opaque ``file://`` origin (``"null"``); the browser's own background
requests have none.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--disable-quic",
         "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-logging=stderr", "--v=0")

#: appended to a copy of the page: redraws every 3D scene and counts its drawn (coloured) WebGL pixels
GL_PROBE = """<script>setTimeout(function () {
  var out = [];
  document.querySelectorAll('.js-plotly-plot').forEach(function (gd) {
    var scene = gd._fullLayout && gd._fullLayout.scene && gd._fullLayout.scene._scene;
    if (!scene) return;
    scene.glplot.redraw();  // draw now and read before the buffer is composited away
    var gl = scene.glplot.gl, w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    var d = new Uint8Array(w * h * 4), n = 0;
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, d);
    for (var i = 0; i < d.length; i += 4) if (d[i + 3] > 0 && (d[i] < 235 || d[i + 1] < 235 || d[i + 2] < 235)) n++;
    out.push(n + '/' + (w * h));
  });
  document.body.setAttribute('data-gl-pixels', out.join(' '));
}, 4000);</script>"""


@dataclass(frozen=True)
class Opened:
    dom: str
    screenshot: Path
    console_errors: list
    requests: list
    gl_pixels: list


def chromium() -> str:
    """The chromium executable; skip when absent (but fail on CI, where bootstrap installs it)."""
    exe = shutil.which("chromium")
    if exe is None:
        if os.environ.get("CI"):
            pytest.fail("chromium is not installed (scripts/bootstrap.sh installs it)")
        pytest.skip("chromium not installed: run scripts/bootstrap.sh as root (apt-get install chromium)")
    return exe


def _page_requests(netlog: Path) -> list:
    text = netlog.read_text(encoding="utf-8", errors="replace") if netlog.exists() else ""
    try:
        events = json.loads(text)["events"]
    except (ValueError, KeyError):  # a log cut short: close it
        events = json.loads(text.rstrip().rstrip(",") + "]}").get("events", [])
    return sorted({e["params"]["url"] for e in events
                   if isinstance(e.get("params"), dict) and e["params"].get("initiator") == "null"
                   and "url" in e["params"]})


def open_page(page: Path, work: Path, *, width: int = 1300, height: int = 5000, probe_gl: bool = True,
              budget_ms: int = 10000) -> Opened:
    """Open ``page`` (a copy with :data:`GL_PROBE`) in headless Chromium; return what it showed."""
    work.mkdir(parents=True, exist_ok=True)
    html = page.read_text(encoding="utf-8")
    if probe_gl:
        html = html.replace("</body>", GL_PROBE + "</body>")
    copy = work / page.name
    copy.write_text(html, encoding="utf-8")
    shot, netlog = work / (page.stem + ".png"), work / "netlog.json"
    run = subprocess.run([chromium(), *FLAGS, f"--user-data-dir={work / 'profile'}", f"--log-net-log={netlog}",
                          f"--virtual-time-budget={budget_ms}", f"--window-size={width},{height}",
                          f"--screenshot={shot}", "--dump-dom", copy.as_uri()],
                         capture_output=True, text=True, timeout=240)
    errors = [line for line in run.stderr.splitlines()
              if "ERROR:CONSOLE" in line or ("CONSOLE" in line and "Uncaught" in line)]
    m = re.search(r'data-gl-pixels="([^"]*)"', run.stdout)
    gl = [tuple(int(v) for v in p.split("/")) for p in m.group(1).split()] if m else []
    return Opened(run.stdout, shot, errors, _page_requests(netlog), gl)

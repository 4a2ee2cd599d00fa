"""The report's pages in headless Debian Chromium: load one from file:// and read what it
wrote into <body data-*> (pagecheck.js: errors, ready; each page its own counts)."""

from __future__ import annotations

import shutil
import subprocess
from html import unescape
from pathlib import Path

CHROMIUM = shutil.which("chromium")


def body_data(url: str, profile: Path) -> dict[str, str]:
    """The page's <body data-*> attributes (names without data-) once it has run."""
    assert CHROMIUM is not None
    r = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu",
                        f"--user-data-dir={profile}", "--window-size=1200,800",
                        "--virtual-time-budget=10000", "--dump-dom", url],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    body = r.stdout[r.stdout.index("<body"):]
    body = body[:body.index(">")]
    out = {}
    for part in body.split(" data-")[1:]:
        key, _, value = part.partition('="')
        out[key] = unescape(value[:value.index('"')])
    assert out.get("ready") == "1", body[:300]
    return out

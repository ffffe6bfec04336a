#!/usr/bin/env python3
"""Drives web/dist's page in headless Chromium for tests/web_page.rs (docs/SPEC.md §10).

    drive_page.py CHROMIUM DIST EXTRA JOBS_JSON

Serves DIST at / and EXTRA at /extra/ on 127.0.0.1, then for each job of JOBS_JSON (a list
of {"query": "scene=extra/x.txt&size=W,H...", "png": PATH or null}) opens
index.html?QUERY, waits until the page's title is no longer `loading` (the hook sets
`done` or the error text) and, when the render is done and "png" is given, writes the
canvas there as a PNG. Prints per job `title: TITLE`, `times: JSON` (the page's render
times) and a line `note: NOTE` for each of the render's notes (the command line's warnings
and notices), and the page's console messages on stderr.

The system's Chromium is driven through Playwright's executable path (no browser of
Playwright's own is downloaded), with WebGPU enabled and its network chatter off.
"""

import base64
import functools
import http.server
import json
import sys
import tempfile
import threading
from pathlib import Path

from playwright.sync_api import sync_playwright

CHROMIUM_ARGS = [
    "--enable-unsafe-webgpu",
    "--no-sandbox",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]

# A render on SwiftShader (WebGPU on the CPU) of a test scene takes seconds; a hang must fail.
RENDER_TIMEOUT_MS = 120_000


class Handler(http.server.SimpleHTTPRequestHandler):
    """DIST at /, EXTRA at /extra/, with .wasm served as application/wasm."""

    extensions_map = {**http.server.SimpleHTTPRequestHandler.extensions_map,
                      ".wasm": "application/wasm", ".js": "text/javascript"}

    def __init__(self, *args, dist, extra, **kwargs):
        self.extra = extra
        super().__init__(*args, directory=dist, **kwargs)

    def translate_path(self, path):
        if path.startswith("/extra/"):
            relative = super().translate_path(path)[len(self.directory):].lstrip("/")
            return str(Path(self.extra) / Path(relative).relative_to("extra"))
        return super().translate_path(path)

    def log_message(self, *args):
        pass


def serve(dist, extra):
    handler = functools.partial(Handler, dist=dist, extra=extra)
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


def run_job(page, base, job):
    page.goto(f"{base}/index.html?{job['query']}")
    page.wait_for_function("document.title !== 'loading'", timeout=RENDER_TIMEOUT_MS)
    title = page.title()
    if title == "done" and job.get("png"):
        url = page.eval_on_selector("#image", "canvas => canvas.toDataURL('image/png')")
        Path(job["png"]).write_bytes(base64.b64decode(url.split(",", 1)[1]))
    return {"title": title, "times": page.evaluate("window.raycasterTimes ?? null"),
            "notes": page.evaluate("window.raycasterNotes ?? []")}


def main():
    chromium, dist, extra, jobs = sys.argv[1], sys.argv[2], sys.argv[3], json.loads(sys.argv[4])
    server = serve(dist, extra)
    base = f"http://127.0.0.1:{server.server_address[1]}"
    results = []
    with tempfile.TemporaryDirectory() as profile, sync_playwright() as playwright:
        browser = playwright.chromium.launch_persistent_context(
            profile, executable_path=chromium, headless=True, args=CHROMIUM_ARGS)
        try:
            for job in jobs:
                page = browser.new_page()
                page.on("console", lambda message: print(f"console: {message.text}", file=sys.stderr))
                results.append(run_job(page, base, job))
                page.close()
        finally:
            browser.close()
    server.shutdown()
    for result in results:
        print("title: " + result["title"].replace("\n", "\\n"))
        print("times: " + json.dumps(result["times"]))
        for note in result["notes"]:
            print("note: " + note.replace("\n", "\\n"))


if __name__ == "__main__":
    main()

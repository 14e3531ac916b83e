"""A headless Chromium driven through the Chrome DevTools protocol (for the browser player's test).

Starts ``chromium --headless`` with a fresh profile and a DevTools port, talks to its page over a
websocket (aiohttp, which the player's libraries install), and offers what the test needs:
open a page, evaluate JavaScript, wait for a condition, take a screenshot, list the addresses the
page requested. No browser is downloaded: the system's ``chromium`` is used.
"""
from __future__ import annotations

import asyncio
import base64
import itertools
import json
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--hide-scrollbars", "--mute-audio"]


def chromium_path():
    """The system's Chromium executable, or None."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        p = shutil.which(name)
        if p:
            return p
    return None


class Browser:
    """One headless Chromium with one page; use as an async context manager."""

    def __init__(self, size=(1280, 800)):
        self.size = size
        self.requests = []
        self._ids = itertools.count(1)
        self._pending = {}

    async def __aenter__(self):
        import aiohttp

        self._profile = tempfile.TemporaryDirectory(prefix="femb-chromium-", ignore_cleanup_errors=True)
        w, h = self.size
        self._proc = subprocess.Popen(
            [chromium_path(), *FLAGS, f"--user-data-dir={self._profile.name}", "--remote-debugging-port=0",
             f"--window-size={w},{h}", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
        port_file = Path(self._profile.name) / "DevToolsActivePort"
        deadline = time.monotonic() + 60.0
        while not port_file.is_file() or len(port_file.read_text().split()) < 2:
            if self._proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("chromium did not start (no DevToolsActivePort)")
            await asyncio.sleep(0.1)
        port = int(port_file.read_text().split()[0])
        self._http = aiohttp.ClientSession()
        for _ in range(100):
            async with self._http.get(f"http://127.0.0.1:{port}/json/list") as resp:
                pages = [p for p in await resp.json(content_type=None) if p.get("type") == "page"]
            if pages:
                break
            await asyncio.sleep(0.1)
        self._ws = await self._http.ws_connect(pages[0]["webSocketDebuggerUrl"], max_msg_size=0)
        self._reader = asyncio.get_event_loop().create_task(self._read())
        await self.send("Network.enable")
        await self.send("Page.enable")
        await self.send("Emulation.setDeviceMetricsOverride", width=w, height=h, deviceScaleFactor=1,
                        mobile=False)
        return self

    async def __aexit__(self, *exc):
        self._reader.cancel()
        await self._ws.close()
        await self._http.close()
        self._proc.terminate()
        try:
            self._proc.wait(10)
        except subprocess.TimeoutExpired:
            self._proc.kill()
        self._profile.cleanup()
        return False

    async def _read(self):
        async for msg in self._ws:
            data = json.loads(msg.data)
            if "id" in data and data["id"] in self._pending:
                self._pending.pop(data["id"]).set_result(data)
            elif data.get("method") == "Network.requestWillBeSent":
                self.requests.append(data["params"]["request"]["url"])

    async def send(self, method, **params):
        """Send one DevTools command; returns its result (raises on an error)."""
        i = next(self._ids)
        fut = asyncio.get_event_loop().create_future()
        self._pending[i] = fut
        await self._ws.send_str(json.dumps({"id": i, "method": method, "params": params}))
        data = await asyncio.wait_for(fut, 60.0)
        if "error" in data:
            raise RuntimeError(f"{method}: {data['error']}")
        return data["result"]

    async def goto(self, url):
        await self.send("Page.navigate", url=url)

    async def evaluate(self, expr):
        """The value of a JavaScript expression in the page (JSON-serialisable)."""
        res = await self.send("Runtime.evaluate", expression=expr, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in res:
            raise RuntimeError(f"javascript error: {res['exceptionDetails']}")
        return res["result"].get("value")

    async def wait_for(self, expr, timeout=60.0):
        """Wait until a JavaScript expression is truthy; returns its value (None on timeout)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                val = await self.evaluate(expr)
            except RuntimeError:
                val = None
            if val:
                return val
            await asyncio.sleep(0.25)
        return None

    async def screenshot(self):
        """The page as PNG bytes."""
        res = await self.send("Page.captureScreenshot", format="png")
        return base64.b64decode(res["data"])

#!/usr/bin/env python3
"""`raytracer view` in a real browser: headless Chromium driven through chromedriver
(W3C WebDriver, spoken here with the standard library alone).

It opens the page, waits for passes, drags the camera and checks that the image changes
and the sample count starts again, saves the camera as a [camera] table and checks that
the scene file with that table renders, with `raytracer SCENE --spp N`, the bits of the
view's film after N passes (the EXR the page's button downloads). It also checks the
safety rules: other hosts, origins and routes are refused, and a hostile WebSocket
message closes that socket only, while a second socket keeps sharing the render.

    tests/browser/view_test.py BINARY [--screenshot PNG] [--measure]

--screenshot writes the page's screenshot (the README's docs/view.png); --measure also
measures the goals (bunny 800x450 and cornell 800x800 on two threads) and prints them.
Prints one JSON line of figures at the end; exits non-zero on the first failed check.
"""

import argparse
import base64
import json
import os
import re
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def fail(message):
    print(f"FAIL: {message}", file=sys.stderr)
    sys.exit(1)


def check(condition, message):
    if not condition:
        fail(message)
    print(f"ok: {message}")


class WebDriver:
    """The few W3C WebDriver commands the test needs."""

    def __init__(self, chromedriver, chromium):
        self.port = free_port()
        self.process = subprocess.Popen(
            [chromedriver, f"--port={self.port}"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        self.base = f"http://127.0.0.1:{self.port}"
        for _ in range(100):
            try:
                self.call("GET", "/status")
                break
            except OSError:
                time.sleep(0.1)
        options = {
            "binary": chromium,
            "args": [
                "--headless=new",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-dev-shm-usage",
                "--window-size=900,800",
            ],
        }
        caps = {"capabilities": {"alwaysMatch": {"goog:chromeOptions": options}}}
        self.session = self.call("POST", "/session", caps)["sessionId"]

    def call(self, method, path, body=None):
        data = None if body is None else json.dumps(body).encode()
        request = urllib.request.Request(self.base + path, data=data, method=method)
        request.add_header("Content-Type", "application/json")
        try:
            with urllib.request.urlopen(request, timeout=60) as response:
                return json.loads(response.read())["value"]
        except urllib.error.HTTPError as e:
            fail(f"webdriver {method} {path}: {e.read()[:500]!r}")

    def s(self, method, path, body=None):
        return self.call(method, f"/session/{self.session}{path}", body)

    def get(self, url):
        self.s("POST", "/url", {"url": url})

    def js(self, script, *args):
        return self.s("POST", "/execute/sync", {"script": script, "args": list(args)})

    def js_async(self, script, *args):
        return self.s("POST", "/execute/async", {"script": script, "args": list(args)})

    def element(self, css):
        found = self.s("POST", "/element", {"using": "css selector", "value": css})
        return next(iter(found.values()))

    def click(self, css):
        self.s("POST", f"/element/{self.element(css)}/click", {})

    def actions(self, actions):
        self.s("POST", "/actions", {"actions": actions})
        self.s("DELETE", "/actions")

    def screenshot(self, path, css):
        """A screenshot of the element `css` (PNG)."""
        with open(path, "wb") as f:
            f.write(base64.b64decode(self.s("GET", f"/element/{self.element(css)}/screenshot")))

    def quit(self):
        try:
            self.call("DELETE", f"/session/{self.session}")
        finally:
            self.process.terminate()
            self.process.wait(timeout=10)


class View:
    """A `raytracer view` process and its URL."""

    def __init__(self, binary, *args):
        # An empty working directory: the view writes no file, and Ctrl-C leaves none.
        self.cwd = tempfile.mkdtemp(prefix="raytracer-view-")
        self.process = subprocess.Popen(
            [os.path.abspath(binary), "view", *args, "--port", "0"],
            cwd=self.cwd,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        line = self.process.stdout.readline()
        match = re.search(r"http://(127\.0\.0\.1:\d+)/", line)
        if not match:
            fail(f"no URL from raytracer view: {line!r} {self.process.stderr.read()!r}")
        self.host = match.group(1)
        self.url = f"http://{self.host}/"

    def fetch(self, path, host=None, origin=None):
        request = urllib.request.Request(self.url.rstrip("/") + path)
        if host:
            request.add_header("Host", host)
        if origin:
            request.add_header("Origin", origin)
        try:
            with urllib.request.urlopen(request, timeout=60) as response:
                return response.status, response.read()
        except urllib.error.HTTPError as e:
            return e.code, e.read()

    def stop(self):
        """Ctrl-C: the process ends by the signal, and says nothing on its way out."""
        self.process.send_signal(2)
        code = self.process.wait(timeout=10)
        left = os.listdir(self.cwd)
        os.rmdir(self.cwd) if not left else None
        check(not left, f"the view left no file ({left})")
        return code


def wait_for(driver, condition, timeout, what):
    end = time.time() + timeout
    while time.time() < end:
        value = driver.js(f"return {condition};")
        if value:
            return value
        time.sleep(0.05)
    fail(f"timed out waiting for {what}: {driver.js('return window.viewStats;')}")


def stats(driver):
    return driver.js("return window.viewStats;")


def canvas_digest(driver):
    """A digest of the canvas's pixels (their sum and a rolling hash)."""
    return driver.js(
        """const c = document.getElementById('view');
        const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
        let sum = 0, hash = 0;
        for (let i = 0; i < d.length; i += 4) {
            sum += d[i] + d[i + 1] + d[i + 2];
            hash = (hash * 31 + d[i] + 7 * d[i + 1] + 13 * d[i + 2]) >>> 0;
        }
        return [sum, hash];"""
    )


def drag(driver, steps, dx, dy, button=0, pause_ms=20):
    """A drag from the canvas's centre: `steps` moves of (dx, dy) pixels."""
    canvas = driver.element("#view")
    moves = [{"type": "pointerMove", "origin": {"element-6066-11e4-a52e-4f735466cecf": canvas},
              "x": 0, "y": 0, "duration": 0},
             {"type": "pointerDown", "button": button}]
    for _ in range(steps):
        moves.append({"type": "pointerMove", "origin": "pointer", "x": dx, "y": dy,
                      "duration": pause_ms})
    moves.append({"type": "pointerUp", "button": button})
    driver.actions([{"type": "pointer", "id": "mouse", "parameters": {"pointerType": "mouse"},
                     "actions": moves}])


def measure_at_rest(driver, seconds):
    """Passes a second at rest, from the page's own frame times: samples of its
    passesPerSecond, and the passes' render, encode and send times."""
    driver.js("const s = window.viewStats; s.passMs.length = 0; s.encodeMs.length = 0;"
              " s.sendMs.length = 0;")
    rates = []
    end = time.time() + seconds
    while time.time() < end:
        time.sleep(0.25)
        rates.append(stats(driver)["passesPerSecond"])
    s = stats(driver)
    pass_ms = statistics.median(s["passMs"])
    encode_ms = statistics.median(s["encodeMs"])
    send_ms = statistics.median(s["sendMs"]) if s["sendMs"] else 0.0
    return {
        "passes_per_second": round(statistics.median(rates[2:] or rates), 1),
        "pass_ms": round(pass_ms, 2),
        "encode_ms": round(encode_ms, 2),
        "send_ms": round(send_ms, 2),
        # The server's time a second (a frame's encoding and sending, at the frame rate)
        # over the renderer's (a pass's time, at the pass rate).
        "server_share": round(s["framesPerSecond"] * (encode_ms + send_ms)
                              / (s["passesPerSecond"] * pass_ms), 3),
        "mrays_per_second": round(s["mraysPerSecond"], 1),
        "frames_per_second": round(s["framesPerSecond"], 1),
    }


def measure_moves(driver, steps=40):
    """Frame latency after a move: a drag of `steps` moves 30 ms apart."""
    driver.js("window.viewStats.latencies.length = 0; window.viewStats.previews = 0;")
    drag(driver, steps, 3, 1, pause_ms=30)
    time.sleep(0.5)
    s = stats(driver)
    latencies = s["latencies"]
    return {
        "moves": len(latencies),
        "previews": s.get("previews", 0),
        "preview_factor": s.get("previewFactor", 1),
        "latency_median_ms": round(statistics.median(latencies), 1),
        "latency_p90_ms": round(sorted(latencies)[int(0.9 * (len(latencies) - 1))], 1),
        "latency_max_ms": round(max(latencies), 1),
    }


def replace_camera(scene_text, table):
    start = scene_text.index("[camera]")
    rest = scene_text[start + len("[camera]"):]
    end = re.search(r"^\[", rest, re.M)
    tail = rest[end.start():] if end else ""
    return scene_text[:start] + table + "\n" + tail


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("binary")
    parser.add_argument("--screenshot")
    parser.add_argument("--measure", action="store_true")
    args = parser.parse_args()
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    chromedriver = shutil.which("chromedriver")
    if not chromium or not chromedriver:
        fail("chromium and chromedriver are needed")
    figures = {}
    driver = WebDriver(chromedriver, chromium)
    try:
        # The page, its passes, and the safety rules, on bunny at its own size.
        view = View(args.binary, "bunny", "--threads", "2")
        driver.get(view.url)
        wait_for(driver, "window.viewStats.passes >= 20", 60, "20 passes")
        s = stats(driver)
        check((s["width"], s["height"]) == (800, 450), f"the page shows 800x450: {s['width']}x{s['height']}")
        status, _ = view.fetch("/", host=f"evil.example:{view.host.split(':')[1]}")
        check(status == 403, f"another host name is refused ({status})")
        status, _ = view.fetch("/camera.toml", origin="http://evil.example")
        check(status == 403, f"another origin is refused ({status})")
        status, _ = view.fetch("/../../etc/passwd")
        check(status == 404, f"other routes are 404 ({status})")
        status, body = view.fetch("/camera.toml")
        check(status == 200 and body.startswith(b"[camera]\n"), "the camera table is served")

        at_rest = measure_at_rest(driver, 3)
        figures["bunny_800x450"] = at_rest
        print(f"bunny at rest: {at_rest}")
        if args.screenshot:
            driver.screenshot(args.screenshot, "main")

        # A second socket shares the render; a hostile message closes its own socket only.
        driver.js_async(
            """const done = arguments[arguments.length - 1];
            const ws = new WebSocket(`ws://${location.host}/ws`);
            ws.binaryType = 'arraybuffer';
            let gen = null;
            ws.onmessage = (e) => {
                if (typeof e.data === 'string') return;
                gen = new DataView(e.data).getUint32(8, true);
                ws.send('{"shutdown": true}');
            };
            ws.onclose = () => { window.secondSocket = {generation: gen}; done(); };"""
        )
        second = driver.js("return window.secondSocket;")
        check(second["generation"] == stats(driver)["generation"],
              f"a second socket gets the same render ({second})")
        frames = stats(driver)["frames"]
        time.sleep(0.5)
        check(not stats(driver)["closed"] and stats(driver)["frames"] > frames,
              "a hostile message closed its socket only: the page still gets frames")

        # Drag: the image changes and the count starts again.
        before = stats(driver)
        digest = canvas_digest(driver)
        drag(driver, 10, 12, 4)
        wait_for(driver, f"window.viewStats.generation > {before['generation']}", 10, "a moved frame")
        after = stats(driver)
        check(after["passes"] < before["passes"],
              f"the pass count restarts after a drag ({before['passes']} -> {after['passes']})")
        time.sleep(0.3)
        check(canvas_digest(driver) != digest, "the image changes after a drag")
        moves = measure_moves(driver)
        figures["bunny_moves"] = moves
        print(f"bunny moving: {moves}")

        # The camera button gives the moved camera.
        driver.click("#show-camera")
        table = wait_for(driver, "document.getElementById('camera').value", 10, "the camera table")
        check(table.startswith("[camera]\nwidth = 800\naspect_ratio = \"16:9\"\n"),
              "the camera button shows the [camera] table")
        check("look_from = [0.0, 0.0, 0.5]" not in table, "the table holds the moved camera")
        code = view.stop()
        check(code in (-2, 130), f"Ctrl-C stops the view ({code})")

        # Bit-identity: N passes of a moved camera against the command line.
        n = 6
        view = View(args.binary, "spheres", "--width", "160", "--spp", str(n), "--threads", "2")
        driver.get(view.url)
        wait_for(driver, "window.viewStats.passes >= 1", 30, "the first pass")
        drag(driver, 4, 10, -6)
        drag(driver, 3, 8, 5, button=2)
        wait_for(driver, f"window.viewStats.passes === {n} && window.viewStats.frames > 3", 30,
                 f"{n} passes after the moves")
        time.sleep(0.3)
        check(stats(driver)["passes"] == n, f"the view stops at --spp {n}")
        driver.click("#show-camera")
        table = wait_for(driver, "document.getElementById('camera').value", 10, "the camera table")
        status, exr = view.fetch("/image.exr")
        check(status == 200 and exr[:4] == b"v/1\x01", "the EXR button's image is an EXR")
        status, png = view.fetch("/image.png")
        check(status == 200 and png[:8] == b"\x89PNG\r\n\x1a\n", "the PNG button's image is a PNG")
        view.stop()
        with tempfile.TemporaryDirectory() as tmp:
            scene = os.path.join(tmp, "moved.toml")
            with open(os.path.join(ROOT, "scenes", "spheres.toml")) as f:
                text = replace_camera(f.read(), table)
            with open(scene, "w") as f:
                f.write(text)
            out = os.path.join(tmp, "moved.exr")
            subprocess.run([args.binary, scene, "--spp", str(n), "-q", "-o", out], check=True)
            with open(out, "rb") as f:
                cli = f.read()
            unmoved = os.path.join(tmp, "unmoved.exr")
            subprocess.run([args.binary, "spheres", "--width", "160", "--spp", str(n), "-q",
                            "-o", unmoved], check=True)
            with open(unmoved, "rb") as f:
                check(f.read() != exr, "the moved view is not the scene's own camera")
        check(cli == exr, f"the view's film after {n} passes is the bits of --spp {n} with its camera")

        if args.measure:
            view = View(args.binary, "cornell", "--threads", "2")
            driver.get(view.url)
            wait_for(driver, "window.viewStats.passes >= 5", 60, "5 passes")
            figures["cornell_800x800"] = measure_at_rest(driver, 5)
            print(f"cornell at rest: {figures['cornell_800x800']}")
            figures["cornell_moves"] = measure_moves(driver, 20)
            print(f"cornell moving: {figures['cornell_moves']}")
            view.stop()
    finally:
        driver.quit()
    print(json.dumps(figures))


if __name__ == "__main__":
    main()

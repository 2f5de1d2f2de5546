# SPDX-License-Identifier: Apache-2.0
"""nebview's page in a headless Chromium (Debian's chromium and chromium-driver, driven by
python3-selenium): the page loads and shows the final frame; orbiting by mouse changes the
image (latency and frame rate measured); the voxel probe answers a click; a camera path built
in the page is saved and rendered by nebrender; a broken path file is refused with a message
and the page goes on.

    test_browser.py NEBVIEW NEBRENDER INPUT_VDB WORKDIR

Skipped (exit 77) without chromium, chromedriver or selenium. The timing figures (latency
median <= 100 ms, >= 10 frames per second while orbiting) are printed as "TIMING MISS"
warnings unless NEBVIEW_STRICT_TIMING=1: a shared 2-core machine is noisy.
"""
import json
import math
import os
import queue
import shutil
import signal
import statistics
import subprocess
import sys
import threading
import time

SKIP = 77
DEBIAN_PYTHON = "/usr/bin/python3"

try:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait
    from selenium.common.exceptions import TimeoutException
except ImportError:
    # A virtual environment or pyenv may come first on PATH without Debian's modules.
    if (os.path.realpath(sys.executable) != os.path.realpath(DEBIAN_PYTHON)
            and os.path.exists(DEBIAN_PYTHON)
            and subprocess.run([DEBIAN_PYTHON, "-c", "import selenium"],
                               capture_output=True).returncode == 0):
        os.execv(DEBIAN_PYTHON, [DEBIAN_PYTHON] + sys.argv)
    print("SKIP: python3-selenium is missing")
    sys.exit(SKIP)



# Every wait's bound follows the machine's measured speed (tests/machine_speed.sh, as the
# ctest time-outs do): the waits are for conditions; the bounds only catch a hang.
SCALE = int(os.environ.get("NEBULA_TEST_TIME_SCALE", "1") or "1")

def find_program(names):
    for name in names:
        found = shutil.which(name)
        if found:
            return found
    return None


CHROMIUM = find_program(["/usr/bin/chromium", "chromium"])
CHROMEDRIVER = find_program(["/usr/bin/chromedriver", "chromedriver"])
if not CHROMIUM or not CHROMEDRIVER:
    missing = [name for name, path in (("chromium", CHROMIUM), ("chromium-driver", CHROMEDRIVER))
               if not path]
    print("SKIP: " + " and ".join(missing) + " missing")
    sys.exit(SKIP)

if len(sys.argv) != 5:
    print(__doc__)
    sys.exit(2)
NEBVIEW, NEBRENDER, INPUT_VDB, WORK = sys.argv[1:5]
WORK = os.path.abspath(WORK)
os.makedirs(WORK, exist_ok=True)
STRICT_TIMING = os.environ.get("NEBVIEW_STRICT_TIMING") == "1"


class Failure(Exception):
    pass


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        raise Failure(what)


def timing(ok, what):
    """A timing figure: a failure only with NEBVIEW_STRICT_TIMING=1."""
    if ok:
        print("ok   " + what, flush=True)
    elif STRICT_TIMING:
        check(False, what)
    else:
        print("TIMING MISS " + what, flush=True)


def start_nebview():
    """Starts nebview (stdout piped)."""
    path_out = os.path.join(WORK, "path.json")
    if os.path.exists(path_out):
        os.remove(path_out)
    cmd = [NEBVIEW, "-i", INPUT_VDB, "--res", "512x512", "--path-out", path_out]
    cmd += os.environ.get("NEBVIEW_ARGS", "").split()  # e.g. "--fast-step 1.5" (benchmarks)
    print("$ " + " ".join(cmd), flush=True)
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)


def nebview_url(proc):
    """The URL nebview prints first (within 60 s)."""
    lines = queue.Queue()

    def reader():  # keeps reading so that the pipe never fills
        for line in proc.stdout:
            lines.put(line.rstrip("\n"))
        lines.put(None)

    threading.Thread(target=reader, daemon=True).start()
    deadline = time.monotonic() + 60 * SCALE
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            raise Failure(f"nebview printed no URL within {60 * SCALE} s")
        try:
            line = lines.get(timeout=min(left, 1.0))
        except queue.Empty:
            if proc.poll() is not None and lines.empty():
                raise Failure(f"nebview exited ({proc.returncode}) before printing its URL")
            continue
        if line is None:
            proc.wait()
            raise Failure(f"nebview exited ({proc.returncode}) before printing its URL")
        if line.startswith("http://"):
            return line.strip()
        print("nebview: " + line, flush=True)


def start_browser():
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1200,900",
                "--disable-dev-shm-usage", "--no-first-run", "--disable-extensions"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)


def js(driver, script, *args):
    return driver.execute_script(script, *args)


def wait_for(driver, script, what, timeout=60, *args):
    """Waits until @p script (a JS expression's body, `return ...`) is truthy."""
    timeout *= SCALE
    try:
        return WebDriverWait(driver, timeout, poll_frequency=0.05).until(
            lambda d: d.execute_script(script, *args))
    except TimeoutException:
        state = js(driver, "const n = window.nebview; return n ? JSON.stringify({"
                   "lastFrame: n.lastFrame && Object.assign({}, n.lastFrame, {camera: undefined}),"
                   "lastViewId: n.lastViewId, frames: n.frames, lastError: n.lastError,"
                   "connected: n.connected, jsErrors: n.jsErrors}) : 'no window.nebview'")
        raise Failure(f"timed out after {timeout} s waiting for {what} (page: {state})")


FINAL_OF_LAST_VIEW = ("const n = window.nebview; return !!(n && n.lastFrame && "
                      "n.lastFrame.stage === 'final' && n.lastViewId > 0 && "
                      "n.lastFrame.id >= n.lastViewId);")


def wait_final(driver, what):
    wait_for(driver, FINAL_OF_LAST_VIEW, what)


def canvas_data(driver):
    return js(driver, "return document.getElementById('view').toDataURL('image/png');")


def drag(driver, canvas, steps, dx=8, dy=0, pause=0.03):
    """Left-drags from the canvas centre in @p steps moves; returns the seconds it took."""
    actions = ActionChains(driver, duration=10)  # each pointer move 10 ms (default 250)
    actions.move_to_element(canvas).click_and_hold()
    for _ in range(steps):
        actions.move_by_offset(dx, dy).pause(pause)
    actions.release()
    t0 = time.perf_counter()
    actions.perform()
    return time.perf_counter() - t0


def finite_vec(v):
    return isinstance(v, list) and len(v) == 3 and all(
        isinstance(x, (int, float)) and math.isfinite(x) for x in v)


def run_test(driver, url):
    # 2. The page, to its first final frame.
    driver.get(url)
    wait_for(driver, "return !!window.nebview;", "window.nebview", timeout=10)
    wait_final(driver, "the first final frame")
    load_ms = js(driver, "return performance.getEntriesByType('navigation')[0].loadEventEnd;")
    first_final_ms = js(driver, "return performance.now();")
    print(f"page load: {load_ms:.0f} ms", flush=True)
    print(f"first final frame by: {first_final_ms:.0f} ms", flush=True)
    check(0 < load_ms < 1000, f"page load {load_ms:.0f} ms < 1000 ms")
    hello = js(driver, "return window.nebview.hello;")
    check(isinstance(hello, dict) and hello.get("type") == "hello", "hello stored in window.nebview")
    frame = js(driver, "return window.nebview.lastFrame;")
    print(f"final frame: {frame['width']}x{frame['height']} {frame.get('format')}, "
          f"render {frame.get('render_ms')} ms, {frame.get('samples')} samples", flush=True)
    check(frame["width"] == 512 and frame["height"] == 512, "the final frame is 512x512")

    # 3. The page and the canvas as they are (the README's screenshot is the page's).
    canvas = driver.find_element(By.ID, "view")
    shot = os.path.join(WORK, "screenshot.png")
    driver.save_screenshot(shot)
    check(os.path.getsize(shot) > 0, "screenshot " + shot)
    canvas_shot = os.path.join(WORK, "canvas.png")
    canvas.screenshot(canvas_shot)
    check(os.path.getsize(canvas_shot) > 0, "canvas screenshot " + canvas_shot)
    before = canvas_data(driver)

    # 4. Orbit by mouse.
    n_lat = js(driver, "return window.nebview.latencies.length;")
    frames0 = js(driver, "return window.nebview.frames;")
    seconds = drag(driver, canvas, 30)
    frames1 = js(driver, "return window.nebview.frames;")
    during = js(driver, "return window.nebview.latencies.slice(arguments[0]);", n_lat)
    wait_final(driver, "the final frame after the orbit")
    after = canvas_data(driver)
    check(after != before, "the image changed after orbiting")
    camera = js(driver, "return window.nebview.state.camera;")
    check(camera["eye"] != hello["camera"]["eye"], "the orbit moved the eye")
    fps = (frames1 - frames0) / seconds if seconds > 0 else 0.0
    print(f"drag: {seconds * 1000:.0f} ms, {frames1 - frames0} frames drawn, "
          f"{len(during)} latencies", flush=True)
    if during:
        median = statistics.median(during)
        print(f"latency median: {median:.1f} ms (min {min(during):.1f}, max {max(during):.1f})",
              flush=True)
        timing(median <= 100, f"latency median {median:.1f} ms <= 100 ms")
    else:
        print("latency median: none (no frame drawn during the drag)", flush=True)
        timing(False, "no frame answered the drag while it lasted")
    print(f"fps while orbiting: {fps:.1f}", flush=True)
    timing(fps >= 10, f"fps while orbiting {fps:.1f} >= 10")

    # 4b. Single inputs at rest (a user scrolling once): one wheel step each time the last
    # view's preview (or final) frame is on screen, so a refinement is in flight to cancel.
    steps = []
    for i in range(6):
        wait_for(driver, "const f = window.nebview.lastFrame; return !!f && "
                 "f.id >= window.nebview.lastViewId && f.stage !== 'interactive';",
                 "the preview of the last view", 60)
        n = js(driver, "return window.nebview.latencies.length;")
        js(driver, "document.getElementById('view').dispatchEvent(new WheelEvent('wheel', "
           "{deltaY: arguments[0], bubbles: true, cancelable: true}));", 60 if i % 2 else -60)
        steps.append(wait_for(driver, "const l = window.nebview.latencies; "
                              "return l.length > arguments[0] ? l[arguments[0]] : null;",
                              "the frame answering one wheel step", 30, n))
    step_median = statistics.median(steps)
    print(f"latency of single inputs at rest: median {step_median:.1f} ms "
          f"(min {min(steps):.1f}, max {max(steps):.1f}, {len(steps)} wheel steps)", flush=True)
    timing(step_median <= 100, f"latency of single inputs {step_median:.1f} ms <= 100 ms")

    # 5. The voxel probe at the image centre of the starting camera.
    view_id = js(driver, "return window.nebview.setCamera(arguments[0]);", hello["camera"])
    check(view_id > 0, "setCamera sent a view")
    wait_final(driver, "the final frame of the starting camera")
    js(driver, "window.nebview.lastProbe = null;")
    probe_box = driver.find_element(By.ID, "probe-on-click")
    if not probe_box.is_selected():
        probe_box.click()
    t0 = time.perf_counter()
    ActionChains(driver, duration=10).move_to_element(canvas).click().perform()
    probe = wait_for(driver, "return window.nebview.lastProbe;", "the probe's answer", 30)
    print(f"probe: {(time.perf_counter() - t0) * 1000:.0f} ms round trip: "
          f"{json.dumps(probe)}", flush=True)
    probe_box.click()  # off again
    w, h = hello["width"], hello["height"]
    check(abs(probe["x"] - w / 2) <= 2 and abs(probe["y"] - h / 2) <= 2,
          f"the probe asked for the image centre ({probe['x']}, {probe['y']})")
    check(probe.get("hit") is True, "the probe hit dust at the image centre")
    density = probe.get("density")
    check(isinstance(density, (int, float)) and math.isfinite(density) and density > 0,
          f"the density {density} cm^-3 is a positive number")
    position = probe.get("position")
    check(finite_vec(position), f"the position {position} is finite")
    lo, hi = hello["box"]["min"], hello["box"]["max"]
    slack = [1e-6 * max(1.0, abs(a), abs(b)) for a, b in zip(lo, hi)]
    check(all(lo[i] - slack[i] <= position[i] <= hi[i] + slack[i] for i in range(3)),
          f"the position lies in the box {lo} .. {hi}")
    panel = driver.find_element(By.ID, "probe").text
    check("cm" in panel, "the probe panel shows the answer")

    # 6. A camera path: two keyframes, saved, rendered by nebrender.
    js(driver, "window.nebview.lastSaved = null;")
    driver.find_element(By.ID, "add-key").click()
    drag(driver, canvas, 10)
    wait_final(driver, "the final frame after the second orbit")
    driver.find_element(By.ID, "add-key").click()
    rows = len(driver.find_elements(By.CSS_SELECTOR, "#keys tbody tr"))
    check(rows == 2, f"two keyframes in the list ({rows})")
    driver.find_element(By.ID, "save-path").click()
    saved = wait_for(driver, "return window.nebview.lastSaved;", "the path to be saved", 30)
    print("saved: " + json.dumps(saved), flush=True)
    path_file = os.path.join(WORK, "path.json")
    check(os.path.exists(path_file), path_file + " exists")
    with open(path_file) as f:
        path = json.load(f)
    keys = path.get("keyframes", [])
    check(len(keys) == 2, f"{path_file} has 2 keyframes ({len(keys)})")
    check(keys[0]["time"] < keys[1]["time"], "keyframe times increase")
    frames_dir = os.path.join(WORK, "frames")
    os.makedirs(frames_dir, exist_ok=True)
    for name in os.listdir(frames_dir):
        os.remove(os.path.join(frames_dir, name))
    cmd = [NEBRENDER, "-i", INPUT_VDB, "--camera-path", path_file, "--frames", "1-2",
           "--res", "64x64", "-o", os.path.join(frames_dir, "f.####.exr")]
    print("$ " + " ".join(cmd), flush=True)
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600 * SCALE)
    print(f"nebrender: {(time.perf_counter() - t0) * 1000:.0f} ms, exit {r.returncode}", flush=True)
    if r.returncode != 0:
        print(r.stdout + r.stderr)
    check(r.returncode == 0, "nebrender renders the saved path")
    for n in (1, 2):
        for ext in ("exr", "png"):
            out = os.path.join(frames_dir, f"f.{n:04d}.{ext}")
            check(os.path.exists(out), out + " exists")

    # 7. A broken path file: refused with a message, and the page goes on.
    bad = os.path.join(WORK, "bad.json")
    with open(bad, "w") as f:
        f.write('{"fps": 24, "keyframes": [')
    js(driver, "window.nebview.lastError = null;")
    driver.find_element(By.ID, "load-path").send_keys(bad)
    error = wait_for(driver, "return window.nebview.lastError;", "the error for bad.json", 30)
    print("error: " + json.dumps(error), flush=True)
    text = json.dumps(error).lower()
    check("bad.json" in text or "parse" in text, "the error names bad.json or parsing")
    check(driver.find_element(By.ID, "error").is_displayed(), "the error is shown")
    check(len(driver.find_elements(By.CSS_SELECTOR, "#keys tbody tr")) == 2,
          "the keyframes are kept")
    frames0 = js(driver, "return window.nebview.frames;")
    cam = js(driver, "return window.nebview.state.camera;")
    view_id = js(driver, "return window.nebview.setCamera(arguments[0]);", cam)
    check(view_id > 0, "setCamera sent a view after the error")
    wait_final(driver, "a final frame after the error")
    check(js(driver, "return window.nebview.frames;") > frames0, "frames still arrive")
    js_errors = js(driver, "return window.nebview.jsErrors;")
    check(not js_errors, f"no script errors on the page {js_errors}")


def main():
    proc = None
    driver = None
    ok = False
    try:
        proc = start_nebview()
        url = nebview_url(proc)
        print("url: " + url.split("?")[0] + "?token=…", flush=True)
        driver = start_browser()
        run_test(driver, url)
        ok = True
    except Failure as e:
        print("browser test failed: " + str(e), flush=True)
    finally:
        if driver is not None:
            if not ok:
                try:
                    for entry in driver.get_log("browser"):
                        print("browser: " + entry.get("level", "") + " " + entry.get("message", ""))
                except Exception as e:  # the log is a diagnosis only
                    print(f"(no browser log: {e})")
            driver.quit()
        if proc is not None and proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=20 * SCALE)
            except subprocess.TimeoutExpired:
                print("nebview did not stop on SIGTERM within 20 s: killed")
                proc.kill()
                proc.wait()
                ok = False
        if proc is not None:
            print(f"nebview exited {proc.returncode}", flush=True)
    if not ok:
        sys.exit(1)
    print("browser test passed", flush=True)


if __name__ == "__main__":
    main()

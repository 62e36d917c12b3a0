#!/usr/bin/python3
"""How long the dashboard's page of a large study takes to open, in headless Chromium.

    /usr/bin/python3 bench/dashboard_open.py --build BUILD [--runs 50000] [--repeat 7] [--shot PNG]

Fills a fresh store with one succeeded study of the load benchmark's spec (4 models x k_d over
12,500 values at v_a/v_d = 1, 2 x 2 s stages; bench/dashboard_fill writes made-up runs in the
rows a real study leaves, since running 50,000 runs takes minutes), starts stickslipd on it, and
opens #/studies/ID in a new page load `repeat` times. "open" is the page's own mark
`study-ready` (performance.now() at the moment header, progress, spec, the first runs page, the
map's line charts and the heat map are all drawn), measured from the start of the navigation,
so it includes loading the dashboard, every /v1 request and drawing. Prints each load and the
median, and the time and size of each API request of the last load (Resource Timing).
"""
import argparse
import json
import os
import shutil
import signal
import statistics
import subprocess
import tempfile
import time

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.support.ui import WebDriverWait


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--build", required=True)
    p.add_argument("--runs", type=int, default=50000, help="4 models x runs/4 values of k_d")
    p.add_argument("--repeat", type=int, default=7)
    p.add_argument("--shot", help="save a screenshot of the last load here")
    a = p.parse_args()
    work = tempfile.mkdtemp(prefix="stickslip-open-")
    spec = {"name": "load", "stages": [{"duration": 2}, {"duration": 2, "f": 1500}],
            "design": {"type": "grid", "axes": [
                {"name": "k_d", "linspace": [11600, 11800, a.runs // 4]},
                {"name": "va_over_vd", "values": [1]},
                {"name": "model", "values": ["dahl", "karnopp", "reset_integrator", "lugre"]}]}}
    with open(os.path.join(work, "spec.json"), "w") as f:
        json.dump(spec, f)
    db = os.path.join(work, "open.db")
    t0 = time.time()
    sid = subprocess.check_output([os.path.join(a.build, "bench", "dashboard_fill"), os.path.join(work, "spec.json"), db],
                                  text=True).strip()
    print("filled %d runs in %.1f s: %s" % (a.runs, time.time() - t0, sid))
    port_file = os.path.join(work, "port")
    daemon = subprocess.Popen([os.path.join(a.build, "server", "stickslipd"), "--db", db, "--port", "0",
                               "--port-file", port_file, "--log-level", "warn"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    driver = None
    try:
        for _ in range(400):
            if os.path.exists(port_file) and os.path.getsize(port_file) > 0:
                break
            time.sleep(0.025)
        with open(port_file) as f:
            url = "http://127.0.0.1:" + f.read().strip()
        opts = webdriver.ChromeOptions()
        opts.binary_location = "/usr/bin/chromium"
        for arg in ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                    "--disable-background-networking", "--disable-component-update", "--disable-sync",
                    "--disable-dev-shm-usage", "--window-size=1400,1000",
                    "--user-data-dir=" + os.path.join(work, "profile")]:
            opts.add_argument(arg)
        driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=opts)
        times = []
        for i in range(a.repeat):
            # A new document each time (the query string differs; the route is still /).
            driver.get("%s/?load=%d#/studies/%s" % (url, i, sid))
            WebDriverWait(driver, 60, poll_frequency=0.02).until(
                lambda d: d.execute_script("return document.body.dataset.ready") == "study")
            marks = driver.execute_script(
                "return Object.fromEntries(performance.getEntriesByType('mark').map(m => [m.name, m.startTime]))")
            ms = marks["study-ready"]
            times.append(ms)
            print("load %d: %.0f ms (runs table %.0f, map fetched %.0f, map drawn %.0f)"
                  % (i + 1, ms, marks.get("runs-drawn", -1), marks.get("map-fetched", -1), marks.get("map-drawn", -1)))
        print("median %.0f ms, min %.0f, max %.0f over %d loads (the first load fills the browser cache)"
              % (statistics.median(times), min(times), max(times), len(times)))
        for e in driver.execute_script(
                "return performance.getEntriesByType('resource').filter(e => e.name.includes('/v1/'))"
                ".map(e => [e.name.replace(location.origin, ''), e.duration, e.encodedBodySize])"):
            print("  %-60s %6.0f ms %9d bytes" % (e[0][:60], e[1], e[2]))
        cells = driver.execute_script("const c = window.stickslip.charts['heatmap'];"
                                      "return c ? c.stickslipCells.z.flat().length : 0")
        points = driver.execute_script("const u = window.stickslip.charts['map-amplitude'];"
                                       "return u.data.slice(1).reduce((n, d) => n + d.length, 0)")
        print("drawn: %d map points per chart, %d heat-map cells" % (points, cells))
        if a.shot:
            driver.save_screenshot(a.shot)
    finally:
        if driver:
            driver.quit()
        daemon.send_signal(signal.SIGTERM)
        daemon.wait(timeout=30)
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()

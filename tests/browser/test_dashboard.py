#!/usr/bin/python3
"""The dashboard in a real browser: Debian's Chromium, driven by python3-selenium through
chromium-driver, against a real stickslipd on an ephemeral loopback port.

    /usr/bin/python3 tests/browser/test_dashboard.py --build BUILD --out DIR [-v]

Run by CTest (tests/CMakeLists.txt). Every page's screenshot goes to DIR. What is checked:
  * the studies page lists a study submitted while it is open, and its progress bar reaches
    100 % without a reload;
  * the map chart has one series per model and one point per v_a value, read from uPlot's own
    data (u.series, u.data), and the heat map one discrete cell per (model, v_a);
  * an invalid spec shows the schema's and the server's errors next to the offending field; a
    valid one, submitted with a double click, makes one study, which appears in the list;
  * a diagnosis page shows the measured / base / extended traces and the named cause;
  * a study named <script>alert(1)</script> renders as text, and no alert fires;
  * a Sobol study's indices are bars (S1, ST) with their intervals, equal to the API's;
  * with a server that has a token, a submit is refused until the token is given in the dialog,
    and the token appears nowhere in the page;
  * a nightly report is embedded; the server page shows health and the metrics;
  * the page never logs an error (a Content-Security-Policy violation would be one).
Uses only the standard library besides selenium (run it with /usr/bin/python3: a python3 on PATH
may be another interpreter without python3-selenium).
"""
import argparse
import base64
import json
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
import unittest
import urllib.error
import urllib.request

from selenium import webdriver
from selenium.common.exceptions import NoAlertPresentException, TimeoutException
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

ARGS = None
MODELS = ["dahl", "karnopp", "reset_integrator", "lugre"]
VA = [0, 0.5, 1, 2, 4, 6]
XSS = "<script>alert(1)</script><img src=x onerror=alert(2)>"


def http(method, url, body=None, headers=None):
    req = urllib.request.Request(url, data=body, method=method, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=30) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read()


def post_study(url, spec, key=None):
    headers = {"Content-Type": "application/json"}
    if key:
        headers["Idempotency-Key"] = key
    status, _, body = http("POST", url + "/v1/studies", json.dumps(spec).encode(), headers)
    assert status == 202, (status, body[:300])
    return json.loads(body)


def map_spec(name, duration):
    """4 models x 6 values of v_a/v_d; fixed-step RK4 with `duration` seconds per stage."""
    return {
        "name": name,
        "stages": [{"duration": duration}, {"duration": duration, "v_a": 0, "f": 1500}],
        "integrator": {"kind": "rk4", "dt": 1e-5},
        "design": {"type": "grid", "axes": [{"name": "model", "values": MODELS}, {"name": "va_over_vd", "values": VA}]},
    }


class Dashboard(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = ARGS.out
        shutil.rmtree(cls.out, ignore_errors=True)
        os.makedirs(cls.out)
        cls.work = tempfile.mkdtemp(prefix="stickslip-browser-")
        # A nightly report directory with one report (a page like `stickslip report` writes:
        # inline style, no script), served by --reports.
        rep = os.path.join(cls.work, "reports", "2026-11-24")
        os.makedirs(rep)
        with open(os.path.join(rep, "index.html"), "w") as f:
            f.write("<!doctype html><html><head><title>nightly</title><style>h1{color:#246}</style></head>"
                    "<body><h1>Nightly report 2026-11-24</h1><p id='fine'>Every map cell within tolerance.</p></body></html>")
        with open(os.path.join(rep, "summary.json"), "w") as f:
            f.write('{"date": "2026-11-24"}')
        port_file = os.path.join(cls.work, "port")
        cls.daemon_log = open(os.path.join(cls.out, "stickslipd.log"), "w")
        # One OpenMP thread per study, so a study of a few seconds shows its progress moving.
        cls.daemon = subprocess.Popen(
            [os.path.join(ARGS.build, "server", "stickslipd"), "--db", os.path.join(cls.work, "dash.db"), "--port", "0",
             "--port-file", port_file, "--threads", "1", "--diagnosis-threads", "2", "--diagnosis-grace", "0",
             "--reports", os.path.join(cls.work, "reports"), "--log-level", "warn"],
            stdout=cls.daemon_log, stderr=subprocess.STDOUT)
        def read_port():
            try:
                with open(port_file) as f:
                    return f.read().strip()
            except FileNotFoundError:
                return ""
        for _ in range(400):
            if read_port():
                break
            if cls.daemon.poll() is not None:
                raise RuntimeError("stickslipd exited: see " + cls.daemon_log.name)
            time.sleep(0.025)
        cls.url = "http://127.0.0.1:" + read_port()

        opts = webdriver.ChromeOptions()
        opts.binary_location = "/usr/bin/chromium"
        for a in ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--disable-dev-shm-usage", "--window-size=1400,1000", "--hide-scrollbars",
                  "--user-data-dir=" + os.path.join(cls.work, "chromium-profile")]:
            opts.add_argument(a)
        opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
        cls.driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=opts)
        cls.driver.set_page_load_timeout(30)
        # Counts alert() calls in every document (injected through the DevTools protocol, so it
        # runs before the page's own scripts; the page's CSP does not apply to it).
        cls.driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {
            "source": "window.__alerts = 0; window.alert = function () { window.__alerts++; };"})

    @classmethod
    def tearDownClass(cls):
        try:
            cls.driver.quit()
        finally:
            cls.daemon.send_signal(signal.SIGTERM)
            try:
                cls.daemon.wait(timeout=30)
            except subprocess.TimeoutExpired:
                cls.daemon.kill()
            cls.daemon_log.close()
            shutil.rmtree(cls.work, ignore_errors=True)

    # --- helpers ---------------------------------------------------------------------------

    def go(self, hash_path):
        """Navigates to #hash_path within the loaded dashboard (a full load the first time)."""
        if not self.driver.current_url.startswith(self.url):
            self.driver.get(self.url + "/")
        self.driver.execute_script("location.hash = arguments[0]", hash_path)

    def wait(self, fn, timeout=30, what="condition"):
        try:
            return WebDriverWait(self.driver, timeout, poll_frequency=0.1).until(lambda d: fn())
        except TimeoutException:
            self.shot("timeout-" + what.replace(" ", "_"))
            raise AssertionError("timed out waiting for " + what)

    def js(self, script, *args):
        return self.driver.execute_script(script, *args)

    def shot(self, name):
        self.driver.save_screenshot(os.path.join(self.out, name + ".png"))

    def full_shot(self, name):
        """A screenshot of the whole page, beyond the window (DevTools Page.captureScreenshot)."""
        size = self.driver.execute_cdp_cmd("Page.getLayoutMetrics", {})["cssContentSize"]
        shot = self.driver.execute_cdp_cmd("Page.captureScreenshot", {
            "format": "png", "captureBeyondViewport": True,
            "clip": {"x": 0, "y": 0, "width": size["width"], "height": min(size["height"], 6000), "scale": 1}})
        with open(os.path.join(self.out, name + ".png"), "wb") as f:
            f.write(base64.b64decode(shot["data"]))

    def assert_clean_console(self, allow=()):
        """No error in the browser's console (a CSP violation or a script error is one), except
        the failed requests in allow (e.g. the 422 of a submit that is meant to fail)."""
        errors = [e for e in self.driver.get_log("browser")
                  if e["level"] == "SEVERE" and not any(a in e["message"] for a in allow)]
        self.assertEqual(errors, [], "the page logged errors")

    def submit_and_wait(self, spec, timeout=120):
        s = post_study(self.url, spec)
        end = time.time() + timeout
        while time.time() < end:
            _, _, body = http("GET", self.url + "/v1/studies/" + s["id"])
            s = json.loads(body)
            if s["state"] not in ("queued", "running"):
                return s
            time.sleep(0.2)
        self.fail("study %s did not finish" % s["id"])

    # --- tests -----------------------------------------------------------------------------

    def test_1_studies_page_shows_live_progress_without_reload(self):
        self.go("/studies")
        self.wait(lambda: self.js("return document.body.dataset.page") == "studies", what="studies page")
        self.js("window.__loaded = 'once'")  # gone if the page reloads
        # Submitted while the page is open: 4 models x 60 drive stiffnesses, 2 x 2 s stages with
        # the adaptive integrator, on one thread: a few seconds.
        s = post_study(self.url, {
            "name": "live-progress",
            "stages": [{"duration": 2}, {"duration": 2, "f": 1500}],
            "design": {"type": "grid", "axes": [{"name": "k_d", "linspace": [11600, 11800, 60]},
                                                {"name": "va_over_vd", "values": [1]},
                                                {"name": "model", "values": MODELS}]}})
        total = 240
        row = '#studies-table tr[data-id="%s"]' % s["id"]
        seen = []
        end = time.time() + 120
        while time.time() < end:
            v = self.js("""const r = document.querySelector(arguments[0]);
                if (!r) return null;
                const p = r.querySelector('progress');
                return {state: r.dataset.state, value: p.value, max: p.max,
                        label: r.querySelector('.progress-label').textContent};""", row)
            if v:
                seen.append(v)
                if v["state"] == "succeeded" and v["value"] == v["max"]:
                    break
            time.sleep(0.1)
        self.assertTrue(seen, "the submitted study never appeared in the list")
        last = seen[-1]
        self.assertEqual(last["state"], "succeeded")
        self.assertEqual(last["max"], total)
        self.assertEqual(last["value"], total)
        self.assertTrue(last["label"].startswith("100 %"), last["label"])
        # It was seen before it finished, and the page was never reloaded.
        self.assertIn(seen[0]["state"], ("queued", "running"), seen[0])
        self.assertLess(seen[0]["value"], total)
        self.assertGreater(len({v["value"] for v in seen}), 2, "the bar did not move in steps")
        self.assertEqual(self.js("return window.__loaded"), "once")
        self.shot("studies")
        self.assert_clean_console()

    def test_2_map_chart_has_one_series_per_model_and_one_point_per_va(self):
        # 3 s stages: long enough for several stick-slip cycles before the vibration starts.
        sid = self.submit_and_wait(map_spec("paper-map-short", 3.0))["id"]
        self.go("/studies/" + sid)
        self.wait(lambda: self.js("return document.body.dataset.ready") == "study", what="study page")
        chart = self.js("""const u = window.stickslip.charts['map-amplitude'];
            return {labels: u.series.slice(1).map(s => s.label), x: Array.from(u.data[0]),
                    lengths: u.data.slice(1).map(d => d.length),
                    finite: u.data.slice(1).every(d => d.every(v => Number.isFinite(v)))};""")
        self.assertEqual(chart["labels"], MODELS)
        self.assertEqual(chart["x"], VA)
        self.assertEqual(chart["lengths"], [len(VA)] * len(MODELS))
        self.assertTrue(chart["finite"])
        # The same numbers as the API's map, for one cell.
        _, _, body = http("GET", self.url + "/v1/studies/%s/map" % sid)
        m = json.loads(body)
        row = [r for r in m["rows"] if r["key"]["va_over_vd"] == 2][0]
        got = self.js("return window.stickslip.charts['map-amplitude'].data[4][3]")  # lugre, v_a/v_d = 2
        self.assertAlmostEqual(got, row["cells"]["lugre"]["amplitude"][1], places=12)
        # A two-axis design: a heat map with the model as a categorical axis, one cell each.
        cells = self.js("""const c = window.stickslip.charts['heatmap'].stickslipCells;
            return {y: c.y.categories, x: c.x.values, rows: c.z.length, cols: c.z.map(r => r.length)};""")
        self.assertEqual(cells["y"], MODELS)
        self.assertEqual(cells["x"], VA)
        self.assertEqual(cells["cols"], [len(VA)] * len(MODELS))
        # Runs table (24 rows) and its CSV download (a header and 24 lines).
        self.assertEqual(self.js("return document.querySelectorAll('#runs-table tbody tr').length"), 24)
        href = self.js("return document.getElementById('runs-csv').href")
        status, _, csv = http("GET", href)
        self.assertEqual(status, 200)
        self.assertEqual(len(csv.decode().strip().split("\n")), 25)
        # Hover: the legend shows every model's value at the cursor.
        over = self.driver.find_element(By.CSS_SELECTOR, "#map-amplitude .u-over")
        ActionChains(self.driver).move_to_element(over).perform()
        values = self.js("""return Array.from(document.querySelectorAll('#map-amplitude .u-legend .u-value'))
                             .map(e => e.textContent);""")
        self.assertEqual(len(values), 1 + len(MODELS))
        self.assertTrue(all(v not in ("", "--") for v in values), values)
        self.full_shot("study")
        self.assert_clean_console()

    def test_3_submit_shows_field_errors_and_a_double_click_makes_one_study(self):
        self.go("/submit")
        self.wait(lambda: self.js("return document.body.dataset.page") == "submit", what="submit page")
        bad = map_spec("bad-mass", 0.5)
        bad["base"] = {"m": -1}
        self.js("const t = document.getElementById('spec-text'); t.value = arguments[0];"
                "t.dispatchEvent(new Event('input'));", json.dumps(bad, indent=2))
        field = '#spec-fields .field[data-pointer="/base/m"]'
        self.wait(lambda: self.js("return !!document.querySelector(arguments[0] + ' > .field-error[data-source=schema]')", field),
                  what="schema error at /base/m")
        self.driver.find_element(By.ID, "submit-study").click()
        self.wait(lambda: self.js("return !!document.querySelector(arguments[0] + ' > .field-error[data-source=server]')", field),
                  what="server error at /base/m")
        msg = self.js("return document.querySelector(arguments[0] + ' > .field-error[data-source=server]').textContent", field)
        self.assertIn("-1", msg)
        self.assertIn("422", self.driver.find_element(By.ID, "server-problem").text)
        self.full_shot("submit-errors")

        name = "submitted-%d" % int(time.time() * 1000)
        good = map_spec(name, 0.2)
        self.js("const t = document.getElementById('spec-text'); t.value = arguments[0];"
                "t.dispatchEvent(new Event('input'));", json.dumps(good, indent=2))
        self.wait(lambda: self.js("return !document.querySelector('.field-error')"), what="no errors")
        button = self.driver.find_element(By.ID, "submit-study")
        ActionChains(self.driver).double_click(button).perform()
        self.wait(lambda: self.js("return !!document.getElementById('submitted')"), what="submitted")
        # The same text again is the same Idempotency-Key: the server replays, no second study.
        self.wait(lambda: not self.js("return document.getElementById('submit-study').disabled"), what="button enabled")
        button.click()
        self.wait(lambda: "Already submitted" in self.driver.find_element(By.ID, "submitted").text, what="replay")
        _, _, body = http("GET", self.url + "/v1/studies?name=" + name)
        studies = json.loads(body)["studies"]
        self.assertEqual(len(studies), 1, studies)
        self.go("/studies?name=" + name)
        self.wait(lambda: self.js("return document.querySelectorAll('#studies-table tbody tr').length") == 1,
                  what="the submitted study in the list")
        self.assertEqual(self.driver.find_element(By.CSS_SELECTOR, "#studies-table a.study-name").text, name)
        self.assert_clean_console(allow=["/v1/studies - Failed to load resource: the server responded with a status of 422"])

    def test_4_diagnosis_page_shows_traces_and_the_named_cause(self):
        data = os.path.join(self.work, "data")
        client = os.path.join(ARGS.build, "client", "stickslip")
        synth = subprocess.run([client, "synth", "--model", "lugre", "--effect", "viscous", "--effect-param", "sigma2=60",
                                "--duration", "6", "--t-on", "3", "--va", "0", "4e-3", "--rate", "500", "--seed", "3",
                                "--name", "lugre-viscous-2-runs", "--out", data], capture_output=True, text=True, timeout=120)
        self.assertEqual(synth.returncode, 0, synth.stderr)
        manifest = synth.stdout.strip()
        sub = subprocess.run([client, "diagnose", manifest, "--server", self.url, "--models", "lugre", "--candidates", "viscous",
                              "--max-evals-base", "12", "--max-evals-candidate", "10", "--max-evals-fold", "10"],
                             capture_output=True, text=True, timeout=120)
        self.assertEqual(sub.returncode, 0, sub.stderr)
        did = sub.stdout.strip().split("\n")[0]
        self.go("/diagnoses/" + did)
        # The page polls while the diagnosis runs and lays out the result when it succeeds.
        self.wait(lambda: self.js("return !!document.getElementById('cause-name')"), timeout=300, what="diagnosis result")
        _, _, body = http("GET", self.url + "/v1/diagnoses/" + did)
        d = json.loads(body)
        self.assertEqual(d["state"], "succeeded")
        self.assertEqual(self.driver.find_element(By.ID, "cause-name").text, d["result"]["cause"])
        self.assertEqual(self.driver.find_element(By.ID, "diagnosis-name").text, "lugre-viscous-2-runs")
        self.wait(lambda: self.js("return !!(window.stickslip.charts['trace-0'] && window.stickslip.charts['trace-1'])"),
                  what="trace charts")
        _, _, body = http("GET", self.url + "/v1/diagnoses/%s/traces" % did)
        runs = json.loads(body)["runs"]
        self.assertEqual(len(runs), 2)
        for run in runs:
            t = self.js("""const u = window.stickslip.charts['trace-' + arguments[0]];
                const r = window.stickslip.charts['residual-' + arguments[0]];
                return {labels: u.series.slice(1).map(s => s.label), n: u.data[0].length,
                        lens: u.data.slice(1).map(d => d.length), residual: r.data.length - 1};""", run["index"])
            self.assertEqual(t["labels"][0], "measured")
            self.assertEqual(t["labels"][1], "lugre (base)")
            self.assertEqual(len(t["labels"]), 3 if run["extended"] else 2)
            self.assertEqual(t["n"], run["samples"])  # 1500 samples at 250 Hz: not decimated
            self.assertEqual(t["lens"], [run["samples"]] * len(t["labels"]))
            self.assertEqual(t["residual"], len(t["labels"]) - 1)
        # The cause's evidence panel is the marked one (the server names it: cause_view).
        marked = self.js("return Array.from(document.querySelectorAll('#evidence [data-marked=true]')).map(e => e.dataset.view)")
        self.assertEqual(marked, [d["cause_view"]] if d["cause_view"] else [])
        # The candidates table: a row per candidate, with the naming rule's effect size (gain over the noise).
        heads = self.js("return Array.from(document.querySelectorAll('#candidates th')).map(e => e.textContent)")
        self.assertIn("gain over noise", heads)
        self.assertEqual(self.js("return document.querySelectorAll('#candidates tbody tr').length"), len(d["result"]["candidates"]))
        # The calibration table has a row per model with an RMSE per run.
        self.assertEqual(self.js("return document.querySelectorAll('#calibration table')[0].querySelectorAll('tbody tr').length"), 1)
        self.full_shot("diagnosis")
        self.go("/diagnoses")
        self.wait(lambda: self.js("return document.querySelectorAll('#diagnoses-table tbody tr').length") >= 1, what="diagnoses list")
        self.assertIn("lugre-viscous-2-runs", self.driver.find_element(By.ID, "diagnoses-table").text)
        self.shot("diagnoses")
        self.assert_clean_console()

    def test_5_a_study_named_script_renders_as_text(self):
        # The API refuses such a name (the spec's name pattern), so it is written into the store
        # directly, as an older build or another tool could have: the pages must not rely on
        # the input check. Its spec is that of a real study.
        real = self.submit_and_wait(map_spec("xss-spec", 0.2))
        db = sqlite3.connect(os.path.join(self.work, "dash.db"), timeout=10)
        spec_json, spec_hash, total = db.execute(
            "SELECT spec_json, spec_hash, total_runs FROM studies WHERE id = ?", (real["id"],)).fetchone()
        sid = "st-xss-0001"
        db.execute("INSERT INTO studies (id, name, spec_json, spec_hash, state, total_runs, created_at, error) "
                   "VALUES (?, ?, ?, ?, 'failed', ?, '2026-11-25T00:00:00.000Z', ?)",
                   (sid, XSS, spec_json, spec_hash, total, XSS))
        db.commit()
        db.close()
        self.go("/studies?name=script")
        self.wait(lambda: self.js("return !!document.querySelector('#studies-table tr[data-id=\"%s\"]')" % sid), what="xss row")
        link = self.driver.find_element(By.CSS_SELECTOR, '#studies-table tr[data-id="%s"] a.study-name' % sid)
        self.assertEqual(link.text, XSS)
        self.assertEqual(self.js("return document.querySelectorAll('main script, main img').length"), 0)
        self.go("/studies/" + sid)
        self.wait(lambda: self.js("return document.body.dataset.ready") == "study", what="xss study page")
        self.assertEqual(self.driver.find_element(By.ID, "study-name").text, XSS)
        self.assertIn(XSS, self.driver.find_element(By.CSS_SELECTOR, "#study-spec").text + self.driver.find_element(By.TAG_NAME, "main").text)
        self.assertEqual(self.js("return document.querySelectorAll('main script, main img').length"), 0)
        self.shot("xss")
        # A diagnosis: the dataset's and runs' names are free text in the API; this one is stored
        # directly too, with a result that also has a key the page does not know (shown under
        # "Further results", keys and values as text).
        did = "dg-xss-0001"
        result = {"dataset": XSS, "cause": "none", "base_model": "lugre", "best_candidate": "",
                  "calibrations": [{"model": "lugre", "status": XSS, "rmse_run": {XSS: 0.25}}],
                  "candidates": [], "evidence": {}, "heldout_runs": None,
                  "validation": [{"record": XSS, "verdict": XSS, "rmse": 0.5}]}
        db = sqlite3.connect(os.path.join(self.work, "dash.db"), timeout=10)
        db.execute("INSERT INTO diagnoses (id, name, request_json, request_hash, state, created_at, result_json) "
                   "VALUES (?, ?, '{}', 'x', 'succeeded', '2026-11-25T00:00:00.000Z', ?)", (did, XSS, json.dumps(result)))
        db.commit()
        db.close()
        self.go("/diagnoses/" + did)
        self.wait(lambda: self.js("return document.body.dataset.ready") == "diagnosis", what="xss diagnosis page")
        self.assertEqual(self.driver.find_element(By.ID, "diagnosis-name").text, XSS)
        further = self.driver.find_element(By.ID, "further").text
        self.assertIn("validation", further)
        self.assertIn(XSS, further)
        self.assertIn(XSS, self.driver.find_element(By.ID, "calibration").text)
        self.assertEqual(self.js("return document.querySelectorAll('main script, main img').length"), 0)
        # Submitting that name: the schema's and the server's errors quote it, as text.
        self.go("/submit")
        self.wait(lambda: self.js("return document.body.dataset.page") == "submit", what="submit page")
        self.js("const t = document.getElementById('spec-text'); t.value = arguments[0];"
                "t.dispatchEvent(new Event('input'));", json.dumps(map_spec(XSS, 0.2)))
        self.driver.find_element(By.ID, "submit-study").click()
        sel = '#spec-fields .field[data-pointer="/name"] > .field-error[data-source=server]'
        self.wait(lambda: self.js("return !!document.querySelector(arguments[0])", sel), what="server error at /name")
        self.assertIn(XSS, self.js("return document.querySelector(arguments[0]).textContent", sel))
        self.assertEqual(self.js("return document.querySelectorAll('main script, main img').length"), 0)
        self.assertEqual(self.js("return window.__alerts"), 0)
        with self.assertRaises(NoAlertPresentException):
            self.driver.switch_to.alert.text
        self.assert_clean_console(allow=["/v1/studies - Failed to load resource: the server responded with a status of 422"])

    def test_6_reports_and_server_pages(self):
        self.go("/reports")
        self.wait(lambda: self.js("return document.body.dataset.page") == "reports", what="reports page")
        frame = self.driver.find_element(By.ID, "report-frame")
        self.driver.switch_to.frame(frame)
        self.wait(lambda: self.driver.find_elements(By.ID, "fine"), what="report in the frame")
        self.assertIn("within tolerance", self.driver.find_element(By.ID, "fine").text)
        self.driver.switch_to.default_content()
        self.shot("reports")
        self.go("/server")
        self.wait(lambda: self.js("return document.body.dataset.page") == "server", what="server page")
        self.wait(lambda: "ok" in self.js("const e = document.getElementById('health'); return e ? e.innerText : ''"),
                  what="health ok")
        # The page re-renders its tiles on every poll, so a WebElement found here can go stale
        # before it is read: read the text in one script call instead.
        self.wait(lambda: (self.js("const e = document.getElementById('m-rate'); return e ? e.innerText : '…'")
                           .split("\n")[0] != "…"), what="runs/s")
        runs = int(self.js("return document.querySelector('#m-runs .value').innerText"))
        _, _, metrics = http("GET", self.url + "/metrics")
        total = sum(int(l.split()[-1]) for l in metrics.decode().split("\n") if l.startswith("stickslip_runs_total{"))
        self.assertEqual(runs, total)
        self.shot("server")
        self.assert_clean_console()

    def test_8_sobol_indices_are_bars_with_their_intervals(self):
        # The analytic Ishigami function: no simulation, 5 x 256 runs in a moment.
        sid = self.submit_and_wait({"name": "ishigami-sobol", "base": {"model": "ishigami"},
                                    "design": {"type": "sobol", "n": 256, "seed": 3}})["id"]
        self.go("/studies/" + sid)
        self.wait(lambda: self.js("return document.body.dataset.ready") == "study", what="sobol study page")
        self.wait(lambda: self.js("return !!window.stickslip.charts['indices']"), what="indices chart")
        chart = self.js("""const u = window.stickslip.charts['indices'];
            return {labels: u.series.slice(1).map(s => s.label), x: Array.from(u.data[0]),
                    s1: Array.from(u.data[1]), st: Array.from(u.data[2])};""")
        self.assertEqual(chart["labels"], ["S1 (first order)", "ST (total)"])
        self.assertEqual(chart["x"], [0, 1, 2])
        _, _, body = http("GET", self.url + "/v1/studies/%s/indices" % sid)
        ind = json.loads(body)["outputs"][0]
        self.assertTrue(ind["valid"], ind)
        self.assertEqual(chart["s1"], [r["S1"] for r in ind["indices"]])
        self.assertEqual(chart["st"], [r["ST"] for r in ind["indices"]])
        # Each bar's interval is in the legend at the cursor: "value [lo, hi]".
        over = self.driver.find_element(By.CSS_SELECTOR, "#indices-chart .u-over")
        ActionChains(self.driver).move_to_element(over).perform()
        legend = self.js("return Array.from(document.querySelectorAll('#indices-chart .u-legend .u-value')).map(e => e.textContent)")
        self.assertRegex(legend[1], r"^\S+ \[\S+, \S+\]$")
        self.assertFalse(self.js("return !!window.stickslip.charts['map-amplitude']"))  # no map of a sampled design
        self.full_shot("indices")
        self.assert_clean_console()

    def test_9_writes_need_the_token_and_the_page_never_shows_it(self):
        secret = "s3cret-Token-%d" % os.getpid()
        port_file = os.path.join(self.work, "port-token")
        log = open(os.path.join(self.out, "stickslipd-token.log"), "w")
        daemon = subprocess.Popen(
            [os.path.join(ARGS.build, "server", "stickslipd"), "--db", os.path.join(self.work, "token.db"), "--port", "0",
             "--port-file", port_file, "--threads", "1", "--token", secret, "--log-level", "warn"],
            stdout=log, stderr=subprocess.STDOUT)
        try:
            for _ in range(400):
                if os.path.exists(port_file) and os.path.getsize(port_file) > 0:
                    break
                time.sleep(0.025)
            with open(port_file) as f:
                url = "http://127.0.0.1:" + f.read().strip()
            self.driver.get(url + "/#/submit")
            self.wait(lambda: self.js("return document.body.dataset.page") == "submit", what="submit page (token server)")
            self.js("const t = document.getElementById('spec-text'); t.value = arguments[0];"
                    "t.dispatchEvent(new Event('input'));", json.dumps(map_spec("with-token", 0.2)))
            self.driver.find_element(By.ID, "submit-study").click()
            # Refused without the token; the page asks for it.
            self.wait(lambda: "401" in self.driver.find_element(By.ID, "server-problem").text, what="401")
            self.wait(lambda: self.js("return document.getElementById('token-dialog').open"), what="token dialog")
            self.driver.find_element(By.ID, "token-input").send_keys(secret)
            self.driver.find_element(By.ID, "token-save").click()
            self.assertEqual(self.driver.find_element(By.ID, "token-state").text, "token set")
            self.driver.find_element(By.ID, "submit-study").click()
            self.wait(lambda: self.js("return !!document.getElementById('submitted')"), what="submitted with the token")
            _, _, body = http("GET", url + "/v1/studies?name=with-token")
            self.assertEqual(len(json.loads(body)["studies"]), 1)
            # Nowhere in the page: not in the DOM, not in a field's value.
            self.assertNotIn(secret, self.js("return document.documentElement.outerHTML"))
            self.assertNotIn(secret, self.js("return Array.from(document.querySelectorAll('input, textarea')).map(e => e.value).join(' ')"))
            self.assert_clean_console(allow=["/v1/studies - Failed to load resource: the server responded with a status of 401"])
        finally:
            daemon.send_signal(signal.SIGTERM)
            try:
                daemon.wait(timeout=30)
            except subprocess.TimeoutExpired:
                daemon.kill()
            log.close()
            self.driver.get(self.url + "/")

    def test_7_every_response_carries_the_policy(self):
        status, headers, _ = http("GET", self.url + "/")
        self.assertEqual(status, 200)
        csp = headers["Content-Security-Policy"]
        self.assertIn("script-src 'self'", csp)
        self.assertNotIn("unsafe-inline", csp.split("style-src")[0])
        _, headers, _ = http("GET", self.url + "/v1/studies")
        self.assertEqual(headers["Content-Security-Policy"], csp)
        _, headers, _ = http("GET", self.url + "/v1/reports/2026-11-24/index.html")
        self.assertIn("sandbox", headers["Content-Security-Policy"])
        self.assertIn("default-src 'none'", headers["Content-Security-Policy"])


def main():
    global ARGS
    p = argparse.ArgumentParser()
    p.add_argument("--build", required=True)
    p.add_argument("--out", required=True)
    ARGS, rest = p.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""The web page of dfsmd (issue 17) in a real browser.

Headless Chromium (Debian's chromium + chromium-driver, driven by Debian's
python3-selenium; nothing is downloaded at test time) against a real dfsmd on
a replay source:

  1. loads the page (served by dfsmd at /, its files at /ui/...) and waits for
     the live view (a frame shown, camera state "streaming") and the live job
     stream (the event stream, not the polling fallback);
  2. triggers a capture from the form; the job must appear in the list at once;
  3. waits until the job shows "succeeded" (progress bar full);
  4. opens the result: the reference, the colour-mapped depth and the
     confidence canvases must hold non-blank pixels, the depth legend its
     ticks, hovering the depth must read a depth value, the 3-D canvas (WebGL,
     three.js) must show points (pixels other than its clear colour) and a drag
     must rotate it (its pixels change); the download list must hold every file
     of the job's links.files (and the burst), as relative links;
     the page's first load with the 3-D viewer must be <= 300 KB as
     transferred (resource timings; dfsmd compresses);
  5. the calibration panel shows the current and the fused calibration;
  6. uploads a burst tar twice: dropped on the page (a synthetic drop event
     carrying a real File: the drop zone must appear on dragenter and go on
     drop) and through the file input; both jobs must succeed and open;
  7. a 503 shows its message: the page asks for the *next* 64 frames, and
     the replay restarts its 10 frames with a sequence gap each time, so 64
     consecutive frames never come: dfsmd answers 503 "timed out after 1500 ms
     waiting for 64 consecutive frames", deterministically, and the page must
     show that detail with the status;
  8. the page reconnects its event stream (dfsmd ends each after
     server.event_stream_s, 4 s here) and stays live;
  9. no CSP violation or uncaught script error in the browser's console
     (also checked after 10 and 11);
 10. under a path prefix (a reverse proxy in the test serving dfsmd at /dfsm/):
     live view, events, a trigger and its result work, and every request the
     page makes stays under the prefix; the proxy removes 'unsafe-inline' from
     the CSP, and the page must run without a violation;
 11. with a token (a second dfsmd with server.token_file) and every event
     stream taken (4 held by the test): the page asks for the token once, then
     shows the live view with it, falls back to polling (the 5th stream gets
     503) and still follows a job to "succeeded"; the token is kept in
     sessionStorage and appears in no requested URL;
 12. on a phone (390x844, touch; a third dfsmd replaying a generated 1080p
     burst): see phone_tests.

Screenshots go to --out (page.png: the whole page with the result open;
result.png: the result panel; error.png: the 503 message; token.png: the
token prompt; phone.png: the phone's screen; failure.png on a failure), with console.log (the browser's
console) and dfsmd-PORT.log (each dfsmd's output).

Exit status: 0 passed, 1 failed (with the reason), 77 skipped (no Chromium,
chromedriver or Selenium on this machine: the message says which).

  tests/browser/page_test.py --dfsmd build/dfsmd/dfsmd --dfsm build/tools/dfsm/dfsm --out /tmp/page-test
  tests/browser/page_test.py --dfsmd build/dfsmd/dfsmd --burst out/demo/burst --out /tmp/page-test
"""
import argparse
import base64
import http.client
import http.server
import socketserver
import json
import os
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import threading
import time
import urllib.request

SKIP = 77
TOKEN = 'browser-test-token-0123456789abcdef'


class Failure(Exception):
    pass


def log(text):
    print(f'page_test: {text}', flush=True)


def find_browser():
    missing = []
    chromium = shutil.which('chromium') or shutil.which('chromium-browser')
    driver = shutil.which('chromedriver') or (
        '/usr/bin/chromedriver' if os.path.exists('/usr/bin/chromedriver') else None)
    if not chromium:
        missing.append('chromium (apt-get install chromium)')
    if not driver:
        missing.append('chromedriver (apt-get install chromium-driver)')
    try:
        import selenium  # noqa: F401
    except ImportError:
        missing.append(f'selenium for {sys.executable} (apt-get install python3-selenium; run with /usr/bin/python3)')
    if missing:
        print('SKIP: the browser test needs ' + ', '.join(missing), flush=True)
        sys.exit(SKIP)
    return chromium, driver


class Dfsmd:
    """A dfsmd on a free loopback port (server.port 0; the port from its log line)."""

    # A trigger for the "last" 10 frames of a 10-frame replay waits for the
    # loop to complete (up to 9 frames, 300 ms at 30 fps): 1.5 s leaves room
    # for a busy machine.
    def __init__(self, binary, burst, state_dir, extra=('--server.event_stream_s', '4'), burst_timeout_ms=1500):
        self.lines = []
        args = [binary, '--capture.source', f'replay:{burst}', '--jobs.state_dir', state_dir,
                '--server.port', '0', '--pipeline.burst_timeout_ms', str(burst_timeout_ms), *extra]
        log('starting ' + ' '.join(args))
        self.process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.port = None
        ready = threading.Event()

        def read():
            for line in self.process.stdout:
                self.lines.append(line.rstrip('\n'))
                m = re.search(r'listening on http://127\.0\.0\.1:(\d+)', line)
                if m and not self.port:
                    self.port = int(m.group(1))
                    ready.set()
            ready.set()

        threading.Thread(target=read, daemon=True).start()
        if not ready.wait(30) or not self.port:
            self.stop()
            raise Failure('dfsmd did not print its port within 30 s:\n' + '\n'.join(self.lines[-20:]))
        self.base = f'http://127.0.0.1:{self.port}'

    def stop(self):
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()

    def get_json(self, path, token=None):
        request = urllib.request.Request(self.base + path)
        if token:
            request.add_header('Authorization', f'Bearer {token}')
        with urllib.request.urlopen(request, timeout=10) as response:
            return json.load(response)


def wait(what, predicate, timeout, interval=0.2):
    end = time.monotonic() + timeout
    last = None
    while time.monotonic() < end:
        try:
            value = predicate()
            if value:
                return value
        except Exception as e:  # noqa: BLE001 (the page may be between states)
            last = e
        time.sleep(interval)
    raise Failure(f'timed out after {timeout} s waiting for {what}' + (f' (last error: {last})' if last else ''))


# Pixel statistics of a canvas, read back in the page (2-D and WebGL canvases:
# the viewer renders with preserveDrawingBuffer).
CANVAS_STATS = """
const c = document.getElementById(arguments[0]);
const bg = arguments[1];
const w = c.width, h = c.height;
const copy = document.createElement('canvas');
copy.width = w; copy.height = h;
const ctx = copy.getContext('2d');
ctx.drawImage(c, 0, 0);
const d = ctx.getImageData(0, 0, w, h).data;
let differing = 0, nonblack = 0, hash = 0;
const colours = new Set();
for (let i = 0; i < d.length; i += 4) {
  const r = d[i], g = d[i + 1], b = d[i + 2];
  if (r + g + b > 30) nonblack++;
  if (bg && (Math.abs(r - bg[0]) + Math.abs(g - bg[1]) + Math.abs(b - bg[2]) > 24)) differing++;
  if (colours.size < 5000) colours.add((r << 16) | (g << 8) | b);
  hash = (hash * 31 + r + 7 * g + 13 * b) >>> 0;
}
return {w, h, pixels: w * h, nonblack, differing, colours: colours.size, hash};
"""


def start_browser(chromium, driver_path, out):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for arg in ['--headless=new', '--no-sandbox', '--disable-dev-shm-usage', '--window-size=1400,2600',
                '--hide-scrollbars', '--force-device-scale-factor=1',
                # WebGL without a GPU: ANGLE on SwiftShader.
                '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
                f'--user-data-dir={os.path.join(out, "chromium-profile")}']:
        options.add_argument(arg)
    options.set_capability('goog:loggingPrefs', {'browser': 'ALL'})
    service = Service(executable_path=driver_path, log_path=os.path.join(out, 'chromedriver.log'))
    return webdriver.Chrome(service=service, options=options)


def console_problems(driver, seen):
    problems = []
    for entry in driver.get_log('browser'):
        seen.append(entry)
        text = entry.get('message', '')
        if entry.get('level') != 'SEVERE':
            continue
        # Refused requests (the 503 on purpose, a 401 before the token) are logged
        # by Chromium as "Failed to load resource"; those are expected.
        if 'Failed to load resource' in text:
            continue
        problems.append(text)
    return problems


def page_tests(driver, dfsmd, out, burst, work):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    js = driver.execute_script
    find = lambda css: driver.find_element(By.CSS_SELECTOR, css)  # noqa: E731

    # 1. The page and its live parts.
    driver.get(dfsmd.base + '/')
    if 'dfsmd' not in driver.title:
        raise Failure(f'page title is {driver.title!r}; is www/ compiled into this dfsmd?')
    bg = js("return getComputedStyle(document.body).backgroundColor")
    if bg in ('rgba(0, 0, 0, 0)', 'rgb(255, 255, 255)'):
        raise Failure(f'ui/style.css not applied (body background {bg})')
    wait('a live frame', lambda: js("const i = document.getElementById('live-image');"
                                    "return i.complete && i.naturalWidth > 0"), 30)
    wait('camera state "streaming"', lambda: find('#cam-state').text == 'streaming', 15)
    wait('the event stream (connection "live")', lambda: find('#connection').text == 'live', 15)
    live_width = js("return document.getElementById('live-image').naturalWidth")
    log(f'page loaded: live view {live_width} px wide, events live')

    # 2. Trigger.
    frames = find('#trigger-frames')
    frames.clear()
    frames.send_keys('10')
    js("document.getElementById('trigger-when').value = 'last'")
    planes = find('#trigger-planes')
    planes.clear()
    planes.send_keys('64')
    find('#trigger-button').click()
    clicked = time.monotonic()
    job_id = wait('the new job in the list', lambda: js(
        "const li = document.querySelector('#job-list li.job'); return li && li.dataset.jobId"), 5, 0.05)
    log(f'job {job_id} listed {time.monotonic() - clicked:.2f} s after the click')

    # 3. Succeeded.
    item = f'#job-list li[data-job-id="{job_id}"]'
    wait(f'job {job_id} to show succeeded', lambda: find(f'{item} .status').text.lower() == 'succeeded', 180, 0.25)
    progress = js(f"return document.querySelector('{item} progress').value")
    if progress != 1:
        raise Failure(f'progress bar of the succeeded job is {progress}, not 1')
    log(f'job {job_id} succeeded after {time.monotonic() - clicked:.1f} s')

    # 4. The result. The list is re-rendered whenever an event arrives, so the
    # item found may be replaced before the click lands (a stale element):
    # find it again and retry until one click reaches a live element.
    wait(f'a click on job {job_id} in the list', lambda: find(item).click() or True, 10, 0.1)
    wait('the result panel to finish loading', lambda: find('#result-panel').get_attribute('data-ready') == 'true', 60)
    if find('#result-id').text != job_id:
        raise Failure(f'result panel shows {find("#result-id").text!r}, not {job_id}')
    job = dfsmd.get_json(f'/api/v1/jobs/{job_id}')
    width, height = job['input']['width'], job['input']['height']
    for canvas, minimum_colours in (('reference-canvas', 50), ('depth-canvas', 20), ('confidence-canvas', 5)):
        s = js(CANVAS_STATS, canvas, None)
        if (s['w'], s['h']) != (width, height):
            raise Failure(f'{canvas} is {s["w"]}x{s["h"]}, not the burst\'s {width}x{height}')
        if s['nonblack'] < 0.3 * s['pixels'] or s['colours'] < minimum_colours:
            raise Failure(f'{canvas} looks blank: {s}')
        log(f'{canvas}: {s["nonblack"]}/{s["pixels"]} non-black pixels, {s["colours"]} colours')
    ticks = [t.text for t in driver.find_elements(By.CSS_SELECTOR, '#legend-ticks span')]
    if len(ticks) != 5 or not all(re.fullmatch(r'[0-9.]+', t) for t in ticks):
        raise Failure(f'depth legend ticks {ticks}')
    log(f'depth legend: {ticks}')

    # The page's first load, the 3-D viewer included (three.js is imported when a
    # result opens): issue 17 wants <= 300 KB as transferred (dfsmd compresses).
    sizes = js("""
      const nav = performance.getEntriesByType('navigation')[0];
      const ui = performance.getEntriesByType('resource').filter(e => new URL(e.name).pathname.includes('/ui/'));
      return {total: nav.transferSize + ui.reduce((a, e) => a + e.transferSize, 0),
              decoded: nav.decodedBodySize + ui.reduce((a, e) => a + e.decodedBodySize, 0),
              files: ui.length + 1};""")
    if sizes['files'] < 7 or sizes['total'] <= 0:
        raise Failure(f'the page\'s files are not all in the resource timings: {sizes}')
    if sizes['total'] > 300 * 1024:
        raise Failure(f'the page\'s first load transferred {sizes["total"]} bytes, over 300 KB: {sizes}')
    log(f'first load with the 3-D viewer: {sizes["files"]} files, {sizes["total"] / 1024:.0f} KiB transferred '
        f'({sizes["decoded"] / 1024:.0f} KiB decoded)')

    depth_canvas = find('#depth-canvas')
    ActionChains(driver).move_to_element(depth_canvas).perform()
    readout = wait('the hover readout', lambda: (lambda t: t if re.search(r'depth [0-9.]+|no depth estimate', t)
                                                  else None)(find('#hover-readout').text), 5)
    log(f'hover: {readout}')

    wait('the 3-D canvas to render', lambda: int(find('#points-canvas').get_attribute('data-rendered') or 0) > 0, 60)
    time.sleep(0.3)
    background = [0x11, 0x15, 0x1c]
    s3 = js(CANVAS_STATS, 'points-canvas', background)
    if s3['differing'] < 0.005 * s3['pixels'] or s3['colours'] < 20:
        raise Failure(f'3-D canvas shows no points: {s3}')
    log(f'3-D canvas: {s3["differing"]}/{s3["pixels"]} pixels show points, {s3["colours"]} colours '
        f'({find("#points-info").text.strip("()")})')
    viewer = find('#points-canvas')
    ActionChains(driver).move_to_element(viewer).click_and_hold().move_by_offset(120, 40).release().perform()
    time.sleep(0.5)
    s3b = js(CANVAS_STATS, 'points-canvas', background)
    if s3b['hash'] == s3['hash'] or s3b['differing'] < 0.002 * s3b['pixels']:
        raise Failure(f'dragging did not rotate the 3-D view: before {s3}, after {s3b}')
    log(f'drag rotated the view ({s3b["differing"]} pixels show points)')
    ActionChains(driver).double_click(viewer).perform()  # back to the reference camera for the screenshot

    hrefs = js("return [...document.querySelectorAll('#downloads a')].map(a => a.getAttribute('href'))")
    expected = [f for f in job['links']['files']] + ([job['links']['burst']] if job['links'].get('burst') else [])
    names = sorted(h.split('/')[-1] for h in hrefs)
    if names != sorted(f.split('/')[-1] for f in expected):
        raise Failure(f'download links {names} are not the job\'s files {expected}')
    for h in hrefs:
        if not h.startswith(dfsmd.base + '/api/v1/jobs/'):
            raise Failure(f'download link {h} does not resolve under the page')
    log(f'{len(hrefs)} download links')
    cal_text = find('#result-calibration').text
    if 'focal length' not in cal_text or '±' not in cal_text:
        raise Failure(f'the result\'s calibration lacks focal length ± sigma: {cal_text!r}')
    if not re.search(r'rolling shutter\s*readout -?[0-9.]+ of the frame interval \(estimated\)', cal_text):
        raise Failure(f'the result\'s calibration does not show the estimated readout: {cal_text!r}')

    # 5. Calibration panel.
    wait('the calibration panel', lambda: 'fused' in find('#calibration-body').text.lower()
         and 'focal length' in find('#calibration-body').text, 20)
    log('calibration panel: current + fused + history')

    time.sleep(0.5)
    driver.save_screenshot(os.path.join(out, 'page.png'))
    find('#result-panel').screenshot(os.path.join(out, 'result.png'))
    log(f'screenshots: {out}/page.png, {out}/result.png')

    # 6. Upload: a burst tar dropped on the page (a synthetic drop event with a
    # real File, as Selenium cannot drag files from the desktop), then the same
    # tar through the file input (the drop zone's fallback).
    tar_path = os.path.join(work, 'burst.tar')
    with tarfile.open(tar_path, 'w', format=tarfile.USTAR_FORMAT) as tar:
        for name in sorted(os.listdir(burst)):
            tar.add(os.path.join(burst, name), arcname=f'burst/{name}')
    with open(tar_path, 'rb') as f:
        tar_b64 = base64.b64encode(f.read()).decode()
    listed = lambda: set(js(  # noqa: E731
        "return [...document.querySelectorAll('#job-list li.job')].map(l => l.dataset.jobId)"))

    def uploaded(how, before):
        job = wait(f'the job uploaded by {how} in the list', lambda: next(iter(listed() - before), None), 30)
        wait(f'uploaded job {job} to show succeeded',
             lambda: find(f'#job-list li[data-job-id="{job}"] .status').text.lower() == 'succeeded', 180, 0.25)
        wait(f'the result of uploaded job {job} to open', lambda: find('#result-id').text == job
             and find('#result-panel').get_attribute('data-ready') == 'true', 60)
        origin = dfsmd.get_json(f'/api/v1/jobs/{job}').get('origin')
        log(f'upload by {how}: job {job} (origin {origin}) succeeded and its result opened')
        return job

    before = listed()
    js("""
      const bin = atob(arguments[0]);
      const bytes = new Uint8Array(bin.length);
      for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
      window.testDrop = new DataTransfer();
      window.testDrop.items.add(new File([bytes], 'burst.tar', {type: 'application/x-tar'}));
      for (const type of ['dragenter', 'dragover'])
        document.body.dispatchEvent(new DragEvent(type, {bubbles: true, cancelable: true, dataTransfer: window.testDrop}));
    """, tar_b64)
    if not find('#drop-overlay').is_displayed():
        raise Failure('dragging a file over the page does not show the drop zone')
    js("document.body.dispatchEvent(new DragEvent('drop', {bubbles: true, cancelable: true, dataTransfer: window.testDrop}))")
    if find('#drop-overlay').is_displayed():
        raise Failure('the drop zone stays after the drop')
    uploaded('drop', before)
    before = listed()
    find('#upload-input').send_keys(tar_path)
    uploaded('file input', before)

    # 7. A 503 shows its detail.
    driver.execute_script("window.scrollTo(0, 0)")
    frames.clear()
    frames.send_keys('64')
    js("document.getElementById('trigger-when').value = 'next'")
    find('#trigger-button').click()
    text = wait('the 503 message', lambda: next((m.text for m in driver.find_elements(
        By.CSS_SELECTOR, '#messages .message.error span') if '503' in m.text), None), 15)
    if 'timed out after 1500 ms waiting for 64 consecutive frames' not in text:
        raise Failure(f'the 503 message does not carry the detail: {text!r}')
    log(f'503 shown: {text!r}')
    driver.save_screenshot(os.path.join(out, 'error.png'))

    # dfsmd ends each event stream after server.event_stream_s (4 s here): the
    # page must have reconnected, and it followed every job above through them.
    streams = int(find('#connection').get_attribute('data-streams') or 0)
    if streams < 2 or find('#connection').text != 'live':
        raise Failure(f'the page opened {streams} event streams and shows {find("#connection").text!r}; '
                      'it should reconnect after each stream ends')
    log(f'event streams: {streams} opened one after another (each ends after 4 s), still live')


class PrefixProxy:
    """A reverse proxy serving dfsmd under /dfsm/ (as nginx's `location /dfsm/ {
    proxy_pass http://dfsmd/; }`): the page must work with relative URLs only.
    Responses are streamed (the event stream too), close-delimited. The proxy
    also drops 'unsafe-inline' from dfsmd's Content-Security-Policy: the page
    must run without it (the console check after this part catches violations)."""

    PREFIX = '/dfsm/'

    def __init__(self, upstream_port):
        prefix = self.PREFIX
        self.csp = csp_seen = []

        class Handler(http.server.BaseHTTPRequestHandler):
            protocol_version = 'HTTP/1.0'

            def log_message(self, *args):
                pass

            def forward(self):
                if not self.path.startswith(prefix):
                    self.send_error(404, 'outside the prefix')
                    return
                length = int(self.headers.get('Content-Length') or 0)
                body = self.rfile.read(length) if length else None
                headers = {k: v for k, v in self.headers.items()
                           if k.lower() not in ('connection', 'keep-alive', 'content-length')}
                upstream = http.client.HTTPConnection('127.0.0.1', upstream_port, timeout=120)
                upstream.request(self.command, '/' + self.path[len(prefix):], body=body, headers=headers)
                response = upstream.getresponse()
                self.send_response(response.status, response.reason)
                for k, v in response.getheaders():
                    if k.lower() == 'content-security-policy':
                        # Stricter than dfsmd's: no 'unsafe-inline' for styles either (the
                        # page sets none), so a violation shows in the console check.
                        v = v.replace(" 'unsafe-inline'", '')
                        csp_seen.append(v)
                    if k.lower() not in ('connection', 'keep-alive', 'transfer-encoding', 'content-length'):
                        self.send_header(k, v)
                self.end_headers()
                try:
                    while True:
                        chunk = response.read1(65536)
                        if not chunk:
                            break
                        self.wfile.write(chunk)
                        self.wfile.flush()
                except (OSError, ValueError, http.client.HTTPException):
                    pass  # the browser or dfsmd ended the stream (a reload, the 60 s limit, the proxy stopping)
                finally:
                    upstream.close()

            do_GET = do_POST = do_DELETE = do_HEAD = forward

        class Server(socketserver.ThreadingMixIn, http.server.HTTPServer):
            daemon_threads = True

            def handle_error(self, request, client_address):
                pass  # a connection cut while proxying is not a test failure

        self.server = Server(('127.0.0.1', 0), Handler)
        self.base = f'http://127.0.0.1:{self.server.server_address[1]}{prefix}'
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def stop(self):
        self.server.shutdown()
        self.server.server_close()


def prefix_tests(driver, dfsmd):
    from selenium.webdriver.common.by import By

    js = driver.execute_script
    find = lambda css: driver.find_element(By.CSS_SELECTOR, css)  # noqa: E731
    proxy = PrefixProxy(dfsmd.port)
    try:
        driver.get(proxy.base)
        wait('a live frame under the prefix', lambda: js("const i = document.getElementById('live-image');"
                                                         "return i.complete && i.naturalWidth > 0"), 30)
        wait('the event stream under the prefix', lambda: find('#connection').text == 'live', 15)
        js("document.getElementById('trigger-when').value = 'last'")
        frames = find('#trigger-frames')
        frames.clear()
        frames.send_keys('10')
        # The jobs that exist come from dfsmd, not from the page's list: the list may
        # still be filling in, and an older job appearing late is not the new one.
        before = {j['id'] for j in dfsmd.get_json('/api/v1/jobs?limit=1000')['jobs']}
        find('#trigger-button').click()
        job_id = wait('the new job under the prefix', lambda: next(iter(set(js(
            "return [...document.querySelectorAll('#job-list li.job')].map(l => l.dataset.jobId)")) - before), None), 10)
        wait(f'job {job_id} to succeed and open under the prefix', lambda: find('#result-id').text == job_id
             and find('#result-panel').get_attribute('data-ready') == 'true', 180, 0.25)
        if not proxy.csp or any('unsafe' in v for v in proxy.csp):
            raise Failure(f'the page was not served with a strict CSP through the proxy: {proxy.csp[:1]}')
        urls = js("return performance.getEntriesByType('resource').map(e => e.name)")
        outside = [u for u in urls if not u.startswith(proxy.base)]
        if outside:
            raise Failure(f'under the prefix {proxy.PREFIX} the page requested URLs outside it: {outside[:5]}')
        log(f'under the path prefix {proxy.base}: live view, events, trigger, result; '
            f'all {len(urls)} requests stayed under the prefix; CSP without unsafe-inline: {proxy.csp[0]!r}')
    finally:
        proxy.stop()


def hold_event_streams(dfsmd, count, token):
    """Takes `count` event streams (the page's must then fall back to polling)."""
    held = []
    for _ in range(count):
        c = http.client.HTTPConnection('127.0.0.1', dfsmd.port, timeout=10)
        c.request('GET', '/api/v1/events', headers={'Authorization': f'Bearer {token}'})
        r = c.getresponse()
        if r.status != 200:
            raise Failure(f'event stream {len(held) + 1} answered {r.status}, not 200')
        held.append(c)
    return held


def token_tests(driver, dfsmd, out):
    from selenium.webdriver.common.by import By

    js = driver.execute_script
    find = lambda css: driver.find_element(By.CSS_SELECTOR, css)  # noqa: E731
    # Every event stream this dfsmd allows (4) is taken before the page loads.
    held = hold_event_streams(dfsmd, 4, TOKEN)
    try:
        driver.get(dfsmd.base + '/')
        wait('the token prompt', lambda: js("return document.getElementById('token-dialog').open"), 15)
        driver.save_screenshot(os.path.join(out, 'token.png'))
        find('#token-input').send_keys(TOKEN)
        find('#token-ok').click()
        wait('a live frame with the token', lambda: js("const i = document.getElementById('live-image');"
                                                       "return i.complete && i.naturalWidth > 0"), 30)
        wait('camera state with the token', lambda: find('#cam-state').text == 'streaming', 15)
        if js("return document.getElementById('token-dialog').open"):
            raise Failure('the token prompt is still open')
        asked = js("return document.getElementById('token-dialog').dataset.asked")
        if asked != '1':
            raise Failure(f'the page asked for the token {asked} times, not once')
        if js("return sessionStorage.getItem('dfsmd.token')") != TOKEN:
            raise Failure('the token is not kept in sessionStorage')
        log('token: asked once, then the live view with the bearer header')

        # The fifth stream got 503: the page polls, and the list still follows jobs.
        wait('the polling fallback', lambda: 'polling' in find('#connection').text, 15)
        find('#trigger-button').click()
        job_id = wait('the new job in the list', lambda: js(
            "const li = document.querySelector('#job-list li.job'); return li && li.dataset.jobId"), 5, 0.05)
        wait(f'job {job_id} to show succeeded by polling',
             lambda: find(f'#job-list li[data-job-id="{job_id}"] .status').text.lower() == 'succeeded', 180, 0.25)
        log(f'events busy (503): the page shows "{find("#connection").text}" and job {job_id} reached succeeded '
            f'by polling')
    finally:
        for c in held:
            c.close()

    urls = js("return performance.getEntriesByType('resource').map(e => e.name).concat([location.href])")
    leaked = [u for u in urls if TOKEN in u]
    if leaked:
        raise Failure(f'the token appears in URLs: {leaked}')
    log(f'token in none of the {len(urls)} URLs the page requested')


# Records, every 15 ms, the value of the newest job's progress bar whenever it
# changes: what a user watching the list sees.
PROGRESS_RECORDER = """
window.progressSeen = [];
window.progressTimer = setInterval(() => {
  const li = document.querySelector('#job-list li.job');
  const bar = li && li.querySelector('progress');
  if (!bar) return;
  const seen = window.progressSeen, v = Number(bar.value), last = seen[seen.length - 1];
  if (!last || last.id !== li.dataset.jobId || last.v !== v)
    seen.push({id: li.dataset.jobId, v, status: li.dataset.status});
}, 15);
"""

# The displayed elements a user can reach or needs named, and those of them
# without an accessible name (images with alt="" are decorative).
UNNAMED_CANDIDATES = """
return [...document.querySelectorAll(
  'img, canvas, button, input:not([type=hidden]), select, textarea, a[href], progress, [role=img], [tabindex]')]
  .filter(e => e.getClientRects().length > 0 && getComputedStyle(e).visibility !== 'hidden')
  .filter(e => !(e.tagName === 'IMG' && e.getAttribute('alt') === ''));
"""


def accessible_names(js, tries=5):
    """Counts the visible controls with and without an accessible name, as
    the browser's accessibility tree computes it. The job list and the
    calibration panel re-render on events, so an element found by the query
    can be gone before its name is read: the whole scan is then taken again."""
    from selenium.common.exceptions import StaleElementReferenceException
    for attempt in range(tries):
        unnamed, named = [], 0
        try:
            for element in js(UNNAMED_CANDIDATES):
                name = element.accessible_name
                if name and name.strip():
                    named += 1
                else:
                    unnamed.append(element.get_attribute('outerHTML')[:120])
            return unnamed, named
        except StaleElementReferenceException:
            if attempt == tries - 1:
                raise
            time.sleep(0.2)


def touch(driver, kind, points):
    driver.execute_cdp_cmd('Input.dispatchTouchEvent', {
        'type': kind, 'touchPoints': [{'x': x, 'y': y, 'id': i} for i, (x, y) in enumerate(points)]})


def touch_gesture(driver, paths, steps=12):
    """Moves len(paths) fingers along straight paths [((x0, y0), (x1, y1)), ...]."""
    at = lambda t: [(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])) for a, b in paths]  # noqa: E731
    touch(driver, 'touchStart', at(0))
    for step in range(1, steps + 1):
        touch(driver, 'touchMove', at(step / steps))
        time.sleep(0.016)
    driver.execute_cdp_cmd('Input.dispatchTouchEvent', {'type': 'touchEnd', 'touchPoints': []})
    time.sleep(0.3)


def phone_tests(driver, dfsmd, out):
    """At 390x844 with touch (issue 58), on a 1080p replay: the page by keyboard
    (capture and upload reachable by Tab, Enter works them), the progress of a
    1080p job, no horizontal scroll, every control and image named, the result
    heading in view and focused, the 3-D view by touch without trapping the
    page's scrolling, and the live view's rate (none when paused, hidden or
    while a result is open)."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    js = driver.execute_script
    find = lambda css: driver.find_element(By.CSS_SELECTOR, css)  # noqa: E731
    driver.execute_cdp_cmd('Emulation.setDeviceMetricsOverride',
                           {'width': 390, 'height': 844, 'deviceScaleFactor': 2, 'mobile': True})
    driver.execute_cdp_cmd('Emulation.setTouchEmulationEnabled', {'enabled': True, 'maxTouchPoints': 5})
    driver.get(dfsmd.base + '/')
    js("localStorage.clear(); performance.setResourceTimingBufferSize(100000)")
    driver.get(dfsmd.base + '/')
    js("performance.setResourceTimingBufferSize(100000)")
    wait('a live frame on the phone', lambda: js("const i = document.getElementById('live-image');"
                                                 "return i.complete && i.naturalWidth > 0"), 30)
    wait('the event stream on the phone', lambda: find('#connection').text == 'live', 15)
    view = js("return {w: innerWidth, h: innerHeight, shown: document.getElementById('live-image').naturalWidth}")
    if view['w'] != 390:
        raise Failure(f'the phone viewport is {view}, not 390 px wide')
    if not 16 <= view['shown'] <= 1024:
        raise Failure(f'the live view on a 390 px screen fetches frames {view["shown"]} px wide; it should ask '
                      'for about the width it shows, not the 1080p frame')
    log(f'phone: viewport {view["w"]}x{view["h"]}, live frames {view["shown"]} px wide (of 1920)')

    def snapshots_in(seconds):
        js("performance.clearResourceTimings()")
        time.sleep(seconds)
        return js("return performance.getEntriesByType('resource')"
                  ".filter(e => e.name.includes('snapshot.jpg')).length")

    def pick_rate(value):
        js("const s = document.getElementById('live-rate'); s.value = arguments[0];"
           "s.dispatchEvent(new Event('change'))", value)

    pick_rate('1')
    slow = snapshots_in(3)
    pick_rate('0')
    time.sleep(1.2)
    paused = snapshots_in(2)
    pick_rate('15')
    js("Object.defineProperty(document, 'hidden', {configurable: true, get: () => true});"
       "document.dispatchEvent(new Event('visibilitychange'))")
    time.sleep(1.2)
    hidden = snapshots_in(2)
    js("delete document.hidden; document.dispatchEvent(new Event('visibilitychange'))")
    fast = snapshots_in(2)
    if not (1 <= slow <= 5 and paused == 0 and hidden == 0 and fast >= 6):
        raise Failure(f'live view requests: {slow} in 3 s at 1 fps, {paused} in 2 s paused, {hidden} in 2 s '
                      f'hidden, {fast} in 2 s at 15 fps')
    log(f'live view: {slow} frames in 3 s at 1 fps, {fast} in 2 s at 15 fps, none paused or hidden')

    # Keyboard only: Tab reaches the capture button, then the upload button;
    # Enter on the upload opens the file chooser (its input's click, stopped
    # here: headless Chromium has no dialog); Enter on capture triggers.
    js("document.activeElement.blur(); window.scrollTo(0, 0);"
       "window.chooserOpened = 0; document.getElementById('upload-input').addEventListener('click',"
       " (e) => { window.chooserOpened++; e.preventDefault(); });")
    order = []
    for _ in range(40):
        ActionChains(driver).send_keys(Keys.TAB).perform()
        focused = js("return document.activeElement.id")
        order.append(focused)
        if focused == 'upload-button':
            break
    if 'trigger-button' not in order or order[-1] != 'upload-button':
        raise Failure(f'Tab does not reach the capture and upload buttons: {order}')
    ActionChains(driver).send_keys(Keys.ENTER).perform()
    wait('the file chooser from Enter on the upload button', lambda: js("return window.chooserOpened") == 1, 5)
    log(f'keyboard: Tab reaches capture and upload ({len(order)} stops), Enter opens the file chooser')

    js(PROGRESS_RECORDER)
    ActionChains(driver).key_down(Keys.SHIFT).send_keys(Keys.TAB).key_up(Keys.SHIFT).perform()
    if js("return document.activeElement.id") != 'trigger-button':
        raise Failure(f'Shift+Tab from upload lands on {js("return document.activeElement.id")!r}')
    ActionChains(driver).send_keys(Keys.ENTER).perform()
    job_id = wait('the 1080p job in the list', lambda: js(
        "const li = document.querySelector('#job-list li.job'); return li && li.dataset.jobId"), 10, 0.05)
    wait(f'1080p job {job_id} to succeed', lambda: find(f'#job-list li[data-job-id="{job_id}"] .status')
         .text.lower() == 'succeeded', 240, 0.25)
    time.sleep(0.2)
    seen = [e['v'] for e in js("clearInterval(window.progressTimer); return window.progressSeen")
            if e['id'] == job_id]
    steps = [b - a for a, b in zip(seen, seen[1:])]
    if len(seen) < 8 or any(s <= 0 for s in steps) or max(steps) > 0.35 or seen[-1] != 1:
        raise Failure(f'progress of the 1080p job as shown: {seen}; it should rise strictly through at least '
                      '8 values to 1, no step over 0.35')
    log(f'1080p job {job_id}: progress through {len(seen)} values, largest step {max(steps):.2f}: '
        + ' '.join(f'{v:.2f}' for v in seen))

    wait('the result to open', lambda: find('#result-id').text == job_id
         and find('#result-panel').get_attribute('data-ready') == 'true', 60)
    wait('the result heading in view below the header', lambda: js("""
      const h = document.getElementById('result-heading').getBoundingClientRect();
      const bar = document.querySelector('header.bar').getBoundingClientRect();
      return h.top >= bar.bottom - 1 && h.bottom <= innerHeight;"""), 5)
    if js("return document.activeElement.id") != 'result-heading':
        raise Failure(f'focus is on {js("return document.activeElement.id")!r}, not the result heading')
    wait('the calibration panel on the phone', lambda: 'focal length' in find('#calibration-body').text, 20)
    time.sleep(0.5)
    widths = js("return {scroll: document.documentElement.scrollWidth, inner: innerWidth}")
    if widths['scroll'] > widths['inner']:
        wide = js("""return [...document.querySelectorAll('body *')].filter(e => e.getBoundingClientRect().right > innerWidth + 1)
                     .slice(0, 8).map(e => e.tagName + '#' + e.id + '.' + e.className)""")
        raise Failure(f'the page scrolls sideways at 390 px: {widths}; wider than the screen: {wide}')
    live_paused = snapshots_in(1.5)
    if live_paused:
        raise Failure(f'{live_paused} live frames fetched while a result is open')
    log(f'result open: heading in view and focused, no sideways scroll ({widths}), live view paused')

    unnamed, named = accessible_names(js)
    if unnamed:
        raise Failure(f'{len(unnamed)} controls or images without an accessible name: {unnamed}')
    log(f'accessible names: all {named} controls and images named')

    # Touch on the 3-D view: one finger across rotates; one finger up scrolls
    # the page (the viewer does not trap it); two fingers apart zoom.
    wait('the 3-D canvas to render', lambda: int(find('#points-canvas').get_attribute('data-rendered') or 0) > 0, 60)
    js("document.getElementById('points-canvas').scrollIntoView({block: 'center'})")
    time.sleep(0.5)
    box = js("const r = document.getElementById('points-canvas').getBoundingClientRect();"
             "return {x: r.left + r.width / 2, y: r.top + r.height / 2, w: r.width, h: r.height}")
    background = [0x11, 0x15, 0x1c]
    before = js(CANVAS_STATS, 'points-canvas', background)
    x, y = box['x'], box['y']
    touch_gesture(driver, [((x - 80, y), (x + 80, y))])
    rotated = js(CANVAS_STATS, 'points-canvas', background)
    if rotated['hash'] == before['hash']:
        raise Failure('one finger across the 3-D view does not rotate it')
    touch_gesture(driver, [((x - 30, y), (x - 110, y)), ((x + 30, y), (x + 110, y))])
    zoomed = js(CANVAS_STATS, 'points-canvas', background)
    if zoomed['hash'] == rotated['hash']:
        raise Failure('two fingers apart on the 3-D view do not zoom it')
    # A finger down over the viewer: the page scrolls back up (it is scrolled
    # to the viewer, so it can).
    scrolled = js("return scrollY")
    touch_gesture(driver, [((x, y - 100), (x, y + 100))], steps=20)
    if not 0 < js("return scrollY") < scrolled:
        raise Failure(f'a finger down over the 3-D view does not scroll the page (scrollY {scrolled} -> '
                      f'{js("return scrollY")}): the viewer traps it')
    log(f'touch: one finger rotates, two pinch-zoom, a swipe over the viewer scrolls the page '
        f'(scrollY {scrolled} -> {js("return scrollY")})')
    driver.save_screenshot(os.path.join(out, 'phone.png'))

    # Delete by keyboard: the job's Delete button is named for its job; the
    # calibration that came from it goes from the panel.
    if job_id not in find('#calibration-body').text:
        raise Failure(f'the calibration panel does not name job {job_id}: {find("#calibration-body").text!r}')
    delete = find(f'#job-list button[aria-label="Delete job {job_id}"]')
    js("arguments[0].focus()", delete)
    ActionChains(driver).send_keys(Keys.ENTER).perform()
    wait('the confirmation', lambda: driver.switch_to.alert, 5).accept()
    wait(f'job {job_id} to leave the list', lambda: not driver.find_elements(
        By.CSS_SELECTOR, f'#job-list li[data-job-id="{job_id}"]'), 10)
    # The fusion's history still lists the job; the current calibration is gone.
    wait('the calibration panel to forget the deleted job', lambda: not js(
        "return [...document.querySelectorAll('#calibration-body h3 a')].some(a => a.textContent === arguments[0])",
        job_id) and 'No calibration yet' in find('#calibration-body').text, 10)
    log(f'keyboard delete of {job_id}: the calibration panel no longer names it')

    # dfsmd gone: the camera's numbers are no longer shown as if current.
    js("window.scrollTo(0, 0); document.getElementById('result-close').click()")
    dfsmd.stop()
    wait('the page to say dfsmd is unreachable', lambda: find('#cam-fps').text == '–'
         and 'cannot be reached' in find('#live-placeholder').text, 15)
    log(f'dfsmd stopped: camera numbers cleared, the live view says {find("#live-placeholder").text!r}')


def check_console(driver, console, where):
    problems = console_problems(driver, console)
    if problems:
        raise Failure(f'{where}, the browser console shows errors:\n  ' + '\n  '.join(problems))


def desktop_tests(driver, args, burst, work, console, daemons):
    """Parts 1-11: the page at 1400 px on a 320x240 replay, under a prefix, with a token."""
    dfsmd = Dfsmd(args.dfsmd, burst, os.path.join(work, 'state'))
    daemons.append(dfsmd)
    log(f'dfsmd at {dfsmd.base}')
    page_tests(driver, dfsmd, args.out, burst, work)
    check_console(driver, console, 'on the page')
    prefix_tests(driver, dfsmd)
    check_console(driver, console, 'under the path prefix and the strict CSP')
    token_file = os.path.join(work, 'token')
    with open(token_file, 'w') as f:
        f.write(TOKEN + '\n')
    os.chmod(token_file, 0o600)
    token_dfsmd = Dfsmd(args.dfsmd, burst, os.path.join(work, 'state-token'),
                        ['--server.token_file', token_file])  # streams of the default 60 s
    daemons.append(token_dfsmd)
    token_tests(driver, token_dfsmd, args.out)
    check_console(driver, console, 'with a token')


def phone_part(driver, args, work, console, daemons):
    """Part 12: a third dfsmd replaying a generated 1080p burst."""
    if not args.dfsm:
        raise Failure('the phone part needs --dfsm to generate its 1080p burst')
    burst_1080 = os.path.join(work, 'burst-1080')
    subprocess.run([args.dfsm, 'synth', '--out', burst_1080, '--frames', '10', '--supersampling', '2'],
                   check=True, stdout=subprocess.DEVNULL)
    # 1080p frames take longer to copy out of the ring than 320x240 ones.
    dfsmd = Dfsmd(args.dfsmd, burst_1080, os.path.join(work, 'state-phone'), extra=(), burst_timeout_ms=10000)
    daemons.append(dfsmd)
    phone_tests(driver, dfsmd, args.out)
    check_console(driver, console, 'on the phone')


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--dfsmd', required=True, help='the dfsmd binary')
    parser.add_argument('--burst', help='a dfsm-burst/1 directory to replay (default: generated with --dfsm)')
    parser.add_argument('--dfsm', help='the dfsm tool, to generate a 320x240 10-frame burst when --burst is absent')
    parser.add_argument('--out', required=True, help='directory for screenshots and logs')
    parser.add_argument('--keep', action='store_true', help='keep the temporary state directories')
    parser.add_argument('--phone-only', action='store_true', help='only the phone part (12)')
    args = parser.parse_args()

    chromium, driver_path = find_browser()
    os.makedirs(args.out, exist_ok=True)
    for name in os.listdir(args.out):  # outputs of an earlier run
        if re.fullmatch(r'(page|result|error|token|phone|failure)\.png|console\.log|dfsmd-\d+\.log', name):
            os.remove(os.path.join(args.out, name))
    if not os.access(args.dfsmd, os.X_OK):
        raise Failure(f'--dfsmd {args.dfsmd} is not an executable')
    work = tempfile.mkdtemp(prefix='dfsm-page-test-')
    driver = None
    daemons = []
    console = []
    try:
        burst = args.burst
        if not burst:
            if not args.dfsm:
                raise Failure('give --burst DIR or --dfsm PATH (to generate one)')
            burst = os.path.join(work, 'burst')
            subprocess.run([args.dfsm, 'synth', '--out', burst, '--width', '320', '--height', '240',
                            '--frames', '10'], check=True, stdout=subprocess.DEVNULL)
        if not os.path.exists(os.path.join(burst, 'manifest.json')):
            raise Failure(f'{burst} is not a burst directory (no manifest.json)')
        driver = start_browser(chromium, driver_path, work)
        log(f'{driver.capabilities.get("browserName")} {driver.capabilities.get("browserVersion")}')
        if not args.phone_only:
            desktop_tests(driver, args, burst, work, console, daemons)
        phone_part(driver, args, work, console, daemons)
        log('PASS')
        return 0
    except Failure as e:
        print(f'page_test: FAIL: {e}', file=sys.stderr, flush=True)
        if driver:
            try:
                driver.save_screenshot(os.path.join(args.out, 'failure.png'))
                console_problems(driver, console)
                print('page_test: screenshot at ' + os.path.join(args.out, 'failure.png'), file=sys.stderr)
            except Exception:  # noqa: BLE001
                pass
        return 1
    finally:
        if console:
            with open(os.path.join(args.out, 'console.log'), 'w') as f:
                for entry in console:
                    f.write(f'{entry.get("level")} {entry.get("message")}\n')
        for d in daemons:
            if d:
                d.stop()
                with open(os.path.join(args.out, f'dfsmd-{d.port}.log'), 'w') as f:
                    f.write('\n'.join(d.lines) + '\n')
        if driver:
            driver.quit()
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == '__main__':
    try:
        sys.exit(main())
    except Failure as e:
        print(f'page_test: FAIL: {e}', file=sys.stderr)
        sys.exit(1)

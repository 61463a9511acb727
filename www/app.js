// dfsmd's web page (issue 17): live view, trigger, jobs with progress, result
// (reference, depth with legend and hover, confidence, 3-D points, files,
// calibration), calibration panel, upload by drop, bearer token.
//
// Plain ES modules, no build step. Every URL is relative to the page, so the
// page works behind a reverse proxy under a path prefix. The token (when the
// server asks for one with 401) lives in sessionStorage and travels only in
// the Authorization header: images and downloads are fetched, not linked.
import {decodeFloatTiff, parsePly, SseParser, TURBO_LUT} from './formats.js';

const $ = (id) => document.getElementById(id);
const TOKEN_KEY = 'dfsmd.token';
const JOB_LIMIT = 50;

// ---------------------------------------------------------------------------
// HTTP: relative URLs, the bearer token, problem+json.

// '/api/v1/jobs/x' (as the server's links say) -> 'api/v1/jobs/x' relative to the page.
function url(path) {
  return new URL(path.replace(/^\/+/, ''), document.baseURI).href;
}

class ApiError extends Error {
  constructor(status, title, detail, type) {
    super(detail || title || `HTTP ${status}`);
    this.status = status;
    this.title = title;
    this.detail = detail;
    this.type = type;
  }
  describe() {
    const head = this.status ? `${this.status} ${this.title || ''}`.trim() : (this.title || 'error');
    return this.detail ? `${head}: ${this.detail}` : head;
  }
}

async function problemOf(response) {
  let title = response.statusText, detail = '', type = '';
  try {
    const text = await response.text();
    try {
      const body = JSON.parse(text);
      title = body.title || title;
      detail = body.detail || '';
      type = body.type || '';
    } catch {
      detail = text.slice(0, 300);
    }
  } catch { /* no body */ }
  return new ApiError(response.status, title, detail, type);
}

let tokenPrompt = null;     // the pending dialog, shared by concurrent 401s
let tokenDeclined = false;  // the user cancelled: ask again only on request

function token() { return sessionStorage.getItem(TOKEN_KEY) || ''; }

function askToken(reason) {
  if (tokenPrompt) return tokenPrompt;
  const dialog = $('token-dialog');
  $('token-reason').textContent = reason;
  $('token-input').value = '';
  $('token-button').hidden = false;
  dialog.dataset.asked = String(Number(dialog.dataset.asked || 0) + 1);  // read by the browser test
  tokenPrompt = new Promise((resolve) => {
    const done = (value) => {
      dialog.removeEventListener('close', onClose);
      if (dialog.open) dialog.close();
      tokenPrompt = null;
      resolve(value);
    };
    const onClose = () => done(dialog.returnValue === 'ok' ? $('token-input').value.trim() : '');
    dialog.addEventListener('close', onClose);
    dialog.returnValue = '';
    dialog.showModal();
  }).then((value) => {
    if (value) {
      sessionStorage.setItem(TOKEN_KEY, value);
      tokenDeclined = false;
    } else {
      tokenDeclined = true;
    }
    return value;
  });
  return tokenPrompt;
}

// fetch() with the token; on 401 asks for it (once, shared) and retries.
async function api(path, options = {}, retried = false) {
  const headers = new Headers(options.headers || {});
  const t = token();
  if (t) headers.set('Authorization', `Bearer ${t}`);
  let response;
  try {
    response = await fetch(url(path), {cache: 'no-store', ...options, headers});
  } catch (e) {
    throw new ApiError(0, 'dfsmd cannot be reached', e.message || String(e));
  }
  if (response.status === 401 && !retried) {
    const challenge = response.headers.get('WWW-Authenticate') || '';
    await response.body?.cancel();
    if (tokenDeclined && !t) throw new ApiError(401, 'Unauthorized', 'this dfsmd needs its token (press "Token…")');
    const reason = /invalid_token/.test(challenge) || t
      ? 'The token was refused: enter the right one.'
      : 'This dfsmd is protected by a bearer token.';
    const entered = await askToken(reason);
    if (!entered) throw new ApiError(401, 'Unauthorized', 'no token given (press "Token…" to enter it)');
    return api(path, options, true);
  }
  if (!response.ok) throw await problemOf(response);
  return response;
}

const getJson = async (path) => (await api(path)).json();

// ---------------------------------------------------------------------------
// Messages (errors as the problem's detail, and notices).

function message(text, kind = 'error', {sticky = false} = {}) {
  const box = $('messages');
  const item = document.createElement('div');
  item.className = `message ${kind}`;
  const span = document.createElement('span');
  span.textContent = text;
  const close = document.createElement('button');
  close.type = 'button';
  close.className = 'close';
  close.textContent = '×';
  close.title = 'dismiss';
  close.setAttribute('aria-label', 'Dismiss this message');
  close.addEventListener('click', () => item.remove());
  item.append(span, close);
  box.prepend(item);
  while (box.children.length > 5) box.lastElementChild.remove();
  if (kind !== 'error' && !sticky) setTimeout(() => item.remove(), 8000);
  return item;
}

function showError(prefix, error) {
  const text = error instanceof ApiError ? error.describe() : (error && error.message) || String(error);
  message(prefix ? `${prefix}: ${text}` : text, 'error');
}

// ---------------------------------------------------------------------------
// Live view: the newest frame by fetch (so the token can be sent), at the
// rate and size the user picks (kept in localStorage), none while the tab is
// hidden or a result is open; and the camera's state once a second.

const LIVE_KEY = 'dfsmd.live';
const live = {shown: [], url: null, busy: false, lastCamera: null};

function liveSettings() {
  return {fps: Number($('live-rate').value), size: $('live-size').value};
}

function bindLiveSettings() {
  try {
    const saved = JSON.parse(localStorage.getItem(LIVE_KEY) || '{}');
    if ([...$('live-rate').options].some((o) => o.value === String(saved.fps))) $('live-rate').value = String(saved.fps);
    if ([...$('live-size').options].some((o) => o.value === saved.size)) $('live-size').value = saved.size;
  } catch { /* a damaged entry: the defaults */ }
  for (const id of ['live-rate', 'live-size'])
    $(id).addEventListener('change', () => localStorage.setItem(LIVE_KEY, JSON.stringify(liveSettings())));
}

// Why the live view fetches nothing now, or '' when it runs.
function livePaused() {
  if (document.hidden) return 'paused while the tab is hidden';
  if (liveSettings().fps <= 0) return 'live view paused (pick a rate above)';
  if (!$('result-panel').hidden) return 'live view paused while a result is open';
  return '';
}

// The snapshot's URL: at the width the image is shown ("fit"), in device pixels.
function snapshotPath() {
  if (liveSettings().size === 'full') return 'api/v1/snapshot.jpg';
  const shown = $('live-image').clientWidth || $('live-placeholder').clientWidth || 640;
  const width = Math.min(8192, Math.max(16, Math.ceil((shown * (window.devicePixelRatio || 1)) / 64) * 64));
  return `api/v1/snapshot.jpg?width=${width}`;
}

function showLivePlaceholder(text) {
  $('live-placeholder').hidden = false;
  $('live-placeholder').textContent = text;
}

async function liveLoop() {
  for (;;) {
    const started = performance.now();
    const paused = livePaused();
    $('view-rate').textContent = paused ? 'paused' : `${liveSettings().fps} fps, ${liveSettings().size === 'full' ? 'full' : 'fit'}`;
    if (paused) {
      if (!document.hidden) showLivePlaceholder(paused);
      live.shown = [];
      await sleep(300);
      continue;
    }
    try {
      const response = await api(snapshotPath());
      const blob = await response.blob();
      const next = URL.createObjectURL(blob);
      const img = $('live-image');
      await new Promise((resolve) => {
        img.onload = img.onerror = resolve;
        img.src = next;
      });
      if (live.url) URL.revokeObjectURL(live.url);
      live.url = next;
      img.hidden = false;
      $('live-placeholder').hidden = true;
      const now = performance.now();
      live.shown.push(now);
      while (live.shown.length && now - live.shown[0] > 2000) live.shown.shift();
    } catch (e) {
      showLivePlaceholder(e.status === 503 ? 'no frame yet (capture not streaming)'
        : e.status === 0 ? 'dfsmd cannot be reached; retrying…' : `no frame: ${e.message}`);
      await sleep(e.status === 401 ? 5000 : 1000);
    }
    const wait = 1000 / Math.max(1, liveSettings().fps) - (performance.now() - started);
    if (wait > 0) await sleep(wait);
  }
}

async function cameraLoop() {
  for (;;) {
    try {
      const cam = await getJson('api/v1/camera');
      const previous = live.lastCamera;
      live.lastCamera = {...cam, at: performance.now()};
      $('camera-source').textContent = `${cam.source || ''} ${cam.width || '?'}x${cam.height || '?'}`;
      const state = $('cam-state');
      state.textContent = cam.streaming ? 'streaming' : (cam.last_error ? 'error' : 'not streaming');
      state.className = cam.streaming ? 'ok' : 'bad';
      let measured = '';
      if (previous && cam.frames_captured >= previous.frames_captured) {
        const dt = (live.lastCamera.at - previous.at) / 1000;
        if (dt > 0) measured = ` (${((cam.frames_captured - previous.frames_captured) / dt).toFixed(1)} measured)`;
      }
      $('cam-fps').textContent = `${cam.fps ? Number(cam.fps).toFixed(1) : '?'}${measured}`;
      $('cam-captured').textContent = String(cam.frames_captured ?? '–');
      $('cam-drops').textContent = String(cam.frames_dropped ?? '–');
      $('cam-ring').textContent = `${cam.ring_fill ?? '?'} / ${cam.ring_capacity ?? '?'}`;
      if (cam.ring_capacity) $('trigger-frames').max = String(cam.ring_capacity);
      const err = $('cam-error');
      err.hidden = !cam.last_error;
      err.textContent = cam.last_error ? `last error: ${cam.last_error}` : '';
    } catch (e) {
      // Nothing below is known any more: no number stays as if it were.
      for (const id of ['cam-fps', 'cam-captured', 'cam-drops', 'cam-ring']) $(id).textContent = '–';
      live.lastCamera = null;
      $('cam-state').textContent = e.status ? `HTTP ${e.status}` : 'dfsmd unreachable';
      $('cam-state').className = 'bad';
    }
    const n = live.shown.length;
    $('view-fps').textContent = n > 1 ? ((n - 1) / ((live.shown[n - 1] - live.shown[0]) / 1000)).toFixed(1) : '–';
    await sleep(1000);
  }
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// ---------------------------------------------------------------------------
// Jobs: a map kept by the event stream (or polling), rendered newest first.

const jobs = new Map();
let followed = new Set();   // jobs triggered or uploaded from this page: opened when they succeed
let openJobId = null;

// Where a job is, in the order it gets there.
const STATUS_RANK = {queued: 0, processing: 1, succeeded: 2, failed: 2};

// What `job` (an event, a poll's or a request's answer) changes of `before`:
// never a step back within one run, since an answer may be older than the
// last event (the capture's own answer, "queued", often is).
function mergeJob(before, job) {
  if (!before) return {...job, progress: typeof job.progress === 'number' ? job.progress : 0};
  const older = (job.attempts ?? before.attempts) === before.attempts &&
    (STATUS_RANK[job.status] ?? 0) < (STATUS_RANK[before.status] ?? 0);
  if (older) {
    const {status, stage, progress, ...rest} = job;
    return {...before, ...rest};
  }
  const merged = {...before, ...job};
  if (merged.status === 'succeeded' || merged.status === 'failed') merged.progress = 1;
  else if (typeof job.progress !== 'number') merged.progress = before.progress || 0;
  else if (before.status === merged.status && before.attempts === merged.attempts)
    merged.progress = Math.max(before.progress || 0, job.progress);
  return merged;
}

function upsertJob(job) {
  if (!job || !job.id) return;
  if (job.deleted) {
    jobs.delete(job.id);
    if (openJobId === job.id) closeResult();
    scheduleCalibration();  // it may have come from this job
  } else {
    const before = jobs.get(job.id);
    const merged = mergeJob(before, job);
    jobs.set(job.id, merged);
    // A new status is shown at once, before a result opens and takes the
    // main thread; progress and stages wait for the next frame.
    if (!before || before.status !== merged.status) {
      renderJobs();
    }
    if (job.status === 'succeeded' && (!before || before.status !== 'succeeded')) {
      scheduleCalibration();
      if (followed.has(job.id)) {
        followed.delete(job.id);
        openResult(job.id);
      }
    }
    if (job.status === 'failed' && followed.has(job.id)) {
      followed.delete(job.id);
      const advice = adviceFor(job.error || '');
      message(`job ${job.id} failed: ${job.error || 'no reason given'}${advice ? `. ${advice}` : ''}`);
    }
  }
  scheduleRender();
}

let renderPending = false;
function scheduleRender() {
  if (renderPending) return;
  renderPending = true;
  requestAnimationFrame(() => { renderPending = false; renderJobs(); });
}

function el(tag, props = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(props)) {
    if (k === 'class') e.className = v;
    else if (k === 'dataset') Object.assign(e.dataset, v);
    else if (k.startsWith('on')) e.addEventListener(k.slice(2), v);
    else if (v !== undefined && v !== null && v !== false) e.setAttribute(k, v === true ? '' : v);
  }
  for (const c of children) if (c !== null && c !== undefined && c !== false) e.append(c);
  return e;
}

function fmtTime(ms) {
  if (!ms) return '';
  const d = new Date(ms);
  return d.toLocaleTimeString([], {hour: '2-digit', minute: '2-digit', second: '2-digit'});
}

// What to do about a failed burst, by the reason the pipeline gave.
const ADVICE = [
  [/insufficient parallax|too little baseline|move the camera a little/, 'Too little motion: hold the camera by hand (not on a tripod or a table), as still as for a photo, and capture again; the tremor does the rest.'],
  [/too few (consistent )?tracks/, 'Too little to track: aim at a textured, well-lit scene a few metres away, and hold the camera steadier (less blur).'],
  [/needs at least 3 frames/, 'Capture more frames (10-30).'],
];

function adviceFor(error) {
  const found = ADVICE.find(([pattern]) => pattern.test(error));
  return found ? found[1] : '';
}

function jobItem(id, j) {
  const stage = j.status === 'processing' && j.stage ? j.stage : '';
  const total = j.timings_ms && j.timings_ms.total ? `${(j.timings_ms.total / 1000).toFixed(1)} s` : '';
  const input = j.input && j.input.width ? `${j.input.frames}×${j.input.width}x${j.input.height}` : '';
  const advice = j.status === 'failed' ? adviceFor(j.error || '') : '';
  const li = el('li', {class: `job ${j.status}${id === openJobId ? ' open' : ''}`, dataset: {jobId: id, status: j.status},
                       title: j.status === 'succeeded' ? 'open the result' : ''},
    el('div', {class: 'job-head'},
      el('span', {class: 'mono job-id'}, id),
      el('span', {class: `status status-${j.status}`}, j.status),
      stage && el('span', {class: 'stage'}, stage),
      j.status === 'succeeded' && el('button', {type: 'button', class: 'link-like open-result',
        'aria-label': `Open the result of job ${id}`, onclick: (e) => { e.stopPropagation(); openResult(id); }}, 'open')),
    el('div', {class: 'job-meta muted'},
      [fmtTime(j.created_ms), j.origin, input, total].filter(Boolean).join(' · ')),
    el('progress', {max: '1', value: String(j.progress ?? 0), 'aria-label': `progress of job ${id}`}),
    j.error ? el('div', {class: 'error-text'}, j.error) : null,
    advice ? el('div', {class: 'advice'}, advice) : null);
  if (j.status !== 'processing') {
    li.append(el('button', {type: 'button', class: 'small delete', 'aria-label': `Delete job ${id}`,
      title: 'delete this job and its files', onclick: (e) => { e.stopPropagation(); deleteJob(id); }}, 'Delete'));
  }
  li.addEventListener('click', () => { if (j.status === 'succeeded') openResult(id); });
  return li;
}

function renderJobs() {
  const ids = [...jobs.keys()].sort().reverse();  // ids sort by creation time
  $('jobs-empty').hidden = ids.length > 0;
  $('jobs-count').textContent = ids.length ? `(${ids.length})` : '';
  // The focused control is found again by its label after the list is rebuilt.
  const focused = document.activeElement && $('job-list').contains(document.activeElement)
    ? document.activeElement.getAttribute('aria-label') : null;
  $('job-list').replaceChildren(...ids.slice(0, JOB_LIMIT).map((id) => jobItem(id, jobs.get(id))));
  if (focused) {
    const again = [...$('job-list').querySelectorAll('button')].find((b) => b.getAttribute('aria-label') === focused);
    if (again) again.focus();
  }
}

async function deleteJob(id) {
  if (!confirm(`Delete job ${id} with its burst and results?`)) return;
  try {
    await api(`api/v1/jobs/${id}`, {method: 'DELETE'});
    upsertJob({id, deleted: true});
    message(`job ${id} deleted`, 'notice');
  } catch (e) {
    showError(`cannot delete ${id}`, e);
  }
}

async function refreshJobs() {
  const body = await getJson(`api/v1/jobs?limit=${JOB_LIMIT}`);
  const seen = new Set();
  for (const j of body.jobs || []) { seen.add(j.id); upsertJob(j); }
  // Jobs older than the newest page stay; newer ones missing were deleted.
  const oldest = body.jobs && body.jobs.length ? body.jobs[body.jobs.length - 1].id : '';
  for (const id of [...jobs.keys()]) if (!seen.has(id) && (!body.next || id > oldest)) upsertJob({id, deleted: true});
}

// The event stream through fetch (EventSource cannot send the Authorization
// header); on 503 (too many streams) or errors: polling every 2 s, and a new
// attempt at the stream a minute later.
function setConnection(text, kind) {
  const c = $('connection');
  c.textContent = text;
  c.className = `pill ${kind}`;
}

async function eventsLoop() {
  let retry = 2000;
  for (;;) {
    let ok = false;
    try {
      const response = await api('api/v1/events', {headers: {Accept: 'text/event-stream'}});
      if (!response.body) throw new Error('no stream');
      setConnection('live', 'ok');
      ok = true;
      const pill = $('connection');
      pill.dataset.streams = String(Number(pill.dataset.streams || 0) + 1);  // read by the browser test
      const parser = new SseParser(({event, data}) => {
        if (event !== 'job') return;
        try { upsertJob(JSON.parse(data)); } catch { /* not JSON: ignore */ }
      }, (ms) => { retry = ms; });
      const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
      for (;;) {
        const {value, done} = await reader.read();
        if (done) break;
        parser.push(value);
      }
      // The server ends each stream after about a minute: reconnect at once
      // (the list would miss the changes of a pause), after a failure later.
      await sleep(100);
    } catch (e) {
      if (!ok) {
        await pollFor(e.status === 503 ? 60000 : 20000, e);
      } else {
        await sleep(retry);
      }
    }
  }
}

async function pollFor(ms, why) {
  setConnection(why && why.status === 503 ? 'polling (event streams busy)' : 'polling', 'warn');
  const until = performance.now() + ms;
  while (performance.now() < until) {
    try {
      await refreshJobs();
      if ($('connection').classList.contains('bad')) setConnection('polling', 'warn');
    } catch (e) {
      setConnection(e.status === 401 ? 'needs token' : 'offline', 'bad');
    }
    await sleep(2000);
  }
}

// ---------------------------------------------------------------------------
// Trigger and upload.

// "auto" keeps as many of Frames as the motion needs: ticked, Frames becomes
// a maximum, 30 where it was lower (and the ring holds that many).
function autoFramesToggled() {
  const frames = $('trigger-frames');
  if ($('trigger-auto').checked && Number(frames.value) < 30)
    frames.value = String(Math.min(30, Number(frames.max) || 30));
}

async function trigger(event) {
  event.preventDefault();
  const button = $('trigger-button');
  const frames = Number($('trigger-frames').value);
  // "auto": the job keeps as many of them as its parallax needs.
  const body = $('trigger-auto').checked ? {frames: 'auto', max_frames: frames} : {frames};
  body.when = $('trigger-when').value;
  body.planes = Number($('trigger-planes').value);
  button.disabled = true;
  const wait = body.when === 'next' ? message(`waiting for the next ${frames} frames…`, 'notice') : null;
  try {
    const response = await api('api/v1/captures', {
      method: 'POST', headers: {'Content-Type': 'application/json'}, body: JSON.stringify(body)});
    const job = await response.json();
    followed.add(job.id);
    upsertJob({progress: 0, created_ms: Date.now(), origin: 'capture', ...job});
    message(`job ${job.id} ${job.status}`, 'notice');
    getJson(`api/v1/jobs/${job.id}`).then(upsertJob).catch(() => {});
  } catch (e) {
    showError('capture refused', e);
  } finally {
    if (wait) wait.remove();
    button.disabled = false;
  }
}

// POST with the upload's progress (fetch reports none): resolves to the
// parsed JSON of a 2xx answer, rejects with the ApiError of any other.
function postWithProgress(path, file, onProgress) {
  return new Promise((resolve, reject) => {
    const xhr = new XMLHttpRequest();
    xhr.open('POST', url(path));
    xhr.setRequestHeader('Content-Type', 'application/x-tar');
    if (token()) xhr.setRequestHeader('Authorization', `Bearer ${token()}`);
    xhr.upload.addEventListener('progress', (e) => { if (e.lengthComputable) onProgress(e.loaded / e.total); });
    xhr.addEventListener('error', () => reject(new ApiError(0, 'dfsmd cannot be reached', 'the upload was cut off')));
    xhr.addEventListener('load', () => {
      let body = {};
      try { body = JSON.parse(xhr.responseText); } catch { /* not JSON */ }
      if (xhr.status >= 200 && xhr.status < 300) resolve(body);
      else reject(new ApiError(xhr.status, body.title || xhr.statusText, body.detail || xhr.responseText.slice(0, 300), body.type));
    });
    xhr.send(file);
  });
}

async function upload(file) {
  if (!file) return;
  const note = message(`uploading ${file.name} (${(file.size / 1048576).toFixed(1)} MiB)…`, 'notice', {sticky: true});
  const bar = el('progress', {max: '1', value: '0', 'aria-label': `upload of ${file.name}`});
  note.querySelector('span').append(bar);
  try {
    let job;
    try {
      job = await postWithProgress('api/v1/jobs', file, (share) => { bar.value = share; });
    } catch (e) {
      if (e.status !== 401) throw e;
      // The server asks for its token: once, then the upload again through api().
      job = await (await api('api/v1/jobs', {
        method: 'POST', headers: {'Content-Type': 'application/x-tar'}, body: file})).json();
    }
    followed.add(job.id);
    upsertJob({progress: 0, created_ms: Date.now(), origin: 'upload', ...job});
    message(`${file.name}: job ${job.id} ${job.status}`, 'notice');
    getJson(`api/v1/jobs/${job.id}`).then(upsertJob).catch(() => {});
  } catch (e) {
    showError(`upload of ${file.name} refused`, e);
  } finally {
    note.remove();
  }
}

function bindDrop() {
  const overlay = $('drop-overlay');
  let depth = 0;
  const hasFiles = (e) => e.dataTransfer && [...e.dataTransfer.types].includes('Files');
  document.addEventListener('dragenter', (e) => { if (hasFiles(e)) { depth++; overlay.hidden = false; } });
  document.addEventListener('dragleave', () => { if (--depth <= 0) { depth = 0; overlay.hidden = true; } });
  document.addEventListener('dragover', (e) => { if (hasFiles(e)) e.preventDefault(); });
  document.addEventListener('drop', (e) => {
    if (!hasFiles(e)) return;
    e.preventDefault();
    depth = 0;
    overlay.hidden = true;
    for (const f of e.dataTransfer.files) upload(f);
  });
  $('upload-button').addEventListener('click', () => $('upload-input').click());
  $('upload-input').addEventListener('change', (e) => {
    for (const f of e.target.files) upload(f);
    e.target.value = '';
  });
}

// ---------------------------------------------------------------------------
// Result view.

const result = {id: null, depth: null, confidence: null, range: null, viewer: null, generation: 0};

function closeResult() {
  const id = openJobId;
  openJobId = null;
  result.id = null;
  $('result-panel').hidden = true;
  renderJobs();
  // Back to where the user came from: the job's own control, else the list.
  const back = [...$('job-list').querySelectorAll('button.open-result')]
    .find((b) => b.getAttribute('aria-label') === `Open the result of job ${id}`);
  if (back) back.focus();
}

const IMAGE_NAMES = {
  'reference-canvas': 'reference frame',
  'depth-canvas': 'depth map (colour scale below: far blue, near red)',
  'confidence-canvas': 'confidence of the depth (bright: confident)',
  'points-canvas': '3-D point cloud of the depth',
};

function fileUrl(job, name) {
  return (job.links && job.links.files || []).find((f) => f.endsWith(`/${name}`));
}

async function openResult(id) {
  const generation = ++result.generation;
  const stale = () => generation !== result.generation;
  openJobId = id;
  result.id = id;
  scheduleRender();
  const panel = $('result-panel');
  panel.hidden = false;
  panel.dataset.ready = '';
  $('result-id').textContent = id;
  $('result-summary').textContent = 'loading…';
  $('result-warnings').replaceChildren();
  $('downloads').replaceChildren();
  $('result-calibration').replaceChildren();
  $('hover-readout').textContent = 'hover over or touch an image to read the depth at a pixel';
  for (const c of ['reference-canvas', 'depth-canvas', 'confidence-canvas']) delete $(c).dataset.ready;
  for (const [canvas, name] of Object.entries(IMAGE_NAMES)) $(canvas).setAttribute('aria-label', `${name} of job ${id}`);
  // The heading below the sticky header (scroll-margin-top), and the focus
  // on it, so that keyboard and screen-reader users land on the result.
  $('result-heading').focus({preventScroll: true});
  $('result-heading').scrollIntoView({behavior: 'smooth', block: 'start'});
  let job, res;
  try {
    job = await getJson(`api/v1/jobs/${id}`);
    upsertJob(job);
    res = await getJson(fileUrl(job, 'result.json') || `api/v1/jobs/${id}/result.json`);
  } catch (e) {
    if (!stale()) $('result-summary').textContent = '';
    showError(`cannot open ${id}`, e);
    return;
  }
  if (stale()) return;
  result.res = res;
  renderSummary(job, res);
  renderDownloads(job);
  renderResultCalibration(res);
  const tasks = [
    loadReference(job, res, stale),
    loadDepth(job, res, stale, $('depth-source').value),
    loadConfidence(job, stale),
    loadPoints(job, stale),
  ];
  const outcomes = await Promise.allSettled(tasks);
  if (stale()) return;
  for (const o of outcomes) if (o.status === 'rejected') showError(`result ${id}`, o.reason);
  panel.dataset.ready = 'true';
}

function renderSummary(job, res) {
  const parts = [];
  // The verdict on the depth map as a whole: "unreliable" is a map likely flattened or inverted.
  if (res.depth_verdict && res.depth_verdict.quality) parts.push(`depth ${res.depth_verdict.quality}`);
  if (res.input) parts.push(`${res.input.frames} frames of ${res.input.width}x${res.input.height}`);
  // "frames": "auto": how many of the frames taken the motion needed, and why.
  if (res.auto_frames) parts.push(`kept ${res.auto_frames.frames} of ${res.auto_frames.of} frames (${res.auto_frames.reason})`);
  if (res.untracked_frames && res.untracked_frames.length)
    parts.push(`${res.untracked_frames.length} frame${res.untracked_frames.length > 1 ? 's' : ''} left out (lost by the tracker)`);
  // What the burst's motion gave: its parallax, and the precision of the focal length it measured.
  const parallax = res.parallax || {};
  if (typeof parallax.median_px === 'number')
    parts.push(`parallax ${num(parallax.median_px, 1)} px (rotation taken out)` +
      (parallax.relative_depth_sigma > 0 ? `, depth ± ${num(100 * parallax.relative_depth_sigma, 1)} % per track` : ''));
  const sigma = res.calibration && res.calibration.uncertainty && res.calibration.uncertainty.sigma_f_percent;
  if (typeof sigma === 'number') parts.push(`focal length ± ${num(sigma, 2)} %`);
  if (res.depth) parts.push(`${Math.round(100 * (res.depth.valid_fraction || 0))} % of pixels measured, ${res.depth.planes} planes`);
  if (res.depth_outputs && res.depth_outputs.points) parts.push(`${res.depth_outputs.points} points`);
  if (job.timings_ms && job.timings_ms.total) parts.push(`pipeline ${(job.timings_ms.total / 1000).toFixed(2)} s`);
  if (job.finished_ms) parts.push(`finished ${fmtTime(job.finished_ms)}`);
  $('result-summary').textContent = parts.join(' · ');
  const warnings = [...new Set([...(res.warnings || []), ...(job.warnings || [])])];
  $('result-warnings').replaceChildren(...warnings.map((w) => el('li', {}, w)));
}

function renderDownloads(job) {
  const files = [...(job.links && job.links.files || [])];
  if (job.links && job.links.burst) files.push(job.links.burst);
  const items = files.map((f) => {
    const name = f.split('/').pop();
    const a = el('a', {href: url(f), download: `${job.id}-${name}`, class: 'download'}, name);
    a.addEventListener('click', (e) => {
      if (!token()) return;  // a plain link works without a token
      e.preventDefault();    // with one, fetch it with the header and save the blob
      api(f).then((r) => r.blob()).then((blob) => {
        const tmp = el('a', {href: URL.createObjectURL(blob), download: `${job.id}-${name}`});
        document.body.append(tmp);
        tmp.click();
        tmp.remove();
        setTimeout(() => URL.revokeObjectURL(tmp.href), 10000);
      }).catch((err) => showError(`download of ${name}`, err));
    });
    return el('li', {}, a);
  });
  $('downloads').replaceChildren(...items);
}

const num = (v, digits = 2) => (typeof v === 'number' && isFinite(v) ? v.toFixed(digits) : '–');

function calibrationTable(cal, extra = {}) {
  const u = cal.uncertainty || {};
  const rows = [
    ['focal length', `${num(cal.fx, 1)} px` + (u.available !== false && u.sigma_f_px != null
      ? ` ± ${num(u.sigma_f_px, 1)} px (${num(u.sigma_f_percent ?? extra.sigma_f_percent, 2)} %)`
      : extra.sigma_f_percent != null && typeof cal.fx === 'number'
        ? ` ± ${num((cal.fx * extra.sigma_f_percent) / 100, 1)} px (${num(extra.sigma_f_percent, 2)} %)` : '')],
    ['principal point', `${num(cal.cx, 1)}, ${num(cal.cy, 1)} px`],
    ['k1', num(cal.k1, 4) + (u.sigma_k1 != null ? ` ± ${num(u.sigma_k1, 4)}` : extra.sigma_k1 != null ? ` ± ${num(extra.sigma_k1, 4)}` : '')],
    ['k2', num(cal.k2, 4) + (u.sigma_k2 != null ? ` ± ${num(u.sigma_k2, 4)}` : extra.sigma_k2 != null ? ` ± ${num(extra.sigma_k2, 4)}` : '')],
  ];
  const dsig = u.distortion_sigma_px ?? extra.distortion_sigma_px;
  if (dsig != null) rows.push(['distortion σ', `${num(dsig, 2)} px` + (u.distortion_sigma_max_px != null ? ` (max ${num(u.distortion_sigma_max_px, 2)} px)` : '')]);
  if (cal.width) rows.push(['image', `${cal.width}x${cal.height}${cal.distortion_model ? `, ${cal.distortion_model}` : ''}`]);
  if (cal.quality) rows.push(['quality', cal.quality]);
  if (cal.source) rows.push(['source', cal.source + (cal.known ? ` (known: ${cal.known})` : '')]);
  // The readout of a rolling shutter, in frame intervals (0: a global shutter).
  const shutter = cal.rolling_shutter;
  if (shutter) rows.push(['rolling shutter', shutter.mode === 'global' ? 'global (not modelled)'
    : `readout ${num(shutter.readout, 3)} of the frame interval (${shutter.mode === 'estimate' ? 'estimated' : 'known'})`
      + (shutter.sigma_readout != null ? `, σ ${num(shutter.sigma_readout, 3)}` : '')
      + (shutter.row_path === 'angular_velocity' ? '; each frame\'s rows turn at its own angular velocity' : '')]);
  for (const [k, v] of Object.entries(extra.rows || {})) rows.push([k, v]);
  const dl = el('dl', {class: 'kv'});
  for (const [k, v] of rows) dl.append(el('dt', {}, k), el('dd', {class: k === 'quality' ? `quality-${v}` : ''}, v));
  const reasons = (cal.quality_reasons || []).map((r) => el('li', {}, r));
  return el('div', {}, dl, reasons.length ? el('ul', {class: 'warnings'}, ...reasons) : null);
}

function renderResultCalibration(res) {
  const box = $('result-calibration');
  if (!res.calibration) { box.replaceChildren(el('p', {class: 'muted'}, 'no calibration in result.json')); return; }
  const rows = {};
  if (res.bundle_adjustment) rows['reprojection RMS'] = `${num(res.bundle_adjustment.rms_reprojection_px, 3)} px`;
  const fusion = res.calibration_fusion;
  // A sentence ("fused", "outlier: chi2 ...", "fusion off"), or an object in other versions.
  if (fusion) rows['fusion'] = typeof fusion === 'string' ? fusion
    : [fusion.outcome, fusion.reason].filter(Boolean).join(': ') || JSON.stringify(fusion);
  box.replaceChildren(calibrationTable(res.calibration, {rows}));
}

async function loadBitmap(path, crop, size) {
  const blob = await (await api(path)).blob();
  const resize = size ? {resizeWidth: size.w, resizeHeight: size.h, resizeQuality: 'high'} : {};
  return crop ? createImageBitmap(blob, crop.x, crop.y, crop.w, crop.h, resize)
              : createImageBitmap(blob, resize);
}

function drawBitmap(canvas, bitmap) {
  canvas.width = bitmap.width;
  canvas.height = bitmap.height;
  canvas.getContext('2d', {willReadFrequently: true}).drawImage(bitmap, 0, 0);
  canvas.dataset.ready = 'true';
}

async function loadReference(job, res, stale) {
  // preview.png is the reference frame beside the inverse depth: its left
  // half, scaled by depth_outputs.preview_scale; drawn back at the depth's size.
  const path = fileUrl(job, 'preview.png');
  if (!path) return;
  const w = res.input && res.input.width, h = res.input && res.input.height;
  const scale = (res.depth_outputs && res.depth_outputs.preview_scale) || 1;
  const crop = {x: 0, y: 0, w: Math.max(1, Math.round(w * scale)), h: Math.max(1, Math.round(h * scale))};
  const bitmap = await loadBitmap(path, w && h ? crop : null, w && h ? {w, h} : null);
  if (!stale()) drawBitmap($('reference-canvas'), bitmap);
}

async function loadConfidence(job, stale) {
  const path = fileUrl(job, 'confidence.png');
  if (!path) return;
  const bitmap = await loadBitmap(path);
  if (stale()) return;
  drawBitmap($('confidence-canvas'), bitmap);
  const ctx = $('confidence-canvas').getContext('2d', {willReadFrequently: true});
  result.confidence = ctx.getImageData(0, 0, bitmap.width, bitmap.height);
}

async function loadDepth(job, res, stale, which) {
  const path = fileUrl(job, which) || fileUrl(job, 'depth.tiff');
  if (!path) throw new Error('the job has no depth.tiff');
  const depth = await decodeFloatTiff(await (await api(path)).arrayBuffer());
  if (stale()) return;
  result.depth = depth;
  // The colour range: result.json's inverse-depth range (as preview.png), else the data's.
  let lo = res.depth && res.depth.min_inverse_depth, hi = res.depth && res.depth.max_inverse_depth;
  if (!(lo > 0 && hi > lo)) {
    lo = Infinity; hi = 0;
    for (const z of depth.data) if (z > 0 && isFinite(z)) { lo = Math.min(lo, 1 / z); hi = Math.max(hi, 1 / z); }
    if (!(hi > lo)) { lo = 0.5; hi = 1; }
  }
  result.range = {lo, hi};
  const canvas = $('depth-canvas');
  canvas.width = depth.width;
  canvas.height = depth.height;
  const ctx = canvas.getContext('2d');
  const image = ctx.createImageData(depth.width, depth.height);
  const px = image.data;
  for (let i = 0; i < depth.data.length; i++) {
    const z = depth.data[i];
    if (z > 0 && isFinite(z)) {
      const t = Math.round(255 * Math.min(1, Math.max(0, (1 / z - lo) / (hi - lo))));
      px[4 * i] = TURBO_LUT[3 * t];
      px[4 * i + 1] = TURBO_LUT[3 * t + 1];
      px[4 * i + 2] = TURBO_LUT[3 * t + 2];
    }
    px[4 * i + 3] = 255;
  }
  ctx.putImageData(image, 0, 0);
  canvas.dataset.ready = 'true';
  drawLegend(lo, hi);
}

function drawLegend(lo, hi) {
  // Left: far (blue), right: near (red); ticks in depth (1 / inverse depth).
  const canvas = $('legend-canvas');
  const ctx = canvas.getContext('2d');
  const img = ctx.createImageData(canvas.width, canvas.height);
  for (let x = 0; x < canvas.width; x++) {
    const t = Math.round((255 * x) / (canvas.width - 1));
    for (let y = 0; y < canvas.height; y++) {
      const p = 4 * (y * canvas.width + x);
      img.data.set([TURBO_LUT[3 * t], TURBO_LUT[3 * t + 1], TURBO_LUT[3 * t + 2], 255], p);
    }
  }
  ctx.putImageData(img, 0, 0);
  const ticks = [0, 0.25, 0.5, 0.75, 1].map((f) => {
    const z = 1 / (lo + f * (hi - lo));
    return el('span', {}, z >= 100 ? z.toFixed(0) : z >= 10 ? z.toFixed(1) : z.toFixed(2));
  });
  $('legend-ticks').replaceChildren(...ticks);
}

async function loadPoints(job, stale) {
  const placeholder = $('points-placeholder');
  const canvas = $('points-canvas');
  placeholder.hidden = false;
  placeholder.textContent = 'loading points.ply…';
  const path = fileUrl(job, 'points.ply');
  if (!path) { placeholder.textContent = 'this job has no points.ply'; return; }
  const [{PointViewer}, buffer] = await Promise.all([
    import('./viewer.js'),
    api(path).then((r) => r.arrayBuffer()),
  ]);
  if (stale()) return;
  const cloud = parsePly(buffer);
  $('points-info').textContent = `(${cloud.count.toLocaleString()} points)`;
  if (!cloud.count) { placeholder.textContent = 'points.ply holds no points'; return; }
  try {
    if (!result.viewer) result.viewer = new PointViewer(canvas);
  } catch (e) {
    placeholder.textContent = `no WebGL in this browser: ${e.message}`;
    throw e;
  }
  result.viewer.setCloud(cloud);
  placeholder.hidden = true;
}

// Hover: the depth (and confidence) at the pixel under the pointer, on any of
// the three images (they share the reference's pixel grid).
function bindHover() {
  for (const id of ['reference-canvas', 'depth-canvas', 'confidence-canvas']) {
    const canvas = $(id);
    canvas.addEventListener('pointermove', (e) => {
      const d = result.depth;
      if (!d) return;
      const rect = canvas.getBoundingClientRect();
      const x = Math.floor(((e.clientX - rect.left) / rect.width) * d.width);
      const y = Math.floor(((e.clientY - rect.top) / rect.height) * d.height);
      if (x < 0 || y < 0 || x >= d.width || y >= d.height) return;
      const z = d.data[y * d.width + x];
      let text = `x ${x}, y ${y}: `;
      text += z > 0 && isFinite(z) ? `depth ${z.toFixed(4)} (inverse ${(1 / z).toFixed(3)})` : 'no depth estimate';
      const c = result.confidence;
      if (c && c.width === d.width && c.height === d.height) text += `, confidence ${(c.data[4 * (y * c.width + x)] / 255).toFixed(2)}`;
      $('hover-readout').textContent = text;
    });
  }
  $('depth-source').addEventListener('change', async () => {
    if (!result.id) return;
    const job = jobs.get(result.id);
    const generation = result.generation;
    try {
      await loadDepth(job, result.res || {}, () => generation !== result.generation, $('depth-source').value);
    } catch (e) {
      showError('depth', e);
    }
  });
  $('result-close').addEventListener('click', closeResult);
}

// ---------------------------------------------------------------------------
// Calibration panel: GET /api/v1/calibration (current and fused with history).

let calibrationTimer = null;
function scheduleCalibration() {
  clearTimeout(calibrationTimer);
  calibrationTimer = setTimeout(loadCalibration, 300);
}

// A fusion's history entry in words (its reason, as the daemon logs it,
// stays in the row's tooltip).
function historyReason(h, gate) {
  const chi2 = typeof h.chi2 === 'number' ? `χ² ${num(h.chi2, 2)}` : '';
  const limit = typeof gate === 'number' ? `, limit ${num(gate, 1)}` : '';
  switch (h.outcome) {
    case 'started': return 'the first burst of the fusion';
    case 'fused': return `agrees with the fusion (${chi2}${limit})`;
    case 'outlier': return `disagrees with the fusion (${chi2}${limit}): left out`;
    case 'restarted-after-change': return 'agrees with the burst left out before it: the camera changed, the fusion restarted';
    default: return h.reason || '';
  }
}

async function loadCalibration() {
  const body = $('calibration-body');
  let cal;
  try {
    cal = await getJson('api/v1/calibration');
  } catch (e) {
    $('calibration-reset').hidden = true;
    body.replaceChildren(el('p', {class: 'muted'},
      `cannot read the calibration: ${e instanceof ApiError ? e.describe() : e.message}`));
    return;
  }
  const parts = [];
  if (!cal.calibration) parts.push(el('p', {class: 'muted'}, 'No calibration yet: it comes with the first job that succeeds.'));
  if (cal.calibration) {
    const rows = {};
    if (cal.rms_reprojection_px != null) rows['reprojection RMS'] = `${num(cal.rms_reprojection_px, 3)} px`;
    const current = el('div', {class: 'cal-block'},
      el('h3', {}, 'Current ', el('span', {class: 'muted'}, 'from job '),
         el('a', {href: '#', class: 'mono', onclick: (e) => { e.preventDefault(); openResult(cal.job); }}, cal.job || '?'),
         el('span', {class: 'muted'}, cal.finished_ms ? ` · ${new Date(cal.finished_ms).toLocaleString()}` : '')),
      calibrationTable(cal.calibration, {rows}));
    parts.push(current);
  }
  const f = cal.fused;
  if (f && !f.empty) {
    const counts = f.counts ? Object.entries(f.counts).map(([k, v]) => `${k} ${v}`).join(', ') : '';
    const rows = {
      bursts: String(f.bursts ?? '–'),
      reliable: f.reliable ? 'yes' : `not yet${(f.unreliable_reasons || []).length ? `: ${f.unreliable_reasons.join('; ')}` : ''}`,
    };
    if (counts) rows.outcomes = counts;
    const fused = el('div', {class: 'cal-block'},
      el('h3', {}, 'Fused ', el('span', {class: 'muted'}, `over ${f.bursts} burst${f.bursts === 1 ? '' : 's'}`)),
      calibrationTable(f.camera || {}, {sigma_f_percent: f.sigma_f_percent, sigma_k1: f.sigma_k1, sigma_k2: f.sigma_k2,
                                        distortion_sigma_px: f.distortion_sigma_px, rows}),
      (f.notes || []).length ? el('ul', {class: 'warnings'}, ...f.notes.map((n) => el('li', {}, String(n)))) : null);
    parts.push(fused);
    const history = [...(f.history || [])].reverse();
    if (history.length) {
      const head = el('tr', {}, ...['time', 'job', 'outcome', 'f (px)', 'σf (%)', 'χ²', 'fused f after', 'reason'].map((h) => el('th', {}, h)));
      const rowsEl = history.slice(0, 50).map((h) => el('tr', {class: `outcome-${h.outcome}`},
        el('td', {}, h.time_ms ? new Date(h.time_ms).toLocaleString() : ''),
        el('td', {class: 'mono'}, h.job || ''),
        el('td', {}, h.outcome || ''),
        el('td', {}, num(h.f, 1)),
        el('td', {}, num(h.sigma_f_percent, 2)),
        el('td', {}, h.chi2 == null ? '–' : num(h.chi2, 2)),
        el('td', {}, num(h.fused_f_after, 1)),
        el('td', {class: 'reason', title: h.reason || ''}, historyReason(h, f.consistency_gate_chi2))));
      parts.push(el('div', {class: 'cal-history'}, el('h3', {}, 'History ', el('span', {class: 'muted'}, 'newest first')),
        el('div', {class: 'table-wrap'}, el('table', {}, el('thead', {}, head), el('tbody', {}, ...rowsEl)))));
    }
    $('calibration-reset').hidden = false;
  } else {
    $('calibration-reset').hidden = true;
    parts.push(el('p', {class: 'muted'}, 'No fused calibration yet.'));
  }
  body.replaceChildren(...parts);
}

async function resetFusion() {
  if (!confirm('Forget the fused calibration (for a new camera or lens)? The history is kept.')) return;
  try {
    await api('api/v1/calibration', {method: 'DELETE'});
    message('fused calibration reset', 'notice');
  } catch (e) {
    showError('cannot reset the calibration', e);
  }
  loadCalibration();
}

// ---------------------------------------------------------------------------

function bindToken() {
  $('token-cancel').addEventListener('click', () => $('token-dialog').close('cancel'));
  $('token-forget').addEventListener('click', () => {
    sessionStorage.removeItem(TOKEN_KEY);
    $('token-dialog').close('cancel');
    message('token forgotten', 'notice');
  });
  $('token-form').addEventListener('submit', (e) => {
    e.preventDefault();
    $('token-dialog').close('ok');
  });
  $('token-button').addEventListener('click', () => askToken('Enter the token of this dfsmd.'));
  if (token()) $('token-button').hidden = false;
}

// The sticky header's height as a CSS variable: what scrolled-to headings keep clear of.
function trackHeaderHeight() {
  const bar = document.querySelector('header.bar');
  const set = () => document.documentElement.style.setProperty('--header-height', `${bar.offsetHeight}px`);
  new ResizeObserver(set).observe(bar);
  set();
}

function main() {
  trackHeaderHeight();
  bindLiveSettings();
  bindToken();
  bindDrop();
  bindHover();
  $('trigger-form').addEventListener('submit', trigger);
  $('trigger-auto').addEventListener('change', autoFramesToggled);
  $('calibration-reset').addEventListener('click', resetFusion);
  refreshJobs().catch((e) => setConnection(e.status === 401 ? 'needs token' : 'offline', 'bad'));
  loadCalibration();
  liveLoop();
  cameraLoop();
  eventsLoop();
}

main();

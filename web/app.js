// panelbass dashboard: engine status, chain settings, jobs with live progress, results with plots,
// and the model store — all through the HTTP API of `panelbass serve` (api/ROUTES.md).

import { api, FINISHED_STATES } from './api.js';
import { drawPlot, PLOT_ORDER } from './plots.js';

const STATUS_PERIOD_MS = 1000;
const JOBS_PERIOD_MS = 2000;
const MODELS_PERIOD_MS = 5000;
const CONFIG_PERIOD_MS = 5000;
const JOB_POLL_MS = 700;

const $ = (selector, root = document) => root.querySelector(selector);
const $$ = (selector, root = document) => Array.from(root.querySelectorAll(selector));

const state = {
  status: null,
  activeKey: '',      // the active models last seen, to refresh what depends on them when they change
  models: [],
  jobs: [],
  config: null,
  configDirty: false,
  selected: null,     // id of the job shown in the result panel
  selectedJob: null,  // its last known record
  follow: null,       // {id, source: EventSource|null, timer}
  renderedResult: null,
  plots: [],
};

// ---------------------------------------------------------------------------------------------
// Small helpers

/** Creates an element: el('td', {class: 'mono'}, 'text', child, …). */
function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null || v === false) continue;
    if (k === 'class') node.className = v;
    else if (k === 'dataset') Object.assign(node.dataset, v);
    else if (k.startsWith('on')) node.addEventListener(k.slice(2), v);
    else node.setAttribute(k, v === true ? '' : v);
  }
  for (const c of children) if (c !== null && c !== undefined) node.append(c);
  return node;
}

function setText(selector, text) {
  const node = $(selector);
  if (node && node.textContent !== String(text)) node.textContent = String(text);
}

function showMessage(selector, text) {
  const node = $(selector);
  node.textContent = text || '';
  node.hidden = !text;
}

const errorText = (e) => (e && typeof e.toString === 'function' ? e.toString() : String(e));

const get = (obj, path) => path.split('.').reduce((o, k) => (o == null ? undefined : o[k]), obj);

function setPath(obj, path, value) {
  const keys = path.split('.');
  let o = obj;
  for (const k of keys.slice(0, -1)) o = o[k] ??= {};
  o[keys[keys.length - 1]] = value;
}

const num = (v) => typeof v === 'number' && Number.isFinite(v);

function fmtNumber(v, digits = 3) {
  if (!num(v)) return v == null ? '—' : String(v);
  if (Number.isInteger(v)) return v.toLocaleString('en-US');
  const a = Math.abs(v);
  if (a !== 0 && (a < 1e-3 || a >= 1e6)) return v.toExponential(2);
  return v.toPrecision(digits + (a >= 1 ? Math.floor(Math.log10(a)) : 0)).replace(/\.?0+$/, '');
}

const fmtPct = (v) => (num(v) ? `${v < 0.1 && v !== 0 ? v.toPrecision(2) : v.toFixed(2)} %` : '—');

function fmtNs(ns) {
  if (!num(ns)) return '—';
  if (ns < 1e3) return `${ns.toFixed(0)} ns`;
  if (ns < 1e6) return `${(ns / 1e3).toFixed(1)} µs`;
  return `${(ns / 1e6).toFixed(2)} ms`;
}

function fmtDuration(s) {
  if (!num(s)) return '—';
  const t = Math.floor(s);
  const h = Math.floor(t / 3600), m = Math.floor((t % 3600) / 60), sec = t % 60;
  const two = (x) => String(x).padStart(2, '0');
  return h ? `${h}:${two(m)}:${two(sec)}` : `${m}:${two(sec)}`;
}

/** ISO 8601 (or epoch seconds) → local "HH:MM:SS", with the date when it is not today. */
function fmtTime(t) {
  if (t === null || t === undefined || t === '') return '—';
  const d = typeof t === 'number' ? new Date(t < 1e12 ? t * 1000 : t) : new Date(t);
  if (Number.isNaN(d.getTime())) return String(t);
  const two = (x) => String(x).padStart(2, '0');
  const time = `${two(d.getHours())}:${two(d.getMinutes())}:${two(d.getSeconds())}`;
  const now = new Date();
  if (d.toDateString() === now.toDateString()) return time;
  return `${d.getFullYear()}-${two(d.getMonth() + 1)}-${two(d.getDate())} ${time}`;
}

function modelLabel(id) {
  if (!id) return '—';
  const m = state.models.find((x) => x.id === id);
  return m && m.name ? `${id} · ${m.name}` : id;
}

/** Runs `fn` now and then every `period` ms after it finished (never two at once). */
function every(period, fn) {
  const tick = async () => {
    try {
      await fn();
    } finally {
      setTimeout(tick, period);
    }
  };
  tick();
}

/** Keeps a table body's rows in step with `items` (keyed by `key`), creating and updating rows in place. */
function syncRows(tbody, items, key, create, update) {
  const existing = new Map($$('tr', tbody).map((tr) => [tr.dataset.key, tr]));
  let previous = null;
  for (const item of items) {
    const k = key(item);
    let tr = existing.get(k);
    if (!tr) {
      tr = create(item);
      tr.dataset.key = k;
    }
    existing.delete(k);
    update(tr, item);
    const wanted = previous ? previous.nextSibling : tbody.firstChild;
    if (wanted !== tr) tbody.insertBefore(tr, wanted);
    previous = tr;
  }
  for (const tr of existing.values()) tr.remove();
}

/** A button that asks for a second click within 3 s before it does `action`. */
function confirmButton(label, action) {
  const button = el('button', { type: 'button', class: 'danger small' }, label);
  let armed = null;
  button.addEventListener('click', async () => {
    if (!armed) {
      button.textContent = 'Sure?';
      armed = setTimeout(() => { armed = null; button.textContent = label; }, 3000);
      return;
    }
    clearTimeout(armed);
    armed = null;
    button.textContent = label;
    await action();
  });
  return button;
}

// ---------------------------------------------------------------------------------------------
// Engine status (every second)

async function pollStatus() {
  let status, health;
  try {
    [status, health] = await Promise.all([api.status(), api.health()]);
  } catch (e) {
    const conn = $('#conn');
    conn.dataset.state = 'offline';
    conn.textContent = 'offline';
    conn.title = errorText(e);
    $('#status-panel').classList.add('stale');
    return;
  }
  const conn = $('#conn');
  conn.dataset.state = health?.status === 'ok' ? 'online' : 'degraded';
  conn.textContent = health?.status === 'ok' ? 'online' : `health: ${health?.status ?? '?'}`;
  conn.title = '';
  setText('#version', health?.version ? `v${health.version}` : '');
  $('#status-panel').classList.remove('stale');
  state.status = status;
  renderStatus(status);
}

function renderStatus(st) {
  const engine = st.engine || {};
  const m = st.metrics || {};
  const badge = $('#status-state');
  badge.dataset.state = engine.state || '';
  setText('#status-state', engine.state || '—');
  setText('#status-backend', engine.backend ?? '—');
  setText('#status-plant', engine.plant || '—');
  setText('#status-fs', num(engine.fs) ? `${engine.fs} Hz` : '—');
  const blockMs = num(engine.block) && num(engine.fs) ? (1e3 * engine.block) / engine.fs : null;
  setText('#status-block', num(engine.block) ? `${engine.block} samples${blockMs ? ` (${blockMs.toFixed(2)} ms)` : ''}` : '—');
  setText('#status-uptime', fmtDuration(engine.uptime_s));

  const load = m.load;
  setText('#status-load', num(load) ? `${(100 * load).toFixed(1)} %` : '—');
  $('#status-load-meter').value = num(load) ? Math.min(1, Math.max(0, load)) : 0;
  const budget = blockMs ? blockMs * 1e6 : null;
  setText('#status-p99', num(m.p99_block_ns)
    ? `${fmtNs(m.p99_block_ns)}${budget ? ` (${((100 * m.p99_block_ns) / budget).toFixed(1)} % of the block)` : ''}`
    : '—');
  setText('#status-mean', num(m.mean_block_ns) ? `${fmtNs(m.mean_block_ns)} · max ${fmtNs(m.max_block_ns)}` : '—');
  setText('#status-xruns', fmtNumber(m.xruns));
  $('#status-xruns').classList.toggle('warn', num(m.xruns) && m.xruns > 0);
  setText('#status-faults', fmtNumber(m.faults));
  $('#status-faults').classList.toggle('warn', num(m.faults) && m.faults > 0);
  setText('#status-last-fault', m.last_fault || '—');
  setText('#status-swaps', fmtNumber(m.swaps));
  const jobs = st.jobs || {};
  setText('#status-jobs', `${jobs.running ?? 0} running, ${jobs.queued ?? 0} queued`);
  $('#status-in-fault').hidden = !m.in_fault;
  $('#status-panel').classList.toggle('in-fault', !!m.in_fault);

  const active = st.active_models || {};
  for (const slot of ['feedforward', 'feedback']) {
    const node = $(`#active-${slot}`);
    node.dataset.modelId = active[slot] || '';
    setText(`#active-${slot}`, modelLabel(active[slot]));
  }
  const key = JSON.stringify(active);
  if (key !== state.activeKey) {
    const first = state.activeKey === '';
    state.activeKey = key;
    if (!first) {
      refreshModels();
      if (!state.configDirty) loadConfig();
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Chain settings

const configFields = () => $$('#config-form [name]');

function fillConfigForm(config) {
  for (const field of configFields()) {
    const v = get(config, field.name);
    if (field.type === 'checkbox') field.checked = !!v;
    else field.value = v ?? '';
  }
  setText('#config-ff-model', modelLabel(config.feedforward?.model));
  setText('#config-fb-model', modelLabel(config.feedback?.model));
  setText('#config-fixed', `fs ${config.fs ?? '—'} Hz · block ${config.block ?? '—'} · history ${config.history ?? '—'} (fixed while running)`);
}

async function loadConfig() {
  try {
    const config = await api.config();
    state.config = config;
    if (!state.configDirty) fillConfigForm(config);
    else {
      setText('#config-ff-model', modelLabel(config.feedforward?.model));
      setText('#config-fb-model', modelLabel(config.feedback?.model));
    }
  } catch (e) {
    showMessage('#config-error', `cannot read the settings: ${errorText(e)}`);
  }
}

/** The merge patch of the fields that differ from the loaded settings; throws on a malformed number. */
function configPatch() {
  const patch = {};
  for (const field of configFields()) {
    let v;
    if (field.type === 'checkbox') v = field.checked;
    else if (field.type === 'number') {
      if (field.value.trim() === '') throw new Error(`${field.name}: a number is needed`);
      v = Number(field.value);
      if (!Number.isFinite(v)) throw new Error(`${field.name}: not a number`);
    } else v = field.value;
    if (v !== get(state.config, field.name)) setPath(patch, field.name, v);
  }
  return patch;
}

function setConfigDirty(dirty) {
  state.configDirty = dirty;
  $('#config-dirty').hidden = !dirty;
}

async function applyConfig(event) {
  event.preventDefault();
  showMessage('#config-error', '');
  showMessage('#config-result', '');
  if (!state.config) return;
  let patch;
  try {
    patch = configPatch();
  } catch (e) {
    showMessage('#config-error', e.message);
    return;
  }
  if (Object.keys(patch).length === 0) {
    showMessage('#config-result', 'nothing changed');
    setConfigDirty(false);
    return;
  }
  const button = $('#config-apply');
  button.disabled = true;
  try {
    const res = await api.patchConfig(patch);
    state.config = res.config;
    setConfigDirty(false);
    fillConfigForm(res.config);
    const change = res.change || {};
    const keys = (change.keys || []).join(', ');
    showMessage('#config-result', `applied — ${change.kind || 'ok'}${keys ? `: ${keys}` : ''}`);
  } catch (e) {
    showMessage('#config-error', errorText(e));
  } finally {
    button.disabled = false;
  }
}

// ---------------------------------------------------------------------------------------------
// Models

async function refreshModels() {
  try {
    const res = await api.models();
    state.models = res.models || [];
    renderModels();
  } catch (e) {
    showMessage('#models-error', `cannot list the models: ${errorText(e)}`);
  }
}

async function activate(id, resultNode) {
  try {
    const res = await api.activateModel(id);
    if (resultNode) resultNode.textContent = `active in ${res.slot}`;
    showMessage('#models-error', '');
    showMessage('#result-activate-error', '');
    pollStatus();
    refreshModels();
    return res;
  } catch (e) {
    const where = resultNode ? '#result-activate-error' : '#models-error';
    showMessage(where, `activate ${id}: ${errorText(e)}`);
    return null;
  }
}

function renderModels() {
  const models = [...state.models].sort((a, b) => String(b.created).localeCompare(String(a.created)));
  $('#models-empty').hidden = models.length > 0;
  syncRows($('#models-table tbody'), models, (m) => m.id,
    (m) => {
      const tr = el('tr', { dataset: { modelId: m.id } });
      tr.append(el('td', { class: 'mono' }, m.id), el('td'), el('td'), el('td', { class: 'num' }), el('td'),
                el('td', { class: 'mono' }), el('td'));
      const activateButton = el('button', { type: 'button', class: 'small activate' }, 'Activate');
      activateButton.addEventListener('click', () => activate(m.id, null));
      const del = confirmButton('Delete', async () => {
        try {
          await api.deleteModel(m.id);
          showMessage('#models-error', '');
          refreshModels();
        } catch (e) {
          showMessage('#models-error', `delete ${m.id}: ${errorText(e)}`);
        }
      });
      del.classList.add('delete');
      tr.append(el('td', { class: 'buttons' }, activateButton, del));
      return tr;
    },
    (tr, m) => {
      const cells = tr.children;
      cells[1].textContent = m.kind ?? '';
      cells[2].textContent = m.name ?? '';
      cells[3].textContent = num(m.fs) ? String(m.fs) : '';
      cells[4].textContent = fmtTime(m.created);
      cells[5].textContent = m.source ?? '';
      const slots = m.active_in || [];
      cells[6].replaceChildren(...slots.map((s) => el('span', { class: 'badge active' }, s)));
      tr.classList.toggle('is-active', slots.length > 0);
      tr.dataset.activeIn = slots.join(' ');
    });
  fillModelSelects();
  // The result panel's activate button follows the store (the model may have been activated elsewhere).
  if (state.selectedJob) renderActivated(state.selectedJob);
}

function fillModelSelects() {
  for (const select of $$('#job-form select[data-model-kinds]')) {
    const kinds = select.dataset.modelKinds.split(' ');
    const fits = state.models.filter((m) => kinds.includes('*') || kinds.includes(m.kind));
    const current = select.value;
    const options = [el('option', { value: '' }, select.hasAttribute('data-optional') ? '(none)' : fits.length ? '— choose —' : '(no model of this kind)')];
    for (const m of fits) options.push(el('option', { value: m.id }, `${m.id}${m.name ? ` · ${m.name}` : ''} (${m.kind})`));
    const signature = options.map((o) => o.value + o.textContent).join('|');
    if (select.dataset.signature !== signature) {
      select.replaceChildren(...options);
      select.dataset.signature = signature;
      select.value = fits.some((m) => m.id === current) ? current : '';
    }
  }
  updatePreview();
}

async function uploadModel(event) {
  event.preventDefault();
  showMessage('#upload-error', '');
  showMessage('#upload-result', '');
  const file = $('#upload-file').files[0];
  if (!file) {
    showMessage('#upload-error', 'choose a model file first');
    return;
  }
  const text = await file.text();
  try {
    JSON.parse(text);
  } catch (e) {
    showMessage('#upload-error', `${file.name}: not JSON (${e.message})`);
    return;
  }
  const name = $('#upload-name').value.trim() || file.name.replace(/\.json$/i, '');
  try {
    const res = await api.uploadModel(text, name);
    showMessage('#upload-result', `stored ${res.id} (${res.kind}${res.name ? `, ${res.name}` : ''})`);
    $('#upload-form').reset();
    refreshModels();
  } catch (e) {
    showMessage('#upload-error', `${file.name}: ${errorText(e)}`);
  }
}

// ---------------------------------------------------------------------------------------------
// Starting jobs

const kindsOf = (node) => (node?.dataset.kinds || '').split(' ');
const usesSource = (kind) => kindsOf($('#job-source').closest('[data-kinds]')).includes(kind);

/** One form field's value for the params, or undefined when it is left empty (the server's default). */
function readParam(input) {
  if (input.dataset.type === 'bool') return input.checked ? true : undefined;
  const raw = input.value.trim();
  if (raw === '') return undefined;
  const name = input.dataset.param;
  const ints = (s) => s.split(/[\s,;:]+|(?<=\d)-(?=\d)/).filter(Boolean).map((x) => {
    const v = Number(x);
    if (!Number.isInteger(v)) throw new Error(`${name}: "${x}" is not an integer`);
    return v;
  });
  switch (input.dataset.type) {
    case 'int': {
      const v = Number(raw);
      if (!Number.isInteger(v)) throw new Error(`${name}: must be an integer, got "${raw}"`);
      return v;
    }
    case 'float': {
      const v = Number(raw);
      if (!Number.isFinite(v)) throw new Error(`${name}: must be a number, got "${raw}"`);
      return v;
    }
    case 'intlist': return ints(raw);
    case 'floatlist': return raw.split(/[\s,;]+/).filter(Boolean).map((x) => {
      const v = Number(x);
      if (!Number.isFinite(v)) throw new Error(`${name}: "${x}" is not a number`);
      return v;
    });
    case 'strlist': return raw.split(/[\s,]+/).filter(Boolean);
    case 'range': {
      const v = ints(raw);
      if (v.length !== 2) throw new Error(`${name}: give two orders, e.g. 2-12`);
      return v;
    }
    default: return raw;
  }
}

/** {kind, params} from the job form; throws an Error naming the field on malformed input. */
function collectJob() {
  const kind = $('#job-kind').value;
  const source = usesSource(kind) ? $('#job-source').value : '';
  const params = {};
  for (const fieldset of $$('#job-form fieldset')) {
    if (!kindsOf(fieldset).includes(kind)) continue;
    const excite = fieldset.id === 'fs-excite';
    if (excite && kind !== 'excite' && source) continue;
    const target = excite && kind !== 'excite' ? (params.excite = {}) : params;
    for (const input of $$('[data-param]', fieldset)) {
      const owner = input.closest('[data-kinds]');
      if (owner !== fieldset && !kindsOf(owner).includes(kind)) continue;
      const v = readParam(input);
      if (v !== undefined) setPath(target, input.dataset.param, v);
    }
  }
  if (params.excite && Object.keys(params.excite).length === 0) delete params.excite;
  if (source) params.record = source;
  return { kind, params };
}

function updateJobForm() {
  const kind = $('#job-kind').value;
  const source = $('#job-source').value;
  for (const node of $$('#job-form [data-kinds]')) {
    let show = kindsOf(node).includes(kind);
    if (node.id === 'fs-excite' && kind !== 'excite' && source) show = false;
    node.hidden = !show;
  }
  updatePreview();
}

function updatePreview() {
  try {
    const { kind, params } = collectJob();
    const body = { kind, params };
    if (!$('#job-activate').closest('[data-kinds]').hidden && $('#job-activate').checked) body.activate = true;
    setText('#job-params-preview', JSON.stringify(body, null, 2));
  } catch (e) {
    setText('#job-params-preview', e.message);
  }
}

async function startJob(event) {
  event.preventDefault();
  showMessage('#job-error', '');
  let job;
  try {
    job = collectJob();
  } catch (e) {
    showMessage('#job-error', e.message);
    return;
  }
  const activateBox = $('#job-activate');
  const activate = !activateBox.closest('[data-kinds]').hidden && activateBox.checked;
  const button = $('#job-start');
  button.disabled = true;
  try {
    const res = await api.startJob(job.kind, job.params, activate);
    await refreshJobs();
    selectJob(res.id);
  } catch (e) {
    showMessage('#job-error', errorText(e));
  } finally {
    button.disabled = false;
  }
}

// ---------------------------------------------------------------------------------------------
// Jobs list

const jobNumber = (id) => Number(String(id).replace(/^\D+/, '')) || 0;

async function refreshJobs() {
  try {
    const res = await api.jobs();
    state.jobs = (res.jobs || []).sort((a, b) => jobNumber(b.id) - jobNumber(a.id));
    renderJobs();
  } catch (e) {
    /* the status badge already says the server is unreachable */
  }
}

function progressCell() {
  return el('td', { class: 'progress-cell' }, el('progress', { max: 1, value: 0 }), el('span', { class: 'mono' }));
}

function renderJobs() {
  $('#jobs-empty').hidden = state.jobs.length > 0;
  syncRows($('#jobs-table tbody'), state.jobs, (j) => j.id,
    (j) => {
      const tr = el('tr', { class: 'clickable', dataset: { jobId: j.id } });
      tr.append(el('td', { class: 'mono' }, j.id), el('td', {}, j.kind), el('td'), progressCell(), el('td', { class: 'message' }),
                el('td'), el('td'), el('td', { class: 'buttons' }));
      tr.addEventListener('click', (e) => {
        if (!e.target.closest('button')) selectJob(j.id);
      });
      return tr;
    },
    (tr, j) => {
      const c = tr.children;
      c[2].replaceChildren(el('span', { class: 'badge', dataset: { state: j.state } }, j.state));
      c[3].firstChild.value = num(j.progress) ? j.progress : 0;
      c[3].lastChild.textContent = num(j.progress) ? `${Math.round(100 * j.progress)} %` : '';
      c[4].textContent = j.state === 'failed' && j.error ? j.error : j.message || '';
      c[4].title = c[4].textContent;
      c[5].textContent = fmtTime(j.created);
      c[6].textContent = fmtTime(j.finished);
      tr.dataset.state = j.state;
      tr.classList.toggle('selected', j.id === state.selected);
      const running = !FINISHED_STATES.has(j.state);
      if (running !== (c[7].childElementCount > 0)) {
        c[7].replaceChildren(...(running ? [el('button', { type: 'button', class: 'danger small cancel', onclick: () => cancelJob(j.id) }, 'Cancel')] : []));
      }
    });
  // Finished excite jobs are records the identify/analyze/diagnose kinds can reuse.
  const select = $('#job-source');
  const records = state.jobs.filter((j) => j.kind === 'excite' && j.state === 'succeeded');
  const signature = records.map((j) => j.id).join(',');
  if (select.dataset.signature !== signature) {
    const current = select.value;
    select.replaceChildren(el('option', { value: '' }, 'new excitation'),
      ...records.map((j) => el('option', { value: j.id }, `record of ${j.id} (${fmtTime(j.finished)})`)));
    select.dataset.signature = signature;
    select.value = records.some((j) => j.id === current) ? current : '';
    updateJobForm();
  }
}

async function cancelJob(id) {
  try {
    await api.cancelJob(id);
  } catch (e) {
    showMessage('#job-error', `cancel ${id}: ${errorText(e)}`);
  }
  refreshJobs();
  if (id === state.selected) loadSelected();
}

// ---------------------------------------------------------------------------------------------
// The selected job: progress (event stream, else polling), then its result

function stopFollowing() {
  const f = state.follow;
  if (!f) return;
  if (f.source) f.source.close();
  clearTimeout(f.timer);
  state.follow = null;
}

function selectJob(id) {
  if (state.selected !== id) {
    stopFollowing();
    state.selected = id;
    state.selectedJob = null;
    state.renderedResult = null;
    clearPlots();
    const panel = $('#result');
    panel.hidden = false;
    panel.dataset.jobId = id;
    panel.dataset.state = '';
    setText('#result-id', id);
    setText('#result-kind', '');
    $('#result-body').hidden = true;
    showMessage('#result-error', '');
    showMessage('#result-activate-error', '');
    setProgress(0, '');
    for (const tr of $$('#jobs-table tbody tr')) tr.classList.toggle('selected', tr.dataset.jobId === id);
  }
  loadSelected().then((job) => {
    if (job && !FINISHED_STATES.has(job.state) && state.selected === id) follow(id);
  });
}

async function loadSelected() {
  const id = state.selected;
  if (!id) return null;
  try {
    const job = await api.job(id);
    if (state.selected !== id) return null;
    renderJob(job);
    return job;
  } catch (e) {
    if (state.selected === id) showMessage('#result-error', `cannot read ${id}: ${errorText(e)}`);
    return null;
  }
}

/** Follows a running job through its event stream; falls back to polling if the stream fails. */
function follow(id) {
  stopFollowing();
  const f = { id, source: null, timer: null };
  state.follow = f;
  const poll = async () => {
    if (state.follow !== f) return;
    const job = await loadSelected();
    if (state.follow !== f) return;
    if (job && FINISHED_STATES.has(job.state)) {
      stopFollowing();
      refreshJobs();
      return;
    }
    f.timer = setTimeout(poll, JOB_POLL_MS);
  };
  if (typeof EventSource !== 'function') {
    $('#result').dataset.transport = 'polling';
    poll();
    return;
  }
  const source = new EventSource(api.jobEventsUrl(id));
  f.source = source;
  $('#result').dataset.transport = 'events';
  source.addEventListener('progress', (e) => {
    if (state.follow !== f) return;
    try {
      const d = JSON.parse(e.data);
      setProgress(d.progress, d.message);
    } catch { /* a malformed event is skipped */ }
  });
  source.addEventListener('state', async (e) => {
    if (state.follow !== f) return;
    let d = {};
    try {
      d = JSON.parse(e.data);
    } catch { /* ignored */ }
    if (d.state) setState(d.state);
    if (FINISHED_STATES.has(d.state)) {
      source.close();
      stopFollowing();
      await loadSelected();
      refreshJobs();
    }
  });
  source.onerror = () => {
    // The stream failed or ended before a final state: poll instead.
    if (state.follow !== f) return;
    source.close();
    f.source = null;
    $('#result').dataset.transport = 'polling';
    poll();
  };
}

function setProgress(fraction, message) {
  const p = num(fraction) ? Math.min(1, Math.max(0, fraction)) : 0;
  $('#job-progress').value = p;
  setText('#job-progress-pct', `${Math.round(100 * p)} %`);
  if (message !== undefined) setText('#job-message', message || '');
  $('#result').dataset.progress = String(p);
}

function setState(jobState) {
  const badge = $('#result-state');
  badge.dataset.state = jobState;
  badge.textContent = jobState;
  $('#result').dataset.state = jobState;
  $('#job-cancel').hidden = FINISHED_STATES.has(jobState);
}

function renderJob(job) {
  state.selectedJob = job;
  setText('#result-kind', job.kind || '');
  setState(job.state);
  setProgress(job.state === 'succeeded' ? 1 : job.progress, job.message);
  showMessage('#result-error', job.state === 'failed' ? `failed: ${job.error || job.message || 'no reason given'}`
    : job.state === 'cancelled' ? 'cancelled' : '');
  if (job.state === 'succeeded' && job.result && state.renderedResult !== job.id) {
    state.renderedResult = job.id;
    renderResult(job);
  }
  renderActivated(job);
}

function clearPlots() {
  for (const p of state.plots) p.dispose();
  state.plots = [];
  $('#plots').replaceChildren();
}

function flatten(obj, prefix = '', out = []) {
  for (const [k, v] of Object.entries(obj || {})) {
    const key = prefix ? `${prefix}.${k}` : k;
    if (v && typeof v === 'object' && !Array.isArray(v)) flatten(v, key, out);
    else out.push([key, v]);
  }
  return out;
}

/** A summary value: numbers to 4 digits, [re, im] pairs (poles, zeros) as complex numbers, long lists cut;
 *  null (a non-finite figure, e.g. a restart's J_c) as "—", in a list too. */
function fmtValue(v) {
  if (v === null || v === undefined) return '—';
  if (typeof v === 'number') return fmtNumber(v, 4);
  if (!Array.isArray(v)) return String(v);
  const item = (x) => {
    if (x === null || x === undefined) return '—';
    if (Array.isArray(x) && x.length === 2 && x.every(num)) {
      const [re, im] = x;
      return im === 0 ? fmtNumber(re, 4) : `${fmtNumber(re, 4)}${im < 0 ? '−' : '+'}${fmtNumber(Math.abs(im), 4)}j`;
    }
    return Array.isArray(x) ? `[${x.map(item).join(', ')}]` : typeof x === 'number' ? fmtNumber(x, 4) : String(x);
  };
  const shown = v.slice(0, 16).map(item).join(', ');
  return v.length > 16 ? `[${shown}, … ${v.length} values]` : `[${shown}]`;
}

/** "linear · oe, na 8 nb 8 nk 1 (identified)" from a diagnose result's baseline. */
function baselineLabel(b) {
  if (!b) return '—';
  const orders = ['na', 'nb', 'nk'].filter((k) => num(b[k])).map((k) => `${k} ${b[k]}`).join(' ');
  const method = [b.method, orders].filter(Boolean).join(', ');
  return `${b.kind || 'model'}${method ? ` · ${method}` : ''}${b.source ? ` (${b.source})` : ''}`;
}

/** Plain sentences on where the baseline's validation residual lies (the report's location.validation). */
function locationSentences(l) {
  if (!l) return [];
  const out = [];
  const f = l.frf_error || {};
  out.push(f.significant
    ? `Frequency: the input explains part of the residual from ${fmtNumber(f.band_low_hz, 4)} to ${fmtNumber(f.band_high_hz, 4)} Hz `
      + `(most at ${fmtNumber(f.frequency_hz, 4)} Hz, the response off by ${fmtNumber(f.relative_db, 3)} dB there): a linear error.`
    : 'Frequency: the input explains none of the residual beyond noise (no FRF error).');
  if (num(l.peak_over_noise) && num(l.peak_threshold)) {
    out.push(l.peak_over_noise > l.peak_threshold
      ? `The residual's spectrum peaks at ${fmtNumber(l.peak_frequency_hz, 4)} Hz, ${fmtNumber(l.peak_over_noise, 3)} × its noise level.`
      : 'The residual\'s spectrum stays within its noise level at every bin.');
  }
  const d = l.distortion || {};
  if (d.periodic) {
    const db = (x) => (num(x) ? `${fmtNumber(x, 3)} dB` : 'n/a');
    out.push(d.odd_lines_only
      ? `Periodic input (${d.period} samples, ${d.periods} periods judged): at the empty lines the residual is ${db(d.residual_odd_db)} `
        + `(odd) and ${db(d.residual_even_db)} (even) over the noise; ${d.threshold_db} dB counts as distortion.`
      : `Periodic input (${d.period} samples), but with even lines excited: odd and even distortion cannot be told apart.`);
  }
  const states = Array.isArray(l.states) ? l.states : [];
  const shaped = states.filter((p) => num(p.shape_chi2)).sort((a, b) => b.shape_chi2 - a.shape_chi2)[0];
  if (shaped) {
    out.push(shaped.shape_chi2 > 3
      ? `State: the residual depends most on the ${shaped.state} (its bin means ${fmtNumber(shaped.shape_chi2, 3)} × what noise gives).`
      : 'State: the residual does not depend on the input, the output or its integrals beyond noise.');
  }
  const directed = states.filter((p) => num(p.direction_t)).sort((a, b) => Math.abs(b.direction_t) - Math.abs(a.direction_t))[0];
  if (directed && Math.abs(directed.direction_t) > 4) {
    out.push(`Direction: the residual differs between a rising and a falling ${directed.state} (${fmtNumber(directed.direction_t, 3)} standard errors).`);
  }
  if (num(l.change_t)) {
    out.push(Math.abs(l.change_t) > 4
      ? `Time: the residual's level changes × ${fmtNumber(l.change_ratio, 3)} at ${fmtNumber(l.change_time_s, 4)} s.`
      : 'Time: the residual\'s level holds steady through the record.');
  }
  return out;
}

/** A diagnose job's own view: baseline, J before and after, the findings, final J against the noise floor. */
function renderDiagnosis(r) {
  const baseline = r.baseline || {};
  setText('#diag-baseline', baselineLabel(baseline));
  setText('#diag-j-before', fmtPct(baseline.J_val_pct ?? r.J_val_before_pct));
  setText('#diag-j-after', fmtPct(r.J_val_after_pct));
  setText('#diag-noise-floor', fmtPct(r.noise_floor_pct));
  const ratio = num(r.J_val_after_pct) && num(r.noise_floor_pct) && r.noise_floor_pct > 0
    ? r.J_val_after_pct / r.noise_floor_pct : null;
  setText('#diag-verdict', ratio === null ? ''
    : ratio < 1.1 ? 'The final model is at the noise floor: what is left of the residual is noise.'
    : `The final model's J is ${fmtNumber(ratio, 2)} × the noise floor: ${fmtPct(r.J_val_after_pct - r.noise_floor_pct)} is still unexplained.`);
  const findings = Array.isArray(r.findings) ? r.findings : [];
  $('#diag-findings tbody').replaceChildren(...findings.map((f, i) => el('tr', { dataset: { effect: f.effect } },
    el('td', { class: 'num' }, String(i + 1)),
    el('td', { class: 'mono' }, f.effect ?? '—'),
    el('td', { class: 'explanation' }, f.explanation ?? ''),
    el('td', { class: 'j' }, `${fmtPct(f.J_val_before_pct)} → ${fmtPct(f.J_val_after_pct)}`))));
  $('#diag-findings').hidden = findings.length === 0;
  $('#diag-no-findings').hidden = findings.length > 0;
  const where = locationSentences(r.location && r.location.validation);
  $('#diag-location').replaceChildren(...where.map((text) => el('li', {}, text)));
  $('#diag-location-box').hidden = where.length === 0;
}

function renderResult(job) {
  const r = job.result;
  const diagnosis = job.kind === 'diagnose';
  $('#result-body').hidden = false;
  $('#result-figures').hidden = diagnosis;
  $('#result-diagnosis').hidden = !diagnosis;
  if (diagnosis) renderDiagnosis(r);
  setText('#result-j-est', fmtPct(r.j_est_pct));
  setText('#result-j-val', fmtPct(r.j_val_pct));
  // A result without J figures (a recording, an evaluation: its J_c per row is in the summary) shows none.
  const noJ = r.j_est_pct == null && r.j_val_pct == null;
  for (const id of ['#result-j-est', '#result-j-val']) $(id).closest('.figure').hidden = noJ;
  const box = $('#result-model-box');
  box.hidden = !r.model_id;
  setText('#result-model', r.model_id ? modelLabel(r.model_id) : '—');
  $('#result-activate').dataset.modelId = r.model_id || '';

  // Summary: the server's summary object, plus the excite figures when this is a record (a diagnosis has
  // none: its data, rate, baseline and rule instead, the scan of orders left out).
  const summary = { ...(r.summary || {}) };
  for (const k of ['fs', 'samples', 'validation_samples', 'rms_drive', 'rms_response']) if (k in r) summary[k] = r[k];
  if (diagnosis) {
    const { scan, ...baseline } = r.baseline || {};
    Object.assign(summary, { data: r.data, baseline, rule: r.rule });
  }
  const rows = flatten(summary).map(([k, v]) => [el('dt', {}, k), el('dd', { class: 'mono' }, fmtValue(v))]).flat();
  $('#result-summary').replaceChildren(...rows);
  $('#result-summary-box').hidden = rows.length === 0;

  clearPlots();
  const plots = r.plots || {};
  const names = PLOT_ORDER.filter((n) => plots[n]).concat(Object.keys(plots).filter((n) => !PLOT_ORDER.includes(n)));
  for (const name of names) {
    const host = el('div', { id: `plot-${name}`, class: 'plot', dataset: { plot: name } });
    $('#plots').append(el('div', { class: 'plot-box' }, host));
    try {
      const plot = drawPlot(host, name, plots[name]);
      if (plot) state.plots.push(plot);
      else host.append(el('div', { class: 'muted' }, `${name}: no data`));
    } catch (e) {
      host.append(el('div', { class: 'error' }, `${name}: cannot draw (${e.message})`));
    }
  }
  if (names.length === 0) $('#plots').append(el('div', { class: 'muted' }, 'this result has no plots'));
}

/** Shows where the result's model is active (from the store) on the result panel. */
function renderActivated(job) {
  const id = job?.result?.model_id;
  if (!id || state.selected !== job.id) return;
  const m = state.models.find((x) => x.id === id);
  const slots = m?.active_in || [];
  setText('#result-model', modelLabel(id));
  setText('#result-activated', slots.length ? `active in ${slots.join(', ')}` : '');
  $('#result-activate').disabled = slots.length > 0;
}

// ---------------------------------------------------------------------------------------------

function init() {
  $('#config-form').addEventListener('submit', applyConfig);
  $('#config-form').addEventListener('input', () => {
    setConfigDirty(true);
    showMessage('#config-result', '');
  });
  $('#config-reload').addEventListener('click', () => {
    setConfigDirty(false);
    showMessage('#config-error', '');
    showMessage('#config-result', '');
    loadConfig();
  });
  $('#upload-form').addEventListener('submit', uploadModel);
  $('#job-form').addEventListener('submit', startJob);
  $('#job-form').addEventListener('input', updatePreview);
  $('#job-form').addEventListener('change', updateJobForm);
  $('#job-cancel').addEventListener('click', () => state.selected && cancelJob(state.selected));
  $('#result-activate').addEventListener('click', () => {
    const id = $('#result-activate').dataset.modelId;
    if (id) activate(id, $('#result-activated'));
  });
  updateJobForm();

  if (typeof window.uPlot !== 'function') {
    document.body.prepend(el('div', { class: 'error banner' },
      'uPlot did not load (node_modules/uplot/dist/uPlot.iife.min.js): run scripts/web_setup.sh; plots are off.'));
  }

  every(STATUS_PERIOD_MS, pollStatus);
  every(JOBS_PERIOD_MS, refreshJobs);
  every(MODELS_PERIOD_MS, refreshModels);
  every(CONFIG_PERIOD_MS, () => (state.configDirty ? null : loadConfig()));
}

init();

// The selected job: its progress while it runs (event stream, else polling), then its result.

import { api, FINISHED_STATES } from '../api.js';
import { $, $$, el, setText, showMessage } from './dom.js';
import { errorText, jobWarnings, num } from './format.js';
import { state } from './state.js';
import { refreshJobs } from './jobs.js';
import { clearPlots, renderActivated, renderResult } from './results.js';

const JOB_POLL_MS = 700;

function stopFollowing() {
  const f = state.follow;
  if (!f) return;
  if (f.source) f.source.close();
  clearTimeout(f.timer);
  state.follow = null;
}

/** Shows job `id` in the result panel and follows it while it runs. */
export function selectJob(id) {
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
    renderWarnings([]);
    setProgress(0, '');
    for (const tr of $$('#jobs-table tbody tr')) tr.classList.toggle('selected', tr.dataset.jobId === id);
  }
  loadSelected().then((job) => {
    if (job && !FINISHED_STATES.has(job.state) && state.selected === id) follow(id);
  });
}

/** Reads the selected job and shows it; resolves with its record (null when it cannot be read). */
export async function loadSelected() {
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

/** Shows a job's warnings above its result, or hides the box when there are none. */
function renderWarnings(warnings) {
  const box = $('#result-warnings');
  const signature = JSON.stringify(warnings);
  if (box.dataset.signature === signature) return;
  box.dataset.signature = signature;
  box.replaceChildren(...(warnings.length
    ? [el('div', {}, warnings.length > 1 ? `⚠ ${warnings.length} warnings on this result:` : '⚠ Warning on this result:'),
       el('ul', {}, ...warnings.map((w) => el('li', {}, w)))]
    : []));
  box.hidden = warnings.length === 0;
}

function renderJob(job) {
  state.selectedJob = job;
  setText('#result-kind', job.kind || '');
  setState(job.state);
  setProgress(job.state === 'succeeded' ? 1 : job.progress, job.message);
  showMessage('#result-error', job.state === 'failed' ? `failed: ${job.error || job.message || 'no reason given'}`
    : job.state === 'cancelled' ? 'cancelled' : '');
  renderWarnings(jobWarnings(job));
  if (job.state === 'succeeded' && job.result && state.renderedResult !== job.id) {
    state.renderedResult = job.id;
    renderResult(job);
  }
  renderActivated(job);
}

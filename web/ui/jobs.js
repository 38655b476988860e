// The jobs table: every job with its state and progress, a click to show one, Cancel on a running one.

import { api, FINISHED_STATES } from '../api.js';
import { $, el, showMessage, syncRows } from './dom.js';
import { errorText, fmtTime, jobWarnings, num } from './format.js';
import { state } from './state.js';
import { fillSourceSelect } from './job_form.js';
import { loadSelected, selectJob } from './job_view.js';

const jobNumber = (id) => Number(String(id).replace(/^\D+/, '')) || 0;

/** Reads the job list (newest first) and shows it. */
export async function refreshJobs() {
  try {
    const res = await api.jobs();
    const previous = state.jobs === null ? null : new Map(state.jobs.map((j) => [j.id, j.state]));
    state.jobs = (res.jobs || []).sort((a, b) => jobNumber(b.id) - jobNumber(a.id));
    renderJobs();
    showFinishedJob(previous);
  } catch (e) {
    /* the status badge already says the server is unreachable */
  }
}

/** Shows a result without a click: on load the newest succeeded job's, later each job's as it succeeds (unless
 *  the job shown is still running). `previous` maps the ids last seen to their states (null on the first read). */
function showFinishedJob(previous) {
  if (previous === null) {
    const newest = state.jobs.find((j) => j.state === 'succeeded');
    if (newest && !state.selected) selectJob(newest.id);
    return;
  }
  const finished = state.jobs.find((j) => j.state === 'succeeded' && previous.get(j.id) !== 'succeeded');
  const shown = state.jobs.find((j) => j.id === state.selected);
  if (finished && finished.id !== state.selected && (!shown || FINISHED_STATES.has(shown.state))) selectJob(finished.id);
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
      const warnings = jobWarnings(j);
      c[4].textContent = j.state === 'failed' && j.error ? j.error
        : warnings.length ? `⚠ ${warnings.length > 1 ? `${warnings.length} warnings: ` : ''}${warnings[0]}` : j.message || '';
      c[4].title = warnings.length ? warnings.join('\n') : c[4].textContent;
      c[4].classList.toggle('warn', warnings.length > 0);
      tr.dataset.warnings = String(warnings.length);
      c[5].textContent = fmtTime(j.created);
      c[6].textContent = fmtTime(j.finished);
      tr.dataset.state = j.state;
      tr.classList.toggle('selected', j.id === state.selected);
      const running = !FINISHED_STATES.has(j.state);
      if (running !== (c[7].childElementCount > 0)) {
        c[7].replaceChildren(...(running ? [el('button', { type: 'button', class: 'danger small cancel', onclick: () => cancelJob(j.id) }, 'Cancel')] : []));
      }
    });
  fillSourceSelect();
}

/** Cancels job `id` and shows the lists again. */
export async function cancelJob(id) {
  try {
    await api.cancelJob(id);
  } catch (e) {
    showMessage('#job-error', `cancel ${id}: ${errorText(e)}`);
  }
  refreshJobs();
  if (id === state.selected) loadSelected();
}

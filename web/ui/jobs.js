// The jobs table: every job with its state and progress, a click to show one, Cancel on a running one.

import { api, FINISHED_STATES } from '../api.js';
import { $, el, showMessage, syncRows } from './dom.js';
import { errorText, fmtTime, num } from './format.js';
import { state } from './state.js';
import { fillSourceSelect } from './job_form.js';
import { loadSelected, selectJob } from './job_view.js';

const jobNumber = (id) => Number(String(id).replace(/^\D+/, '')) || 0;

/** Reads the job list (newest first) and shows it. */
export async function refreshJobs() {
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

// The tune pipeline in one action: measure → identify linear → design LQ (activated) → record in the operating
// regime → identify NARX → design the neural feedback (activated) → verify (probe tones without and with the
// chain: THD and level of the response, shown here). Each step is an ordinary job (its progress in
// the jobs table, its result and plots a click away); the list here says where the pipeline is, and a failed
// step stops it, saying why. The same jobs run on the virtual transducer and on a sound card.

import { api, FINISHED_STATES } from '../api.js';
import { $, el, showMessage } from './dom.js';
import { errorText } from './format.js';
import { refreshJobs } from './jobs.js';
import { selectJob } from './job_view.js';

const POLL_MS = 500;

/** The steps: a label, the job's kind, its params from the ids made so far, whether to activate its model, and
 *  what of its result the next steps need. */
const STEPS = [
  { label: 'measure', kind: 'excite', params: () => ({ signal: 'noise', samples: 10000, validation_samples: 5000, seed: 1 }),
    keep: (job, made) => { made.record = job.id; } },
  { label: 'identify linear', kind: 'identify-linear', params: (made) => ({ record: made.record, method: 'oe', order: 8 }),
    keep: (job, made) => { made.linear = job.result.model_id; } },
  { label: 'design LQ feedforward', kind: 'design-lq', activate: true, params: (made) => ({ plant_model: made.linear }),
    keep: (job, made) => { made.lq = job.result.model_id; } },
  { label: 'record in the operating regime', kind: 'excite',
    params: (made) => ({ signal: 'control', feedforward_model: made.lq, samples: 20000, validation_samples: 5000, seed: 2 }),
    keep: (job, made) => { made.control = job.id; } },
  { label: 'identify NARX', kind: 'identify-narx', params: (made) => ({ record: made.control, weighted: true }),
    keep: (job, made) => { made.narx = job.result.model_id; } },
  { label: 'design neural feedback', kind: 'design-nn', activate: true,
    params: (made) => ({ plant_model: made.narx, feedforward_model: made.lq }),
    keep: (job, made) => { made.nn = job.result.model_id; } },
  { label: 'verify', kind: 'verify', params: (made) => ({ feedforward_model: made.lq, feedback_model: made.nn }),
    keep: (job) => showProbes(job.result) },
];

const fixed = (x, digits) => (typeof x === 'number' && Number.isFinite(x) ? x.toFixed(digits) : '—');

/** The verify step's probes: THD and level of the response without and with the chain, per tone. */
function showProbes(result) {
  // A THD at the sensor's noise floor is shown as the floor it lies under, and the change as the bound it gives.
  const thd = (p, side) => (p[`thd_${side}_at_floor`] ? `≤ ${fixed(p[`thd_${side}_at_most_pct`], 2)} % (noise floor)`
    : `${fixed(p[`thd_${side}_pct`], 2)} %`);
  const change = (p) => (typeof p.thd_change_at_most_db === 'number' ? `≤ ${fixed(p.thd_change_at_most_db, 1)} dB`
    : `${fixed(p.thd_change_db, 1)} dB`);
  const rows = (result.probes || []).map((p) => el('tr', { title: p.note || '' },
    el('td', {}, `${p.frequency_hz} Hz`), el('td', {}, thd(p, 'before')), el('td', {}, thd(p, 'after')),
    el('td', {}, change(p)), el('td', {}, fixed(p.level_before, 4)), el('td', {}, fixed(p.level_after, 4))));
  $('#tune-probes').replaceChildren(el('thead', {}, el('tr', {}, ...['probe', 'THD before', 'THD after',
    'THD change (negative: less distortion)', 'level before',
    'level after'].map((h) => el('th', {}, h)))), el('tbody', {}, ...rows));
  $('#tune-probes').hidden = false;
}

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

/** Waits for job `id` to finish; its final record. */
async function finished(id) {
  for (;;) {
    const job = await api.job(id);
    if (FINISHED_STATES.has(job.state)) return job;
    await sleep(POLL_MS);
  }
}

/** Runs the pipeline, step after step, showing each in #tune-steps. */
export async function tune() {
  const button = $('#tune-start');
  const list = $('#tune-steps');
  showMessage('#tune-error', '');
  button.disabled = true;
  const items = STEPS.map((s) => el('li', { dataset: { state: 'waiting' } }, s.label, ' ', el('span', { class: 'mono' })));
  list.replaceChildren(...items);
  $('#tune-probes').hidden = true;
  const made = {};
  try {
    for (const [n, step] of STEPS.entries()) {
      const item = items[n];
      item.dataset.state = 'running';
      const { id } = await api.startJob(step.kind, step.params(made), step.activate);
      item.lastChild.textContent = id;
      await refreshJobs();
      selectJob(id);
      const job = await finished(id);
      item.dataset.state = job.state;
      if (job.state !== 'succeeded') throw new Error(`${step.label} (${id}) ${job.state}: ${job.error || ''}`);
      step.keep(job, made);
    }
  } catch (e) {
    showMessage('#tune-error', errorText(e));
  } finally {
    button.disabled = false;
  }
}

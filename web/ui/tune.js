// Tune in one click: the server's tune job (api/ROUTES.md "Jobs", usecases/tune.h) — measure the transducer,
// fit its gray-box model from the coil current, design the mirror filter, verify it at equal output level, and
// keep (activate) it only where it cuts the distortion. The list here follows the job's steps; the decision, the
// THD of each probe and level (transducer alone against the chain, at the same output) and the THD-versus-level
// plots (in the job's result, selected when it ends) say what it bought. The same job runs on the virtual
// transducer and on a sound card.

import { api, FINISHED_STATES } from '../api.js';
import { $, el, showMessage } from './dom.js';
import { errorText } from './format.js';
import { refreshJobs } from './jobs.js';
import { selectJob } from './job_view.js';

const POLL_MS = 500;

/** The job's steps, and where each begins in its progress (usecases/tune.cpp reports these spans). */
const STEPS = [
  { name: 'measure', label: 'measure (multisine: drive and coil current)', from: 0 },
  { name: 'fit', label: 'fit the gray-box model from the current; the mirror filter', from: 0.3 },
  { name: 'refine', label: 'refine the friction on two quiet sines (the current\'s harmonics)', from: 0.4 },
  { name: 'verify', label: 'verify at equal output level', from: 0.45 },
  { name: 'decide', label: 'keep it where it helps', from: 0.98 },
];

const fixed = (x, digits) => (typeof x === 'number' && Number.isFinite(x) ? x.toFixed(digits) : '—');

/** A THD reading: its value, or what it is at most when it stands in the sensor's noise. */
function thdText(r) {
  if (!r) return '—';
  return r.noise_bound ? `≤ ${fixed(r.at_most_pct, 2)} % (noise)` : `${fixed(r.thd_pct, 2)} %`;
}

/** A point's cut: a number, a bound, or why there is none. */
function cutText(p) {
  if (!p.reachable) return `not reached: ${p.unreachable_because}`;
  if (typeof p.thd_cut_db === 'number') return `${fixed(p.thd_cut_db, 1)} dB`;
  if (typeof p.thd_cut_at_least_db === 'number') return `≥ ${fixed(p.thd_cut_at_least_db, 1)} dB`;
  return 'unknown (the transducer alone reads at its noise)';
}

/** Verify's points: per probe and program level, the THD alone and through the chain at equal output, the cut. */
function showPoints(result) {
  const points = (result.verify && result.verify.points) || [];
  // a level not reached was not played: it has no output or THD to show (the server's zeros are not readings)
  const rows = points.map((p) => el('tr', { dataset: { reachable: String(p.reachable) } },
    el('td', {}, `${p.frequency_hz} Hz`), el('td', {}, fixed(p.program_level, 2)),
    el('td', {}, p.reachable ? fixed(p.output_level, 4) : '—'),
    el('td', {}, p.reachable ? thdText(p.plant) : '—'), el('td', {}, p.reachable ? thdText(p.chain) : '—'), el('td', {}, cutText(p))));
  $('#tune-probes').replaceChildren(el('thead', {}, el('tr', {}, ...['probe', 'program level', 'output (sensor fundamental)',
    'THD transducer alone', 'THD with the filter', 'THD cut (positive: less distortion)'].map((h) => el('th', {}, h)))),
  el('tbody', {}, ...rows));
  $('#tune-probes').hidden = rows.length === 0;  // nothing verified (a card without a sensor): no table
}

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

/** Marks the steps up to the one `progress` is in as done, that one running. */
function follow(items, progress) {
  let current = 0;
  STEPS.forEach((s, n) => { if (progress >= s.from) current = n; });
  items.forEach((item, n) => { item.dataset.state = n < current ? 'succeeded' : n === current ? 'running' : 'waiting'; });
}

/** Runs the tune job, following its steps in #tune-steps; its decision and points when it ends. */
export async function tune() {
  const button = $('#tune-start');
  const list = $('#tune-steps');
  showMessage('#tune-error', '');
  button.disabled = true;
  const items = STEPS.map((s) => el('li', { dataset: { state: 'waiting', step: s.name } }, s.label, ' ', el('span', { class: 'mono' })));
  list.replaceChildren(...items);
  $('#tune-probes').hidden = true;
  $('#tune-decision').textContent = '';
  try {
    // activate: what the job keeps joins the feedforward slot (it keeps nothing that does not help)
    const { id } = await api.startJob('tune', {}, true);
    await refreshJobs();
    selectJob(id);
    let job;
    for (;;) {
      job = await api.job(id);
      follow(items, job.progress || 0);
      items.find((item) => item.dataset.state === 'running')?.lastChild.replaceChildren(job.message || '');
      if (FINISHED_STATES.has(job.state)) break;
      await sleep(POLL_MS);
    }
    if (job.state !== 'succeeded') {
      items.forEach((item) => { if (item.dataset.state === 'running') item.dataset.state = job.state; });
      throw new Error(`tune (${id}) ${job.state}: ${job.error || ''}`);
    }
    const seconds = Object.fromEntries((job.result.steps || []).map((s) => [s.name, s.seconds]));
    // a step the job did not run (verify without a sensor, refine when turned off) says so
    items.forEach((item, n) => {
      const ran = STEPS[n].name in seconds;
      item.dataset.state = ran ? 'succeeded' : 'skipped';
      item.lastChild.textContent = ran ? `${fixed(seconds[STEPS[n].name], 1)} s` : '— skipped';
    });
    const kept = job.result.keep;
    $('#tune-decision').textContent = `${job.result.decision}${kept && job.activated ? ` — active in the ${job.activated.slot} slot (${job.activated.id})` : ''}`;
    $('#tune-decision').dataset.kept = String(!!kept);
    $('#tune-decision').title = (job.result.left_out || []).map((w) => `left out: ${w}`).join('\n');
    showPoints(job.result);
    await refreshJobs();
    selectJob(id);
  } catch (e) {
    showMessage('#tune-error', errorText(e));
  } finally {
    button.disabled = false;
  }
}

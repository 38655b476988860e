// A succeeded job's result: its J figures, model, summary and plots (a diagnosis has its own view).

import { drawPlot, PLOT_ORDER } from '../plots.js';
import { $, el, setText, showMessage } from './dom.js';
import { flatten, fmtPct, fmtValue } from './format.js';
import { modelLabel, slotsOf, state, whyNoSlot } from './state.js';
import { refreshModels } from './models.js';
import { renderDiagnosis } from './diagnosis.js';

/** Removes the result's plots. */
export function clearPlots() {
  for (const p of state.plots) p.dispose();
  state.plots = [];
  $('#plots').replaceChildren();
}

/** An evaluation's warning where the program needs more drive than the chain can give: `needs` maps a probe
 *  ("160 Hz") to the program amplitudes whose drive asked for full scale or more (false or absent: none). */
export function driveNote(needs) {
  if (!needs || typeof needs !== 'object') return '';
  const where = Object.entries(needs).map(([probe, levels]) => `${probe} at program ${levels.join(', ')}`);
  if (where.length === 0) return '';
  return `The program needs more drive than the chain can give (${where.join('; ')}): the drive asked for full scale `
    + 'or more there, which the limiter squeezes below the rails. Those levels are left out of the cuts; lower the '
    + 'program, or design the controller for its level.';
}

/** Shows a succeeded job's result: figures, model, summary and plots. */
export function renderResult(job) {
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
  // Activate follows the store's summary of the model (its `slots`): renderActivated, once the store lists it.
  const button = $('#result-activate');
  button.dataset.modelId = r.model_id || '';
  button.dataset.slot = '';
  button.hidden = true;
  showMessage('#result-plant-note', '');
  if (r.model_id && !state.models.some((m) => m.id === r.model_id)) refreshModels();

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
  showMessage('#result-drive-note', driveNote(r.summary && r.summary.needs_more_drive));

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

/** Shows, from the store, where the result's model is active and the slots it can be activated in (the server's
 *  `slots`: Activate names the slot; a model no slot runs, a plant, says why instead). Nothing is offered until the
 *  store lists the model. */
export function renderActivated(job) {
  const id = job?.result?.model_id;
  if (!id || state.selected !== job.id) return;
  const m = state.models.find((x) => x.id === id);
  const active = m?.active_in || [];
  setText('#result-model', modelLabel(id));
  setText('#result-activated', active.length ? `active in ${active.join(', ')}` : '');
  const slot = m ? (slotsOf(m)[0] ?? '') : '';
  const button = $('#result-activate');
  button.dataset.slot = slot;
  button.hidden = !slot;
  button.textContent = slot ? `Activate as ${slot}` : 'Activate';
  button.disabled = active.length > 0;
  showMessage('#result-plant-note', m && !slot ? whyNoSlot(m).long : '');
}

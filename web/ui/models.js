// The model store panel: the stored models, activate, delete and upload; the job form's model choices.

import { api } from '../api.js';
import { $, $$, deleteButton, el, showMessage, syncRows } from './dom.js';
import { errorText, fmtTime, num } from './format.js';
import { slotsOf, state, whyNoSlot } from './state.js';
import { renderConfigModels } from './config.js';
import { pollStatus } from './status.js';
import { updatePreview } from './job_form.js';
import { renderActivated } from './results.js';

/** Reads the stored models and shows them. */
export async function refreshModels() {
  try {
    const res = await api.models();
    state.models = res.models || [];
    renderModels();
  } catch (e) {
    showMessage('#models-error', `cannot list the models: ${errorText(e)}`);
  }
}

/** Activates model `id` in `slot`; says so in `resultNode` (the result panel's), or shows the server's error next
 *  to where it was asked. */
export async function activate(id, slot, resultNode) {
  try {
    const res = await api.activateModel(id, slot);
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
      const del = deleteButton(m.id, () => api.deleteModel(m.id), refreshModels, '#models-error');
      tr.append(el('td', { class: 'buttons' }, el('span', { class: 'activate-slots' }), del));
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
      // Activate is offered for each slot the server says runs the model (`slots`); a model no slot runs says why.
      const accepts = slotsOf(m);
      const host = tr.querySelector('.activate-slots');
      if (tr.dataset.slots !== accepts.join(' ') || !host.hasChildNodes()) {
        tr.dataset.slots = accepts.join(' ');
        const why = accepts.length ? null : whyNoSlot(m);
        host.replaceChildren(...(why
          ? [el('span', { class: 'muted no-slot-note', title: why.long }, why.short)]
          : accepts.map((slot) => el('button', { type: 'button', class: 'small activate', dataset: { slot },
                                                 onclick: () => activate(m.id, slot, null) }, `Activate as ${slot}`))));
      }
      for (const button of host.querySelectorAll('button.activate')) button.disabled = slots.includes(button.dataset.slot);
    });
  fillModelSelects();
  renderConfigModels();  // the chain panel's model names, which the store gives
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

/** Uploads the chosen model file (checked to be JSON first) under the given name. */
export async function uploadModel(event) {
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

// The chain settings panel: GET /api/config into the form, the edited fields as a merge patch to
// PATCH /api/config.

import { api } from '../api.js';
import { $, $$, setText, showMessage } from './dom.js';
import { errorText, get, setPath } from './format.js';
import { modelLabel, state } from './state.js';

const configFields = () => $$('#config-form [name]');

function fillConfigForm(config) {
  for (const field of configFields()) {
    const v = get(config, field.name);
    if (field.type === 'checkbox') field.checked = !!v;
    else field.value = v ?? '';
  }
  renderConfigModels();
  setText('#config-fixed', `fs ${config.fs ?? '—'} Hz · block ${config.block ?? '—'} · history ${config.history ?? '—'} (fixed while running)`);
}

/** Shows the slots' models of the last settings read, with their names from the store. */
export function renderConfigModels() {
  setText('#config-ff-model', modelLabel(state.config?.feedforward?.model));
  setText('#config-fb-model', modelLabel(state.config?.feedback?.model));
}

/** Reads the chain settings; fills the form unless it holds edits (then only the model names). */
export async function loadConfig() {
  try {
    const config = await api.config();
    state.config = config;
    if (!state.configDirty) fillConfigForm(config);
    else renderConfigModels();
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

/** Wires the settings form: Apply sends the patch, an edit marks it dirty, Reload reads the settings again. */
export function initConfig() {
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
}

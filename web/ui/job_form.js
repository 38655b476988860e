// The job form: which fields each kind shows, its params read and checked, the request body previewed,
// the job started.

import { api } from '../api.js';
import { $, $$, el, setText, showMessage } from './dom.js';
import { errorText, fmtTime, setPath } from './format.js';
import { state } from './state.js';
import { refreshJobs } from './jobs.js';
import { selectJob } from './job_view.js';

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
  const share = $('#job-val-fraction').value.trim();
  if (isUploadedRecord(source) && share !== '') {
    const v = Number(share);
    if (!Number.isFinite(v)) throw new Error(`validation share: not a number: ${share}`);
    params.val_fraction = v;
  }
  return { kind, params };
}

/** Shows the fields of the chosen kind (the excitation's only without a chosen record). */
export function updateJobForm() {
  const kind = $('#job-kind').value;
  const source = $('#job-source').value;
  for (const node of $$('#job-form [data-kinds]')) {
    let show = kindsOf(node).includes(kind);
    if (node.id === 'fs-excite' && kind !== 'excite' && source) show = false;
    if (node.id === 'job-val-fraction-label' && !isUploadedRecord(source)) show = false;
    node.hidden = !show;
  }
  updatePreview();
}

/** Shows the request body the form would send (or what is wrong with it). */
export function updatePreview() {
  try {
    const { kind, params } = collectJob();
    const body = { kind, params };
    if (!$('#job-activate').closest('[data-kinds]').hidden && $('#job-activate').checked) body.activate = true;
    setText('#job-params-preview', JSON.stringify(body, null, 2));
  } catch (e) {
    setText('#job-params-preview', e.message);
  }
}

/** Starts the form's job and shows it in the result panel. */
export async function startJob(event) {
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

/** True for an uploaded record's id ("r" + 12 hex digits; a job's is "j" + digits). */
export function isUploadedRecord(id) {
  return /^r[0-9a-f]{12}$/.test(id || '');
}

/** Offers the finished excite jobs' records and the uploaded records as data the identify/analyze/diagnose kinds
 *  can reuse. */
export function fillSourceSelect() {
  const select = $('#job-source');
  const records = (state.jobs || []).filter((j) => j.kind === 'excite' && j.state === 'succeeded');
  const uploaded = state.records || [];
  const signature = records.map((j) => j.id).concat(uploaded.map((r) => r.id + r.name)).join(',');
  if (select.dataset.signature !== signature) {
    const current = select.value;
    select.replaceChildren(el('option', { value: '' }, 'new excitation'),
      ...records.map((j) => el('option', { value: j.id }, `record of ${j.id} (${fmtTime(j.finished)})`)),
      ...uploaded.map((r) => el('option', { value: r.id },
                                `uploaded ${r.id}${r.name ? ` · ${r.name}` : ''} (${r.samples} samples)`)));
    select.dataset.signature = signature;
    select.value = records.some((j) => j.id === current) || uploaded.some((r) => r.id === current) ? current : '';
    updateJobForm();
  }
}

// The records panel: the uploaded recordings (WAV or CSV) that jobs take as their data, upload and delete.

import { api } from '../api.js';
import { $, deleteButton, el, showMessage, syncRows } from './dom.js';
import { errorText, fmtTime, num } from './format.js';
import { fillSourceSelect } from './job_form.js';
import { state } from './state.js';

/** Reads the uploaded records and shows them (and offers them as the jobs' data). */
export async function refreshRecords() {
  try {
    const res = await api.records();
    state.records = res.records || [];
    renderRecords();
  } catch (e) {
    showMessage('#records-error', `cannot list the records: ${errorText(e)}`);
  }
}

function renderRecords() {
  const records = [...state.records].sort((a, b) => String(b.created).localeCompare(String(a.created)));
  $('#records-empty').hidden = records.length > 0;
  syncRows($('#records-table tbody'), records, (r) => r.id,
    (r) => {
      const tr = el('tr', { dataset: { recordId: r.id } });
      tr.append(el('td', { class: 'mono' }, r.id), el('td'), el('td'), el('td', { class: 'num' }),
                el('td', { class: 'num' }), el('td', { class: 'mono' }), el('td'));
      tr.append(el('td', { class: 'buttons' },
                   deleteButton(r.id, () => api.deleteRecord(r.id), refreshRecords, '#records-error')));
      return tr;
    },
    (tr, r) => {
      const cells = tr.children;
      cells[1].textContent = r.name ?? '';
      cells[2].textContent = r.file ?? '';
      cells[3].textContent = num(r.samples) ? String(r.samples) : '';
      cells[4].textContent = num(r.fs) ? String(r.fs) : '';
      cells[5].textContent = `u=${r.input} y=${r.output}${r.current ? ` i=${r.current}` : ''}`;
      cells[6].textContent = fmtTime(r.created);
    });
  if (state.jobs) fillSourceSelect();
}

/** Uploads the chosen WAV or CSV file with the form's rate, channels and name. */
export async function uploadRecord(event) {
  event.preventDefault();
  showMessage('#record-upload-error', '');
  showMessage('#record-upload-result', '');
  const file = $('#record-file').files[0];
  if (!file) {
    showMessage('#record-upload-error', 'choose a WAV or CSV file first');
    return;
  }
  const query = {
    fs: $('#record-fs').value.trim(),
    input: $('#record-input').value.trim(),
    output: $('#record-output').value.trim(),
    current: $('#record-current').value.trim(),
    name: $('#record-name').value.trim() || file.name.replace(/\.(wav|csv)$/i, ''),
  };
  const button = $('#record-upload-button');
  button.disabled = true;
  try {
    const res = await api.uploadRecord(file, query);
    showMessage('#record-upload-result',
                `stored ${res.id} (${res.samples} samples at ${res.fs} Hz${res.name ? `, ${res.name}` : ''})`);
    $('#record-form').reset();
    refreshRecords();
  } catch (e) {
    showMessage('#record-upload-error', `${file.name}: ${errorText(e)}`);
  } finally {
    button.disabled = false;
  }
}

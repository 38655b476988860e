// The program panel: what the engine loops (GET /api/program), a new one played with a fade (PUT /api/program),
// and the A/B a listener makes — the controllers' bypass flags (PATCH /api/config feedforward.bypass and
// feedback.bypass), the chain with its controllers against the chain without.

import { request } from '../api.js';
import { loadConfig } from './config.js';
import { $, $$, setText, showMessage } from './dom.js';
import { errorText } from './format.js';
import { state } from './state.js';

/** What GET /api/program returned, in words: "sine 80 Hz at 0.2 (3000 Hz, fading in)". */
function programText(p) {
  if (!p) return '—';
  if (p.source === 'capture') return `from the card's capture channel ${p.channel} (not replaceable here)`;
  const fading = p.settled === false ? ', fading in' : '';
  const where = p.rate ? ` · played at ${p.rate} Hz${fading}` : fading;
  if (p.signal === 'silence') return `silence${where}`;
  if (p.signal === 'custom') return `the program given at start-up${where}`;
  const what = p.signal.startsWith('sine:') ? `sine ${p.frequency_hz ?? p.signal.slice(5)} Hz` : p.signal;
  const seed = p.seed !== undefined ? `, seed ${p.seed}` : '';
  return `${what} at ${p.amplitude}${seed}${where}`;
}

/** Shows the fields the chosen signal takes (a sine its frequency, noise its seed, silence neither amplitude). */
function showSignalFields() {
  const signal = $('#program-signal').value;
  for (const label of $$('#program-form [data-signals]')) label.hidden = !label.dataset.signals.split(' ').includes(signal);
}

/** The request body of the form; throws on a malformed number (the server checks the ranges). */
function programRequest() {
  const signal = $('#program-signal').value;
  const number = (selector, name) => {
    const text = $(selector).value.trim();
    const v = Number(text);
    if (text === '' || !Number.isFinite(v)) throw new Error(`${name}: a number is needed`);
    return v;
  };
  if (signal === 'silence') return { signal };
  const body = { signal: signal === 'sine' ? `sine:${number('#program-frequency', 'frequency')}` : signal,
                 amplitude: number('#program-amplitude', 'amplitude') };
  if (signal === 'noise' && $('#program-seed').value.trim() !== '') body.seed = number('#program-seed', 'seed');
  return body;
}

/** Reads what plays and the controllers' bypass (from the settings the chain panel read last). */
export async function loadProgram() {
  try {
    const p = await request('GET', '/api/program');
    setText('#program-now', programText(p));
    $('#program-apply').disabled = p.source === 'capture';
  } catch (e) {
    showMessage('#program-error', `cannot read the program: ${errorText(e)}`);
  }
  showBypass();
}

/** The toggle as the settings the chain panel read last say: ticked when every active controller is bypassed,
 *  off (and saying why) when no controller is active, as bypassing an empty slot changes nothing. */
export function showBypass() {
  const bypass = $('#program-bypass');
  const slots = ['feedforward', 'feedback'].map((s) => state.config?.[s]).filter((s) => s?.model);
  bypass.disabled = slots.length === 0;
  $('#program-bypass-note').hidden = slots.length > 0;
  if (document.activeElement !== bypass) bypass.checked = slots.length > 0 && slots.every((s) => s.bypass);
}

async function playProgram(event) {
  event.preventDefault();
  showMessage('#program-error', '');
  showMessage('#program-result', '');
  let body;
  try {
    body = programRequest();
  } catch (e) {
    showMessage('#program-error', e.message);
    return;
  }
  const button = $('#program-apply');
  button.disabled = true;
  try {
    const p = await request('PUT', '/api/program', body);
    setText('#program-now', programText(p));
    showMessage('#program-result', `playing ${programText({ ...p, rate: undefined, settled: true })}`);
  } catch (e) {
    showMessage('#program-error', errorText(e));
  } finally {
    button.disabled = false;
  }
}

async function setBypass() {
  const bypass = $('#program-bypass').checked;
  showMessage('#program-error', '');
  showMessage('#program-result', '');
  try {
    await request('PATCH', '/api/config', { feedforward: { bypass }, feedback: { bypass } });
    showMessage('#program-result', bypass ? 'controllers bypassed: the chain without them (B)'
                                          : 'controllers on: the chain with them (A)');
    await loadConfig();
    showBypass();
  } catch (e) {
    $('#program-bypass').checked = !bypass;
    showMessage('#program-error', errorText(e));
  }
}

/** Wires the program form and the bypass toggle. */
export function initProgram() {
  $('#program-form').addEventListener('submit', playProgram);
  $('#program-signal').addEventListener('change', showSignalFields);
  $('#program-bypass').addEventListener('change', setBypass);
  showSignalFields();
}

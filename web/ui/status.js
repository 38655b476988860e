// The engine status panel, polled every second: connection, engine, metrics and the active models.

import { api } from '../api.js';
import { $, setText } from './dom.js';
import { errorText, fmtDuration, fmtNs, fmtNumber, fmtShare, num } from './format.js';
import { modelLabel, state } from './state.js';
import { loadConfig } from './config.js';
import { refreshModels } from './models.js';

/** Reads the status and health; shows them, or the connection as offline. */
export async function pollStatus() {
  let status, health;
  try {
    [status, health] = await Promise.all([api.status(), api.health()]);
  } catch (e) {
    const conn = $('#conn');
    conn.dataset.state = 'offline';
    conn.textContent = 'offline';
    conn.title = errorText(e);
    $('#status-panel').classList.add('stale');
    return;
  }
  const conn = $('#conn');
  conn.dataset.state = health?.status === 'ok' ? 'online' : 'degraded';
  conn.textContent = health?.status === 'ok' ? 'online' : `health: ${health?.status ?? '?'}`;
  conn.title = '';
  setText('#version', health?.version ? `v${health.version}` : '');
  $('#status-panel').classList.remove('stale');
  state.status = status;
  renderStatus(status);
}

/** Shows the drive: its peak since start (which never resets) and, over the limiter's window (about the last
 *  second), the share of samples the limiter compressed and of those that asked for full scale or more. Says
 *  plainly when the program needs more drive than the chain allows (`needs_more_drive`), which clears when the
 *  program gets quieter; a milder note while the limiter only compresses. */
function renderDrive(m, knee) {
  const peak = m.peak_drive;
  setText('#status-peak-drive', num(peak) ? peak.toFixed(4) : '—');
  const meter = $('#status-peak-drive-meter');
  meter.value = num(peak) ? Math.min(1, Math.max(0, peak)) : 0;
  if (num(knee)) meter.low = knee;
  const demand = m.peak_demand;
  setText('#status-peak-demand', num(demand) ? demand.toFixed(4) : '—');
  $('#status-peak-demand').classList.toggle('warn', num(demand) && demand >= 1);

  const span = m.limiter_window_s;
  const limited = m.limited_fraction;
  const over = m.over_range_fraction;
  const measured = num(span) && span > 0 && num(limited) && num(over);
  const limiter = $('#status-limiter');
  limiter.dataset.limited = measured ? String(limited) : '';
  limiter.dataset.overRange = measured ? String(over) : '';
  setText('#status-limiter', measured
    ? `${fmtShare(limited)} of samples compressed, ${fmtShare(over)} over range (last ${span.toFixed(1)} s)`
    : 'measuring…');
  limiter.classList.toggle('warn', measured && limited > 0);

  const note = $('#status-drive-note');
  let level = '';
  let text = '';
  if (m.needs_more_drive === true) {
    level = 'limit';
    text = 'The program needs more drive than the chain allows: '
      + `over the last ${measured ? `${span.toFixed(1)} s, ${fmtShare(over)} of the samples` : 'second, samples'} asked for `
      + 'full scale or more, which the limiter squeezes below the rails, and the output distorts. Lower the program '
      + 'level, or design the LQ feedforward for the program\'s level (Design LQ feedforward, max input).';
  } else if (measured && limited > 0) {
    level = 'limiting';
    text = `The limiter is compressing ${fmtShare(limited)} of the samples (drive asked for above its knee`
      + `${num(knee) ? ` ${fmtNumber(knee)}` : ''}): the program is close to the most the chain allows.`;
  }
  note.dataset.level = level;
  note.className = level === 'limit' ? 'warn-box' : level ? 'warn' : '';
  note.hidden = !text;
  setText('#status-drive-note', text);
}

/** Shows an engine status; reloads the models and settings when the active models changed. */
export function renderStatus(st) {
  const engine = st.engine || {};
  const m = st.metrics || {};
  const badge = $('#status-state');
  badge.dataset.state = engine.state || '';
  setText('#status-state', engine.state || '—');
  setText('#status-backend', engine.backend ?? '—');
  setText('#status-plant', engine.plant || '—');
  setText('#status-fs', num(engine.fs) ? `${engine.fs} Hz` : '—');
  const blockMs = num(engine.block) && num(engine.fs) ? (1e3 * engine.block) / engine.fs : null;
  setText('#status-block', num(engine.block) ? `${engine.block} samples${blockMs ? ` (${blockMs.toFixed(2)} ms)` : ''}` : '—');
  setText('#status-uptime', fmtDuration(engine.uptime_s));

  const load = m.load;
  setText('#status-load', num(load) ? `${(100 * load).toFixed(1)} %` : '—');
  $('#status-load-meter').value = num(load) ? Math.min(1, Math.max(0, load)) : 0;
  const budget = blockMs ? blockMs * 1e6 : null;
  setText('#status-p99', num(m.p99_block_ns)
    ? `${fmtNs(m.p99_block_ns)}${budget ? ` (${((100 * m.p99_block_ns) / budget).toFixed(1)} % of the block)` : ''}`
    : '—');
  setText('#status-mean', num(m.mean_block_ns) ? `${fmtNs(m.mean_block_ns)} · max ${fmtNs(m.max_block_ns)}` : '—');
  setText('#status-xruns', fmtNumber(m.xruns));
  $('#status-xruns').classList.toggle('warn', num(m.xruns) && m.xruns > 0);
  setText('#status-faults', fmtNumber(m.faults));
  $('#status-faults').classList.toggle('warn', num(m.faults) && m.faults > 0);
  setText('#status-last-fault', m.last_fault || '—');
  setText('#status-swaps', fmtNumber(m.swaps));
  renderDrive(m, state.config?.limiter?.knee);
  const jobs = st.jobs || {};
  setText('#status-jobs', `${jobs.running ?? 0} running, ${jobs.queued ?? 0} queued`);
  $('#status-in-fault').hidden = !m.in_fault;
  $('#status-panel').classList.toggle('in-fault', !!m.in_fault);

  const active = st.active_models || {};
  for (const slot of ['feedforward', 'feedback']) {
    const node = $(`#active-${slot}`);
    node.dataset.modelId = active[slot] || '';
    setText(`#active-${slot}`, modelLabel(active[slot]));
  }
  const key = JSON.stringify(active);
  if (key !== state.activeKey) {
    const first = state.activeKey === '';
    state.activeKey = key;
    if (!first) {
      refreshModels();
      if (!state.configDirty) loadConfig();
    }
  }
}

// A diagnose job's view: the baseline, J before and after, the findings, and plain sentences on where the
// baseline's residual lies.

import { $, el, setText } from './dom.js';
import { fmtNumber, fmtPct, num } from './format.js';

/** "linear · oe, na 8 nb 8 nk 1 (identified)" from a diagnose result's baseline. */
export function baselineLabel(b) {
  if (!b) return '—';
  const orders = ['na', 'nb', 'nk'].filter((k) => num(b[k])).map((k) => `${k} ${b[k]}`).join(' ');
  const method = [b.method, orders].filter(Boolean).join(', ');
  return `${b.kind || 'model'}${method ? ` · ${method}` : ''}${b.source ? ` (${b.source})` : ''}`;
}

/** Plain sentences on where the baseline's validation residual lies (the report's location.validation); what is
 *  significant the server decides (the *_significant fields), this only words it. */
export function locationSentences(l) {
  if (!l) return [];
  const out = [];
  const f = l.frf_error || {};
  out.push(f.significant
    ? `Frequency: the input explains part of the residual from ${fmtNumber(f.band_low_hz, 4)} to ${fmtNumber(f.band_high_hz, 4)} Hz `
      + `(most at ${fmtNumber(f.frequency_hz, 4)} Hz, the response off by ${fmtNumber(f.relative_db, 3)} dB there): a linear error.`
    : 'Frequency: the input explains none of the residual beyond noise (no FRF error).');
  if (num(l.peak_over_noise) && num(l.peak_threshold)) {
    out.push(l.peak_significant
      ? `The residual's spectrum peaks at ${fmtNumber(l.peak_frequency_hz, 4)} Hz, ${fmtNumber(l.peak_over_noise, 3)} × its noise level.`
      : 'The residual\'s spectrum stays within its noise level at every bin.');
  }
  const d = l.distortion || {};
  if (d.periodic) {
    const db = (x) => (num(x) ? `${fmtNumber(x, 3)} dB` : 'n/a');
    out.push(d.odd_lines_only
      ? `Periodic input (${d.period} samples, ${d.periods} periods judged): at the empty lines the residual is ${db(d.residual_odd_db)} `
        + `(odd) and ${db(d.residual_even_db)} (even) over the noise; ${d.threshold_db} dB counts as distortion.`
      : `Periodic input (${d.period} samples), but with even lines excited: odd and even distortion cannot be told apart.`);
  }
  const states = Array.isArray(l.states) ? l.states : [];
  const shaped = states.filter((p) => num(p.shape_chi2)).sort((a, b) => b.shape_chi2 - a.shape_chi2)[0];
  if (shaped) {
    out.push(shaped.shape_significant
      ? `State: the residual depends most on the ${shaped.state} (its bin means ${fmtNumber(shaped.shape_chi2, 3)} × what noise gives).`
      : 'State: the residual does not depend on the input, the output or its integrals beyond noise.');
  }
  const directed = states.filter((p) => num(p.direction_t)).sort((a, b) => Math.abs(b.direction_t) - Math.abs(a.direction_t))[0];
  if (directed && directed.direction_significant) {
    out.push(`Direction: the residual differs between a rising and a falling ${directed.state} (${fmtNumber(directed.direction_t, 3)} standard errors).`);
  }
  if (num(l.change_t)) {
    out.push(l.change_significant
      ? `Time: the residual's level changes × ${fmtNumber(l.change_ratio, 3)} at ${fmtNumber(l.change_time_s, 4)} s.`
      : 'Time: the residual\'s level holds steady through the record.');
  }
  return out;
}

/** A diagnose job's own view: baseline, J before and after, the findings, final J against the noise floor. */
export function renderDiagnosis(r) {
  const baseline = r.baseline || {};
  setText('#diag-baseline', baselineLabel(baseline));
  setText('#diag-j-before', fmtPct(baseline.J_val_pct ?? r.J_val_before_pct));
  setText('#diag-j-after', fmtPct(r.J_val_after_pct));
  setText('#diag-noise-floor', fmtPct(r.noise_floor_pct));
  const channels = r.channels && Array.isArray(r.channels.used) ? r.channels.used : [];
  setText('#diag-channels', channels.length ? channels.join(', ') : '—');
  const ratio = num(r.J_val_after_pct) && num(r.noise_floor_pct) && r.noise_floor_pct > 0
    ? r.J_val_after_pct / r.noise_floor_pct : null;
  setText('#diag-verdict', ratio === null ? ''
    : r.at_noise_floor ? 'The final model is at the noise floor: what is left of the residual is noise.'
    : r.unexplained && r.unexplained.sentence ? r.unexplained.sentence
    : `The final model's J is ${fmtNumber(ratio, 2)} × the noise floor: ${fmtPct(r.J_val_after_pct - r.noise_floor_pct)} is still unexplained.`);
  const findings = Array.isArray(r.findings) ? r.findings : [];
  $('#diag-findings tbody').replaceChildren(...findings.map((f, i) => el('tr', { dataset: { effect: f.effect } },
    el('td', { class: 'num' }, String(i + 1)),
    el('td', { class: 'mono' }, f.effect ?? '—'),
    el('td', { class: 'explanation' }, f.explanation ?? '',
      f.confidence && f.confidence.sentence ? el('div', { class: `confidence ${f.confidence.word}` }, f.confidence.sentence) : null),
    el('td', { class: 'j' }, `${fmtPct(f.J_val_before_pct)} → ${fmtPct(f.J_val_after_pct)}`))));
  $('#diag-findings').hidden = findings.length === 0;
  $('#diag-no-findings').hidden = findings.length > 0;
  const where = locationSentences(r.location && r.location.validation);
  $('#diag-location').replaceChildren(...where.map((text) => el('li', {}, text)));
  $('#diag-location-box').hidden = where.length === 0;
}

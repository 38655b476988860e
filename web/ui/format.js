// How the dashboard writes values: numbers, percentages, durations, times, result summaries; and the
// dotted-path access the forms use.

/** An error as the UI shows it (an ApiError's code and message). */
export const errorText = (e) => (e && typeof e.toString === 'function' ? e.toString() : String(e));

/** The value at a dotted path ("band_pass.low_hz") of `obj`, or undefined. */
export const get = (obj, path) => path.split('.').reduce((o, k) => (o == null ? undefined : o[k]), obj);

/** Sets the value at a dotted path of `obj`, creating the objects on the way. */
export function setPath(obj, path, value) {
  const keys = path.split('.');
  let o = obj;
  for (const k of keys.slice(0, -1)) o = o[k] ??= {};
  o[keys[keys.length - 1]] = value;
}

/** A job's warnings (its result is useless or suspicious): the server's `warnings` strings, [] when none. */
export const jobWarnings = (job) => (Array.isArray(job?.warnings) ? job.warnings.filter((w) => typeof w === 'string') : []);

/** Whether `v` is a finite number. */
export const num = (v) => typeof v === 'number' && Number.isFinite(v);

/** A number to `digits` significant digits (grouped integers, exponents when tiny or huge); "—" for none. */
export function fmtNumber(v, digits = 3) {
  if (!num(v)) return v == null ? '—' : String(v);
  if (Number.isInteger(v)) return v.toLocaleString('en-US');
  const a = Math.abs(v);
  if (a !== 0 && (a < 1e-3 || a >= 1e6)) return v.toExponential(2);
  return v.toPrecision(digits + (a >= 1 ? Math.floor(Math.log10(a)) : 0)).replace(/\.?0+$/, '');
}

/** A percentage figure ("2.48 %"); "—" for none. */
export const fmtPct = (v) => (num(v) ? `${v < 0.1 && v !== 0 ? v.toPrecision(2) : v.toFixed(2)} %` : '—');

/** A share of samples as a percentage: "0 %", "0.05 %", "3.2 %", "> 99.9 %", "100 %". */
export function fmtShare(fraction) {
  if (!num(fraction)) return '—';
  const p = 100 * fraction;
  if (p === 0) return '0 %';
  if (p < 0.1) return `${p.toPrecision(1)} %`;
  if (p < 99.95) return `${p.toFixed(1).replace(/\.0$/, '')} %`;
  return fraction >= 1 ? '100 %' : '> 99.9 %';
}

/** A duration in nanoseconds as ns, µs or ms. */
export function fmtNs(ns) {
  if (!num(ns)) return '—';
  if (ns < 1e3) return `${ns.toFixed(0)} ns`;
  if (ns < 1e6) return `${(ns / 1e3).toFixed(1)} µs`;
  return `${(ns / 1e6).toFixed(2)} ms`;
}

/** Seconds as "m:ss" or "h:mm:ss". */
export function fmtDuration(s) {
  if (!num(s)) return '—';
  const t = Math.floor(s);
  const h = Math.floor(t / 3600), m = Math.floor((t % 3600) / 60), sec = t % 60;
  const two = (x) => String(x).padStart(2, '0');
  return h ? `${h}:${two(m)}:${two(sec)}` : `${m}:${two(sec)}`;
}

/** ISO 8601 (or epoch seconds) → local "HH:MM:SS", with the date when it is not today. */
export function fmtTime(t) {
  if (t === null || t === undefined || t === '') return '—';
  const d = typeof t === 'number' ? new Date(t < 1e12 ? t * 1000 : t) : new Date(t);
  if (Number.isNaN(d.getTime())) return String(t);
  const two = (x) => String(x).padStart(2, '0');
  const time = `${two(d.getHours())}:${two(d.getMinutes())}:${two(d.getSeconds())}`;
  const now = new Date();
  if (d.toDateString() === now.toDateString()) return time;
  return `${d.getFullYear()}-${two(d.getMonth() + 1)}-${two(d.getDate())} ${time}`;
}

/** A nested object as [dotted key, value] pairs (arrays kept whole). */
export function flatten(obj, prefix = '', out = []) {
  for (const [k, v] of Object.entries(obj || {})) {
    const key = prefix ? `${prefix}.${k}` : k;
    if (v && typeof v === 'object' && !Array.isArray(v)) flatten(v, key, out);
    else out.push([key, v]);
  }
  return out;
}

/** A summary value: numbers to 4 digits, [re, im] pairs (poles, zeros) as complex numbers, long lists cut;
 *  null (a non-finite figure, e.g. a restart's J_c) as "—", in a list too. */
export function fmtValue(v) {
  if (v === null || v === undefined) return '—';
  if (typeof v === 'number') return fmtNumber(v, 4);
  if (!Array.isArray(v)) return String(v);
  const item = (x) => {
    if (x === null || x === undefined) return '—';
    if (Array.isArray(x) && x.length === 2 && x.every(num)) {
      const [re, im] = x;
      return im === 0 ? fmtNumber(re, 4) : `${fmtNumber(re, 4)}${im < 0 ? '−' : '+'}${fmtNumber(Math.abs(im), 4)}j`;
    }
    return Array.isArray(x) ? `[${x.map(item).join(', ')}]` : typeof x === 'number' ? fmtNumber(x, 4) : String(x);
  };
  const shown = v.slice(0, 16).map(item).join(', ');
  return v.length > 16 ? `[${shown}, … ${v.length} values]` : `[${shown}]`;
}

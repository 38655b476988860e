// Result plots drawn with uPlot (loaded as the global `uPlot` by index.html).
// Every plot of a job result is an object of equal-length columns (ROUTES.md "Jobs"); this file knows
// which column is the x axis of each and how to label and colour the others. Drag to zoom, double-click
// to reset (uPlot's own behaviour).

const MEASURED = '#4ea1ff';
const MODEL = '#ff8a3d';
const H2 = '#4ea1ff';
const H3 = '#5fd38d';
const BEFORE = '#ff5c6a';
const EXTRA = ['#c792ea', '#f7c948', '#ff5c8a', '#7fdbca', '#a3be8c'];

/** The series of an evaluate job's plot: one column per configuration, `<row>_<quantity>`. */
function evaluationRows(quantity) {
  return {
    [`plant_${quantity}`]: { label: 'plant alone', stroke: BEFORE },
    [`feedforward_${quantity}`]: { label: 'band-pass + feedforward', stroke: MEASURED },
    [`feedback_${quantity}`]: { label: '+ feedback', stroke: H3 },
  };
}

/** How each known plot is drawn; columns it does not name are drawn too, in extra colours. */
const SPECS = {
  fit: {
    title: 'Fit on the validation record (simulation)',
    x: 't', xLabel: 'time (s)', yLabel: 'response',
    series: {
      measured: { label: 'measured', stroke: MEASURED, width: 2 },
      simulated: { label: 'simulated', stroke: MODEL, width: 1.25 },
    },
  },
  spectrum: {
    title: 'Frequency response magnitude',
    x: 'f', xLabel: 'frequency (Hz)', yLabel: 'dB', logX: true,
    series: {
      measured_db: { label: 'measured', stroke: MEASURED },
      model_db: { label: 'model', stroke: MODEL },
    },
  },
  residual_spectrum: {
    title: 'Residual spectrum on the validation record (Welch PSD)',
    x: 'frequency_hz', xLabel: 'frequency (Hz)', yLabel: 'dB re 1 unit²/Hz',
    series: {
      before_db: { label: 'before (baseline)', stroke: BEFORE },
      after_db: { label: 'after (final model)', stroke: MEASURED },
      noise_floor_db: { label: 'noise floor', stroke: H3, dash: [6, 4] },
    },
  },
  harmonics: {
    title: 'Harmonic distortion',
    x: 'f', xLabel: 'fundamental (Hz)', yLabel: 'dB re fundamental', logX: true,
    series: {
      measured_h2_db: { label: 'H2 measured', stroke: H2 },
      model_h2_db: { label: 'H2 model', stroke: H2, dash: [6, 4] },
      measured_h3_db: { label: 'H3 measured', stroke: H3 },
      model_h3_db: { label: 'H3 model', stroke: H3, dash: [6, 4] },
    },
  },
  response: {
    title: 'Response of the chain on the transducer (program → measured output)',
    x: 'f', xLabel: 'frequency (Hz)', yLabel: 'dB', logX: true,
    series: evaluationRows('db'),
  },
  thd: {
    title: 'THD at each probe (%)',
    x: 'f', xLabel: 'probe (Hz)', yLabel: 'THD (%)', logX: true, logY: 'auto',
    series: evaluationRows('thd_pct'),
  },
  history: {
    title: 'Performance J per iteration (simulation error, %)',
    x: 'iteration', xLabel: 'iteration', yLabel: 'J (%)', logY: 'auto',
    series: {
      j_est_pct: { label: 'J estimation', stroke: MEASURED },
      j_val_pct: { label: 'J validation', stroke: MODEL },
    },
  },
};

/** An evaluate job's THD-versus-level plot at one probe, `thd_vs_level_<Hz>` (as Klippel plots it). */
function levelSpec(name) {
  return {
    title: `THD against output level at ${name.slice('thd_vs_level_'.length)} Hz (chain and plant alone at equal output)`,
    x: 'level', xLabel: 'fundamental at the sensor (V)', yLabel: 'THD (%)', logX: true, logY: true,
    series: {
      chain_thd_pct: { label: 'chain', stroke: MEASURED },
      plant_thd_pct: { label: 'plant alone', stroke: BEFORE },
    },
  };
}

/** The order in which a result's plots are shown; unknown plot names follow. */
export const PLOT_ORDER = ['fit', 'spectrum', 'residual_spectrum', 'harmonics', 'response', 'thd', 'history'];

const AXIS = { stroke: '#aab4c0', grid: { stroke: 'rgba(160,175,190,0.14)', width: 1 },
               ticks: { stroke: 'rgba(160,175,190,0.3)', width: 1 } };

/** Axis tick labels: 50, 500, 2k, 1.5k, 0.25 — short, engineering style. */
function tickLabel(v) {
  if (v == null) return '';
  const a = Math.abs(v);
  if (a >= 1000) return `${+(v / 1000).toPrecision(3)}k`;
  if (a !== 0 && a < 0.01) return v.toExponential(0);
  return String(+v.toPrecision(3));
}

const ticks = (u, splits) => splits.map(tickLabel);

/** Which ticks of a log axis get a label: 1-2-5 per decade when a decade is wide enough, else decades. */
function logTickFilter(u, splits, axisIdx) {
  const key = u.axes[axisIdx].scale;
  const decadePx = Math.abs(u.valToPos(100, key) - u.valToPos(10, key));
  const keep = decadePx * Math.log10(2) >= 36 ? [1, 2, 5] : [1];
  return splits.map((v) => {
    if (!(v > 0)) return null;
    const mantissa = Math.round(v / 10 ** Math.floor(Math.log10(v) + 1e-9));
    return keep.includes(mantissa) ? v : null;
  });
}

function finite(v) {
  return typeof v === 'number' && Number.isFinite(v) ? v : null;
}

/** Columns → uPlot's [x[], y1[], …], rows sorted by x; rows whose x is unusable (or ≤ 0 on a log axis) dropped. */
function toData(columns, xKey, keys, logX, logY) {
  const x = columns[xKey] || [];
  const rows = [];
  for (let i = 0; i < x.length; i++) {
    const xv = finite(x[i]);
    if (xv === null || (logX && xv <= 0)) continue;
    rows.push(i);
  }
  rows.sort((a, b) => x[a] - x[b]);
  const data = [rows.map((i) => x[i])];
  for (const k of keys) {
    const col = columns[k] || [];
    data.push(rows.map((i) => {
      const v = finite(col[i]);
      return logY && v !== null && v <= 0 ? null : v;
    }));
  }
  return data;
}

/** Whether a J history spans enough decades (and stays positive) to be worth a log axis. */
function wantsLogY(columns, keys) {
  let lo = Infinity, hi = -Infinity;
  for (const k of keys) {
    for (const v of columns[k] || []) {
      if (typeof v !== 'number' || !Number.isFinite(v)) continue;
      if (v <= 0) return false;
      lo = Math.min(lo, v);
      hi = Math.max(hi, v);
    }
  }
  return Number.isFinite(lo) && hi / lo > 20;
}

/**
 * Draws plot `name` of a result into `host` (emptied first). Returns the uPlot instance (with
 * `.dispose()` that also stops following the host's size), or null when the plot has no data.
 */
export function drawPlot(host, name, columns) {
  host.replaceChildren();
  const spec = SPECS[name] || (name.startsWith('thd_vs_level_') ? levelSpec(name) : null) || { title: name, x: Object.keys(columns)[0], xLabel: Object.keys(columns)[0],
                                yLabel: '', series: {} };
  const keys = Object.keys(columns).filter((k) => k !== spec.x && Array.isArray(columns[k]));
  // Known series first in the spec's order, then whatever else the server sent.
  const known = Object.keys(spec.series).filter((k) => keys.includes(k));
  const ordered = known.concat(keys.filter((k) => !known.includes(k)));
  if (!Array.isArray(columns[spec.x]) || ordered.length === 0) return null;
  const logY = spec.logY === 'auto' ? wantsLogY(columns, ordered) : !!spec.logY;
  const data = toData(columns, spec.x, ordered, spec.logX, logY);
  if (data[0].length === 0) return null;

  let extra = 0;
  const series = [{ label: spec.xLabel }];
  for (const k of ordered) {
    const s = spec.series[k] || { label: k.replace(/_/g, ' '), stroke: EXTRA[extra++ % EXTRA.length] };
    series.push({ label: s.label, stroke: s.stroke, width: s.width ?? 1.5, dash: s.dash, points: { show: false },
                  spanGaps: false });
  }

  const width = Math.max(320, Math.floor(host.clientWidth || 600));
  const opts = {
    title: spec.title,
    width,
    height: 260,
    series,
    scales: {
      // A log axis spans the data, not whole decades (uPlot's default), so a 3 kHz rate's band fills the plot.
      x: { time: false, ...(spec.logX ? { distr: 3, log: 10, range: (u, lo, hi) => [lo, hi] } : {}) },
      y: logY ? { distr: 3, log: 10 } : {},
    },
    axes: [
      { ...AXIS, label: spec.xLabel, values: ticks, ...(spec.logX ? { filter: logTickFilter } : {}) },
      { ...AXIS, label: spec.yLabel, size: 60, values: ticks },
    ],
    legend: { live: true },
    cursor: { drag: { x: true, y: false } },
  };
  const plot = new window.uPlot(opts, data, host);
  const resize = new ResizeObserver(() => {
    const w = Math.max(320, Math.floor(host.clientWidth));
    if (w !== plot.width) plot.setSize({ width: w, height: 260 });
  });
  resize.observe(host);
  plot.dispose = () => {
    resize.disconnect();
    plot.destroy();
  };
  return plot;
}

/** The title a plot is shown under (for its placeholder while empty). */
export function plotTitle(name) {
  return SPECS[name]?.title || (name.startsWith('thd_vs_level_') ? levelSpec(name).title : name);
}

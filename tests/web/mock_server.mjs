#!/usr/bin/env node
// A stand-in for `panelbass serve`, for developing and checking the web UI without the C++ server:
// it serves web/ and answers the routes of api/ROUTES.md with canned, plausible data (jobs progress over
// ~2 s, identify jobs make a model with fit/spectrum/history plots, design-nn jobs a summary with the restarts and
// the design's params, diagnose jobs a one-finding report, an identify-narx job without nk a `warnings` entry; its
// start-up demo drives at the limiter — needs_more_drive, the limiter's shares of the last second, peak_drive 0.9999 —
// until POST /mock/program makes it quieter; model summaries list their `slots`; activation takes controllers only,
// each into its slot). Same
// command line and first stdout line as the real server, so the browser tests can drive it (ctest
// web.ui_on_debian12_node runs ui_mock_test.mjs against it):
//   node tests/web/ui_mock_test.mjs --server tests/web/mock_server.mjs --artifacts /tmp/ui
// Not a test of the server: the real test runs against build/bin/panelbass.

import http from 'node:http';
import fs from 'node:fs';
import path from 'node:path';
import crypto from 'node:crypto';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const webRoot = path.resolve(here, '../../web');

const args = process.argv.slice(2);
if (args[0] !== 'serve') {
  console.error('usage: mock_server.mjs serve [--port N] [--store DIR] [--web DIR] [--no-demo] [--job-step-ms N]');
  process.exit(2);
}
const portArg = args.indexOf('--port');
const port = portArg >= 0 ? Number(args[portArg + 1]) : 8080;
// --job-step-ms N: a job's ten progress steps N ms apart (default 200: a job takes ~2 s).
const stepArg = args.indexOf('--job-step-ms');
const jobStepMs = stepArg >= 0 ? Number(args[stepArg + 1]) : 200;
// The program the engine plays, as the status reports it (api/ROUTES.md "Status"): with the start-up demo it
// starts "over" — noise at 0.2 into a chain whose safe amplitude is lower, as the real server's demo did (issue
// #31): 3.2 % of the samples compressed and 0.4 % asking for full scale or more over the last second, so
// needs_more_drive, and the peak drive 0.9999 since start; without the demo "quiet" (nothing sent). A test sets
// it with POST /mock/program {"level":"over"|"limiting"|"quiet"} (a route of the mock only) to see the UI's
// limiter message come and go; the peak drive and demand since start never go down, as the server's.
const PROGRAM_LEVELS = {
  quiet: { limited_fraction: 0, over_range_fraction: 0, peak_drive: 0, peak_demand: 0 },
  limiting: { limited_fraction: 0.012, over_range_fraction: 0, peak_drive: 0.93, peak_demand: 0.97 },
  over: { limited_fraction: 0.032, over_range_fraction: 0.004, peak_drive: 0.9999, peak_demand: 1.37 },
};
let program = args.includes('--no-demo') ? 'quiet' : 'over';
const limiter = { peak_drive: 0, peak_demand: 0, limited_samples: 0, over_range_samples: 0, counted_to: 0 };

const FS = 3000;
const started = Date.now();
const models = new Map();   // id → {summary, model}
const jobs = new Map();     // id → record
let nextJob = 1;
const active = { feedforward: null, feedback: null };
// What GET /api/program says plays (PUT /api/program replaces it; /mock/program above only sets the limiter's story).
let playing = { signal: 'noise', amplitude: 0.2, seed: 1, source: 'memory', rate: FS, fade_s: 0.025 };
let config = {
  band_pass: { low_hz: 20, high_hz: 1200, order: 2, bypass: false },
  feedforward: { model: null, bypass: false },
  feedback: { model: null, source: 'model', bypass: false },
  crossfade_ms: 20, limiter: { knee: 0.8, pinned_level: 1.0, max_pinned_ms: 100 },
  fs: FS, block: 64, history: 512,
};
const now = () => new Date().toISOString().replace(/\.\d+Z$/, 'Z');

/** The limiter's figures at `up` seconds: the counters and peaks since start (the program's level so far), and
 *  the program's shares over the last second (the window, up to 1 s, is 0 in the first 0.1 s as the server's). */
function limiterMetrics(up) {
  const level = PROGRAM_LEVELS[program];
  const samples = Math.floor(up * FS) - limiter.counted_to;
  if (samples > 0) {
    limiter.limited_samples += Math.round(samples * level.limited_fraction);
    limiter.over_range_samples += Math.round(samples * level.over_range_fraction);
    limiter.counted_to += samples;
  }
  limiter.peak_drive = Math.max(limiter.peak_drive, level.peak_drive);
  limiter.peak_demand = Math.max(limiter.peak_demand, level.peak_demand);
  const span = up < 0.1 ? 0 : Math.min(1, up);
  return { peak_drive: limiter.peak_drive, peak_demand: limiter.peak_demand, limited_samples: limiter.limited_samples,
           over_range_samples: limiter.over_range_samples, limiter_window_s: span,
           limited_fraction: span ? level.limited_fraction : 0, over_range_fraction: span ? level.over_range_fraction : 0,
           needs_more_drive: span > 0 && level.over_range_fraction > 0 };
}

function send(res, status, body, type = 'application/json') {
  const text = type === 'application/json' ? JSON.stringify(body) : body;
  res.writeHead(status, { 'Content-Type': type, 'Cache-Control': 'no-store' });
  res.end(text);
}
const fail = (res, status, code, message) => send(res, status, { error: { code, message } });

function readBody(req) {
  return new Promise((resolve) => {
    let data = '';
    req.on('data', (c) => { data += c; });
    req.on('end', () => resolve(data));
  });
}

function storeModel(model, name, source) {
  const id = 'm' + crypto.createHash('sha256').update(JSON.stringify(model)).digest('hex').slice(0, 12);
  const fresh = !models.has(id);
  if (fresh) models.set(id, { summary: { id, kind: model.kind, fs: model.fs, name: name || '', created: now(), source }, model });
  return { id, fresh };
}

// A model's summary: what the store keeps, where it is active, and the slots that run it (`slots`: a controller's
// own slot, none for a plant model).
const modelSummary = (id) => {
  const { summary } = models.get(id);
  return { ...summary, active_in: Object.entries(active).filter(([, v]) => v === id).map(([k]) => k),
           slots: SLOT_OF_KIND[summary.kind] ? [SLOT_OF_KIND[summary.kind]] : [] };
};

function plots(kind) {
  const n = 600, t = [], measured = [], simulated = [];
  for (let i = 0; i < n; i++) {
    t.push(i / FS);
    const y = Math.sin(2 * Math.PI * 50 * i / FS) + 0.4 * Math.sin(2 * Math.PI * 310 * i / FS + 1);
    measured.push(y + 0.05 * Math.sin(i * 1.7));
    simulated.push(y);
  }
  const f = [], mdb = [], odb = [];
  for (let i = 0; i <= 200; i++) {
    const fr = (i * FS) / 2 / 200;
    f.push(fr);
    const h = 20 * Math.log10(1 / Math.hypot(1 - (fr / 180) ** 2, 0.3 * fr / 180) + 1e-3);
    mdb.push(h + 0.5 * Math.sin(i));
    odb.push(h);
  }
  const out = { fit: { t, measured, simulated }, spectrum: { f, measured_db: mdb, model_db: odb },
                history: { iteration: [0, 1, 2, 3, 4, 5], j_est_pct: [40, 12, 4, 2.1, 1.9, 1.85], j_val_pct: [42, 13, 4.5, 2.4, 2.2, 2.2] } };
  if (kind === 'identify-narx') {
    const hf = [50, 80, 120, 200, 300, 450];
    out.harmonics = { f: hf, measured_h2_db: hf.map((x) => -30 - x / 30), measured_h3_db: hf.map((x) => -40 - x / 40),
                      model_h2_db: hf.map((x) => -31 - x / 30), model_h3_db: hf.map((x) => -41 - x / 40) };
  }
  if (kind === 'diagnose') {
    const rf = f.slice(1);
    const peak = (x, at, width) => 14 * Math.exp(-(((x - at) / width) ** 2));
    out.residual_spectrum = { frequency_hz: rf, before_db: rf.map((x, i) => -52 + peak(x, 150, 40) + 0.6 * Math.sin(i)),
                              after_db: rf.map((x, i) => -52 + 0.4 * peak(x, 150, 40) + 0.6 * Math.sin(i + 1)),
                              noise_floor_db: rf.map(() => -52.5) };
    delete out.spectrum;
    delete out.history;
  }
  return out;
}

// A diagnose job's report (api/ROUTES.md "Jobs"): one cubic-spring finding.
const diagnosisReport = (params) => ({
  baseline: { kind: 'linear', source: params.baseline_model ? 'given' : 'identified', method: 'oe', na: 8, nb: 8, nk: 1,
              J_val_pct: 4.6, J_est_pct: 5.4 },
  channels: { used: ['drive', 'output', 'current'], current: { path: { method: 'oe', na: 8, nb: 8, nk: 0 }, J_val_pct: 1.9 } },
  findings: [{ effect: 'cubic_stiffness', J_val_before_pct: 4.6, J_val_after_pct: 2.5,
               explanation: 'The model leaves out a cubic stiffness (a spring that hardens or softens with excursion): '
                 + 'the residual follows the cube of the estimated output (odd and level-dependent; correlation 0.54).',
               confidence: { word: 'clear', runner_up: 'force_factor', runner_up_variant: 'output', margin_bic: 31.2, explained_share: 0.54,
                             sentence: 'clear: cubic_stiffness fits better than the runner-up, force_factor (BIC margin 31.2); it explains 54 % of J above the noise floor.' } }],
  J_val_before_pct: 4.6, J_val_after_pct: 2.5, noise_floor_pct: 0.69, at_noise_floor: false, j_val_pct: 2.5,
  location: { validation: {
    peak_frequency_hz: 152.3, peak_over_noise: 41.0, peak_threshold: 1.4, peak_significant: true, change_time_s: 0.4, change_ratio: 1.02, change_t: 0.6,
    change_significant: false,
    frf_error: { significant: true, frequency_hz: 152.3, band_low_hz: 140.6, band_high_hz: 164.1, relative_db: -18.2,
                 coherence: 0.62, threshold: 0.31 },
    distortion: { periodic: false },
    states: [{ state: 'input', shape_chi2: 1.1, level_ratio: 1.0, direction_t: 0.4, shape_significant: false, direction_significant: false },
             { state: 'output', shape_chi2: 24.0, level_ratio: 1.9, direction_t: 1.2, shape_significant: true, direction_significant: false }] } },
  rule: 'an augmentation is kept when N·ln(J_before/J_after) > p·ln(N) on the N validation samples (BIC)',
});

// A design-nn job's summary (api/ROUTES.md "Jobs"): the J_c figures, the restarts' validation J_c and the one
// kept, and the design's params with the server's defaults filled in.
function designNnSummary(params) {
  const design = { samples: 3000, max_iterations: 20, hidden: [6], nu: 2, nv: 2, ny: 4, sine_share: 0.75, sine_peak: 0.6,
                   program_share: 0, restarts: 1, rail_penalty: 10, dc_penalty: 1, seed: 1 };
  for (const k of Object.keys(design)) if (params[k] !== undefined) design[k] = params[k];
  const restartJc = Array.from({ length: design.restarts }, (_, r) => 2.4 - 0.3 * Math.sin(r + design.seed));
  const chosen = restartJc.indexOf(Math.min(...restartJc));
  return { figure: 'J_c [2C]: loop output (plant model) against the desired linear response',
           plant_model: params.plant_model, feedforward_model: params.feedforward_model ?? null, parameters: 55,
           iterations: design.max_iterations, jc_val_before_pct: 9.7, jc_val_after_pct: restartJc[chosen], rail_fraction: 0,
           chosen_restart: chosen, restart_jc_val_pct: restartJc, bandpass: [20, 1200], bandpass_order: 2, ...design };
}

const summaryOf = (j) => ({ id: j.id, kind: j.kind, state: j.state, progress: j.progress, message: j.message,
                            created: j.created, finished: j.finished, error: j.error,
                            ...(j.warnings.length ? { warnings: j.warnings } : {}) });

// The slot each controller kind goes into; a plant model (linear, narx) goes into none.
const SLOT_OF_KIND = { lq_feedforward: 'feedforward', mirror_filter: 'feedforward', neural_feedback: 'feedback' };

function emit(job, type, data) {
  for (const res of job.listeners) res.write(`event: ${type}\ndata: ${JSON.stringify(data)}\n\n`);
  if (type === 'state' && ['succeeded', 'failed', 'cancelled'].includes(data.state)) {
    for (const res of job.listeners) res.end();
    job.listeners = [];
  }
}

// A tune job's result (api/ROUTES.md "Jobs", usecases/tune.h): its steps, the decision, verify's points at equal
// output (one cut a number, one a bound where the chain's THD is at the noise, one level the chain cannot reach)
// and a THD-versus-level plot; the mirror filter kept.
function tuneResult() {
  const reading = (thd) => ({ thd_pct: thd, floor_pct: 0.05, noise_bound: false, uncertainty_db: 0.1 });
  const atNoise = { thd_pct: null, floor_pct: 0.3, noise_bound: true, uncertainty_db: null, at_most_pct: 0.42 };
  const point = (f, level, extra) => ({ frequency_hz: f, program_level: level, reachable: true, chain_drive_peak: 0.4,
                                        output_level: 0.5 * level, plant_drive: 0.9 * level, plant_output_level: 0.5 * level, ...extra });
  const points = [
    point(80, 0.1, { chain: reading(0.3), plant: reading(3.0), thd_cut_db: 20, thd_cut_at_least_db: null }),
    point(80, 0.2, { chain: atNoise, plant: reading(8.4), thd_cut_db: null, thd_cut_at_least_db: 20 * Math.log10(8.4 / 0.42) }),
    point(80, 0.3, { reachable: false, unreachable_because: "the chain's limiter acts (drive peak 1)", chain: reading(0), plant: null,
                     thd_cut_db: null, thd_cut_at_least_db: null }),
  ];
  return { keep: true, decision: 'kept: it cuts the THD by 20 to 26 dB at equal output over the 2 levels verified',
           steps: ['measure', 'fit', 'refine', 'verify', 'decide'].map((name, n) => ({ name, seconds: 2 + n, summary: {} })),
           verify: { points, plays: 3, warnings: [], worst_cut_db: { 80: 20 } }, backend: 'virtual',
           plots: { thd_vs_level_80: { level: [0.05, 0.1], chain_thd_pct: [0.3, 0.42], plant_thd_pct: [3.0, 8.4] } } };
}

function runJob(job) {
  let step = 0;
  const steps = 10;
  const timer = setInterval(() => {
    if (job.state === 'cancelled') { clearInterval(timer); return; }
    if (job.state === 'queued') {
      job.state = 'running';
      emit(job, 'state', { state: 'running' });
    }
    step++;
    job.progress = step / steps;
    job.message = `${job.kind} iteration ${step}`;
    emit(job, 'progress', { progress: job.progress, message: job.message });
    if (step < steps) return;
    clearInterval(timer);
    const result = job.kind === 'diagnose' ? { ...diagnosisReport(job.params), plots: plots(job.kind) }
      : { j_est_pct: 1.85, j_val_pct: 2.2, summary: { method: job.params.method || 'oe', order: job.params.order ?? 8, delay: 1 },
          plots: plots(job.kind) };
    // identify-narx without nk: the delay estimated far too long and a model no better than zero (issue #31).
    if (job.kind === 'identify-narx' && job.params.nk === undefined) {
      Object.assign(result, { j_est_pct: 100.4, j_val_pct: 100.3, summary: { na: 10, nb: 10, nk: 1001 } });
      job.warnings.push('J_val 100.3 % is no better than predicting zero; the delay estimate nk = 1001 is longer '
                        + 'than the lags support: set nk (e.g. 1)');
    }
    if (job.kind === 'design-nn') {
      result.summary = designNnSummary(job.params);
      result.j_val_pct = result.summary.jc_val_after_pct;
    }
    // verify reports at equal output level, as tune's verify step does (api/ROUTES.md "Jobs").
    if (job.kind === 'verify') Object.assign(result, tuneResult().verify, { backend: 'virtual' });
    if (job.kind === 'tune') Object.assign(result, tuneResult());
    if (job.kind !== 'excite' && job.kind !== 'analyze' && job.kind !== 'diagnose' && job.kind !== 'verify') {
      const kind = { 'identify-linear': 'linear', 'identify-narx': 'narx', 'design-lq': 'lq_feedforward', 'design-nn': 'neural_feedback',
                     tune: 'mirror_filter' }[job.kind];
      const { id } = storeModel({ format: 'panelbass.model/1', kind, fs: FS, params: { job: job.id, p: job.params } }, `${job.kind} ${job.id}`, job.id);
      result.model_id = id;
      if (job.kind === 'tune') result.mirror_model_id = id;
      if (job.activate) {
        const slot = SLOT_OF_KIND[kind];
        if (slot) {
          active[slot] = id;
          job.activated = { slot, id };
        }
      }
    }
    job.result = result;
    job.state = 'succeeded';
    job.finished = now();
    emit(job, 'state', { state: 'succeeded' });
  }, jobStepMs);
}

const MIME = { '.html': 'text/html; charset=utf-8', '.js': 'text/javascript; charset=utf-8', '.mjs': 'text/javascript; charset=utf-8',
               '.css': 'text/css; charset=utf-8', '.json': 'application/json', '.png': 'image/png', '.svg': 'image/svg+xml' };

function serveStatic(req, res, pathname) {
  const rel = decodeURIComponent(pathname === '/' ? '/index.html' : pathname);
  const file = path.resolve(webRoot, '.' + rel);
  if (!file.startsWith(webRoot + path.sep)) return fail(res, 404, 'not_found', 'no such file');
  fs.readFile(file, (err, data) => {
    if (err) return fail(res, 404, 'not_found', `no such file: ${rel}`);
    res.writeHead(200, { 'Content-Type': MIME[path.extname(file)] || 'application/octet-stream' });
    res.end(data);
  });
}

async function handle(req, res) {
  const url = new URL(req.url, 'http://x');
  const p = url.pathname;
  const m = req.method;
  let match;
  if (p === '/mock/program' && m === 'POST') {
    let body;
    try { body = JSON.parse(await readBody(req)); } catch { return fail(res, 400, 'bad_request', 'malformed JSON'); }
    if (!(body?.level in PROGRAM_LEVELS)) return fail(res, 400, 'bad_request', `level: one of ${Object.keys(PROGRAM_LEVELS).join(', ')}`);
    limiterMetrics((Date.now() - started) / 1000);  // the counters up to now at the old level
    program = body.level;
    return send(res, 200, { level: program });
  }
  if (!p.startsWith('/api/')) return serveStatic(req, res, p);
  if (p === '/api/health' && m === 'GET') return send(res, 200, { status: 'ok', version: '0.1.0-mock' });
  if (p === '/api/status' && m === 'GET') {
    const running = [...jobs.values()].filter((j) => j.state === 'running').length;
    const queued = [...jobs.values()].filter((j) => j.state === 'queued').length;
    const up = (Date.now() - started) / 1000;
    return send(res, 200, {
      engine: { state: 'running', backend: 'virtual', plant: 'panel-exciter', fs: FS, block: 64, uptime_s: up },
      metrics: { blocks: Math.floor(up * FS / 64), samples: Math.floor(up * FS), xruns: 0, faults: 0, in_fault: false, last_fault: '',
                 swaps: 0, mean_block_ns: 8200, p99_block_ns: 14100, max_block_ns: 30100, ns_per_sample: 128, load: 0.0066,
                 ...limiterMetrics(up) },
      active_models: active, jobs: { queued, running } });
  }
  if (p === '/api/config' && m === 'GET') {
    return send(res, 200, { ...config, feedforward: { ...config.feedforward, model: active.feedforward }, feedback: { ...config.feedback, model: active.feedback } });
  }
  if (p === '/api/config' && m === 'PATCH') {
    let patch;
    try { patch = JSON.parse(await readBody(req)); } catch { return fail(res, 400, 'bad_request', 'malformed JSON'); }
    if (patch.band_pass && patch.band_pass.low_hz !== undefined && patch.band_pass.low_hz >= (patch.band_pass.high_hz ?? config.band_pass.high_hz)) {
      return fail(res, 400, 'bad_request', 'band_pass.low_hz: must be below band_pass.high_hz');
    }
    const keys = [];
    const merge = (dst, src, prefix) => {
      for (const [k, v] of Object.entries(src)) {
        if (v && typeof v === 'object') merge(dst[k], v, prefix + k + '.');
        else { dst[k] = v; keys.push(prefix + k); }
      }
    };
    merge(config, patch, '');
    return send(res, 200, { config, change: { kind: keys.some((k) => k.startsWith('band_pass.') && !k.endsWith('bypass')) ? 'rebuild with crossfade' : 'in place', keys } });
  }
  if (p === '/api/program' && m === 'GET') return send(res, 200, { ...playing, settled: true });
  if (p === '/api/program' && m === 'PUT') {
    let body;
    try { body = JSON.parse(await readBody(req)); } catch { return fail(res, 400, 'bad_request', 'malformed JSON'); }
    const sine = /^sine:([0-9.eE+-]+)$/.exec(body?.signal ?? '');
    if (!(body?.signal === 'noise' || body?.signal === 'silence' || (sine && Number(sine[1]) > 0 && Number(sine[1]) < FS / 2))) {
      return fail(res, 400, 'bad_request', `program.signal: expected "noise", "silence" or "sine:HZ" (e.g. "sine:80"), got ${JSON.stringify(body?.signal)}`);
    }
    const amplitude = body.signal === 'silence' ? 0 : (body.amplitude ?? 0.2);
    if (typeof amplitude !== 'number' || amplitude < 0 || amplitude > 1) {
      return fail(res, 400, 'bad_request', `program.amplitude: must be finite and within [0, 1], got ${JSON.stringify(body.amplitude)}`);
    }
    playing = { signal: body.signal, amplitude, source: 'memory', rate: FS, fade_s: 0.025,
                ...(sine ? { frequency_hz: Number(sine[1]) } : {}), ...(body.signal === 'noise' ? { seed: body.seed ?? 1 } : {}) };
    return send(res, 200, { ...playing, settled: false });
  }
  if (p === '/api/records' && m === 'GET') return send(res, 200, { records: [], total: 0, offset: 0, limit: 1000 });
  if (p === '/api/models' && m === 'GET') return send(res, 200, { models: [...models.keys()].map(modelSummary) });
  if (p === '/api/models' && m === 'POST') {
    let model;
    try { model = JSON.parse(await readBody(req)); } catch { return fail(res, 400, 'bad_request', 'malformed JSON'); }
    if (model.format !== 'panelbass.model/1') return fail(res, 400, 'bad_request', 'format: must be "panelbass.model/1"');
    const { id, fresh } = storeModel(model, url.searchParams.get('name'), 'upload');
    return send(res, fresh ? 201 : 200, modelSummary(id));
  }
  if ((match = p.match(/^\/api\/models\/([A-Za-z0-9_-]{1,64})(\/activate)?$/))) {
    const id = match[1];
    if (!models.has(id)) return fail(res, 404, 'not_found', `no model ${id}`);
    if (match[2] && m === 'POST') {
      const kind = models.get(id).summary.kind;
      let body = {};
      try { body = JSON.parse((await readBody(req)) || '{}'); } catch { return fail(res, 400, 'bad_request', 'malformed JSON'); }
      const slot = body.slot ?? SLOT_OF_KIND[kind];
      if (!SLOT_OF_KIND[kind]) return fail(res, 409, 'conflict', `${id} is a ${kind} model (a plant): no slot takes it`);
      if (slot !== SLOT_OF_KIND[kind]) return fail(res, 409, 'conflict', `slot ${slot} takes no ${kind} model`);
      active[slot] = id;
      return send(res, 200, { slot, id, change: { kind: 'rebuild with crossfade', keys: [`${slot}.model`] } });
    }
    if (m === 'GET') return send(res, 200, { ...modelSummary(id), model: models.get(id).model });
    if (m === 'DELETE') {
      if (Object.values(active).includes(id)) return fail(res, 409, 'conflict', `${id} is active`);
      models.delete(id);
      res.writeHead(204);
      return res.end();
    }
  }
  if (p === '/api/jobs' && m === 'GET') return send(res, 200, { jobs: [...jobs.values()].map(summaryOf) });
  if (p === '/api/jobs' && m === 'POST') {
    let body;
    try { body = JSON.parse(await readBody(req)); } catch { return fail(res, 400, 'bad_request', 'malformed JSON'); }
    const params = body.params || {};
    if (params.order !== undefined && (!Number.isInteger(params.order) || params.order < 1)) {
      return fail(res, 400, 'bad_request', `params.order: must be an integer ≥ 1, got ${JSON.stringify(params.order)}`);
    }
    if (['design-lq', 'design-nn'].includes(body.kind) && !params.plant_model) return fail(res, 400, 'bad_request', 'params.plant_model: required');
    // As the real server (api/jobs/design_nn_job.cpp): the neural feedback is designed behind its feedforward.
    if (body.kind === 'design-nn' && !params.feedforward_model) return fail(res, 400, 'bad_request', 'params.feedforward_model: required');
    const id = `j${nextJob++}`;
    const job = { id, kind: body.kind, state: 'queued', progress: 0, message: '', created: now(), finished: '', error: '',
                  params, activate: !!body.activate, result: null, activated: null, listeners: [], warnings: [] };
    jobs.set(id, job);
    runJob(job);
    return send(res, 202, { id, kind: job.kind, state: job.state });
  }
  if ((match = p.match(/^\/api\/jobs\/([A-Za-z0-9_-]{1,64})(\/events)?$/))) {
    const job = jobs.get(match[1]);
    if (!job) return fail(res, 404, 'not_found', `no job ${match[1]}`);
    if (match[2] && m === 'GET') {
      res.writeHead(200, { 'Content-Type': 'text/event-stream', 'Cache-Control': 'no-store' });
      res.write(`event: state\ndata: ${JSON.stringify({ state: job.state })}\n\n`);
      if (['succeeded', 'failed', 'cancelled'].includes(job.state)) return res.end();
      job.listeners.push(res);
      return;
    }
    if (m === 'GET') return send(res, 200, { ...summaryOf(job), params: job.params, result: job.result, activated: job.activated });
    if (m === 'DELETE') {
      if (['succeeded', 'failed', 'cancelled'].includes(job.state)) return fail(res, 409, 'conflict', `${job.id} already ${job.state}`);
      job.state = 'cancelled';
      job.finished = now();
      emit(job, 'state', { state: 'cancelled' });
      return send(res, 200, summaryOf(job));
    }
  }
  return fail(res, 404, 'not_found', `no route ${m} ${p}`);
}

const server = http.createServer((req, res) => {
  handle(req, res).catch((e) => fail(res, 500, 'internal', e.message));
});
server.listen(port, '127.0.0.1', () => {
  console.log(`panelbass: serving http://127.0.0.1:${server.address().port}/`);
});
process.on('SIGTERM', () => process.exit(0));

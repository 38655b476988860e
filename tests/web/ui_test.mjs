// Browser test of the web UI against a real `panelbass serve`:
//   node tests/web/ui_test.mjs --server build/bin/panelbass --artifacts build/test-artifacts
// Starts the server on a free port with a fresh store and no demo, drives Debian's headless Chromium
// (/usr/bin/chromium, through playwright-core from web/node_modules; no browser is downloaded; tests/web/harness.mjs)
// and checks, as a person would: the status is shown, peak drive included, and the limiter's activity over the
// last second as none (nothing is played); an "Excite + identify" job (identify-linear, 3000 samples, order 6)
// started from the form runs with its progress shown and succeeds; its model, a plant (the server lists no slot
// for it), is offered no Activate (the result and the store say it is a plant); the fit plot is drawn (uPlot
// canvas with the series' colours in it); a "Diagnose" job (its own 3000 + 2000-sample excitation, the identified
// model as baseline, one finding at most) shows the baseline, J before and after, the noise floor, the
// findings table (or its "no finding" line), the location sentences as the server's verdict fields decide
// them, and the residual-spectrum plot; an LQ feedforward designed on the identified model is activated
// with "Activate as feedforward" and appears as the active feedforward model in the status; a small NARX plant
// identified, a "Design NN feedback" job with every field of its form set off its default sends each value in
// its request body, succeeds, and its summary shows the restart kept, every restart's validation J_c and the
// design's params; an evaluate job shows its figures; after a reload the newest finished job's result and plots
// are shown without a click, with the hint that a click shows another's; a CSV recording uploaded from the records
// form is listed, a bad one refused naming its line, an identification takes the uploaded record as its data
// (split by the form's validation share) and the record is deleted. Saves the page after the tour as
// $PANELBASS_SCREENSHOT (default ARTIFACTS/ui.png; docs/images/ui.png is one), ui-diagnosis.png (the diagnose
// job's result panel), ui-server.log and ui-console.log.
// Exit 0 on success; 1 with "ui_test: FAIL <step>: <reason>" otherwise; 2 on bad usage.

import fs from 'node:fs';
import path from 'node:path';
import { BrowserRun, check, parseArgs, TestFailure, until } from './harness.mjs';

const OVERALL_TIMEOUT_MS = 90_000;
const JOB_TIMEOUT_MS = 60_000;
// The fit plot's series colours (web/plots.js: MEASURED, MODEL).
const SERIES_RGB = [[0x4e, 0xa1, 0xff], [0xff, 0x8a, 0x3d]];

const { server: serverPath, artifacts } = parseArgs('ui_test');
// The page after the tour, for the README (docs/images/ui.png is one of these).
const screenshotPath = path.resolve(process.env.PANELBASS_SCREENSHOT || path.join(artifacts, 'ui.png'));
const run = new BrowserRun('ui_test', { artifacts, prefix: 'ui', timeoutMs: OVERALL_TIMEOUT_MS });
const log = (m) => run.log(m);
let page = null;

/** Clicks Start on the job form and waits for the job (not `previousId`) to succeed; returns its id. */
async function runFormJob(what, previousId) {
  await page.click('#job-start');
  const id = await until(async () => {
    const err = await page.$eval('#job-error', (e) => (e.hidden ? '' : e.textContent));
    if (err) throw new TestFailure(`the server refused the ${what} job: ${err}`);
    const shown = await page.$eval('#result', (e) => (e.hidden ? '' : e.dataset.jobId || ''));
    return shown && shown !== previousId ? shown : '';
  }, 10_000, `the result panel never showed the ${what} job`);
  const t = Date.now();
  await until(async () => {
    const s = await page.$eval('#result', (e) => e.dataset.state);
    if (['failed', 'cancelled'].includes(s)) throw new TestFailure(`${what} job ${id} ${s}: ${await page.textContent('#result-error')}`);
    return s === 'succeeded';
  }, JOB_TIMEOUT_MS, `${what} job ${id} did not succeed within ${JOB_TIMEOUT_MS / 1000} s`, 100);
  await page.waitForSelector('#result-body:not([hidden])', { timeout: 5000 });
  log(`${what} job ${id} succeeded in ${((Date.now() - t) / 1000).toFixed(1)} s`);
  return id;
}

/** The model id the result panel shows (a model-making job's). */
async function resultModel(what) {
  const id = await page.$eval('#result-activate', (e) => e.dataset.modelId);
  check(/^m[0-9a-f]{12}$/.test(id), `the ${what} result names no model id (got "${id}")`);
  return id;
}

async function main() {
  run.step = 'starting the server';
  const base = await run.startServer(serverPath, ['--no-demo']);
  page = await run.openPage(base);

  run.step = 'status shown';
  await page.waitForSelector('#conn[data-state="online"]', { timeout: 10_000 });
  await until(async () => (await page.textContent('#status-state')).trim() !== '—', 5000, 'engine state never shown');
  const status = await page.evaluate(() => Object.fromEntries(['state', 'backend', 'fs', 'block', 'load', 'p99', 'xruns', 'faults', 'peak-drive']
    .map((k) => [k, document.querySelector(`#status-${k}`).textContent.trim()])));
  check(/\d/.test(status.fs), `sample rate not shown: ${JSON.stringify(status)}`);
  check(status.backend !== '—' && status.xruns !== '—', `status incomplete: ${JSON.stringify(status)}`);
  check(/^\d\.\d{4}$/.test(status['peak-drive']), `peak drive not shown: ${JSON.stringify(status)}`);
  log(`status: ${Object.entries(status).map(([k, v]) => `${k}=${v}`).join(', ')}`);
  // Without the demo nothing is played: once the server has a window, the limiter compressed nothing in it and
  // the status says nothing of needing more drive.
  const limiter = await until(async () => {
    const t = (await page.textContent('#status-limiter')).trim();
    return /^0 % of samples compressed, 0 % over range \(last \d\.\d s\)$/.test(t) ? t : null;
  }, 8000, `the limiter's activity over the last second is not shown as none: "${await page.textContent('#status-limiter')}"`);
  check(await page.isHidden('#status-drive-note'), `a drive note is shown with nothing played: "${await page.textContent('#status-drive-note')}"`);
  log(`limiter: ${limiter}`);
  await until(async () => (await page.inputValue('[name="band_pass.high_hz"]')) !== '', 8000, 'chain settings never loaded from GET /api/config');

  run.step = 'starting an excite + identify job';
  await page.selectOption('#job-kind', 'identify-linear');
  await page.selectOption('#job-source', '');
  await page.fill('#excite-samples', '3000');
  await page.selectOption('#lin-method', 'oe');
  await page.fill('#lin-order', '6');
  await page.click('#job-start');
  const jobId = await until(async () => {
    const err = await page.$eval('#job-error', (e) => (e.hidden ? '' : e.textContent));
    if (err) throw new TestFailure(`the server refused the job: ${err}`);
    return page.$eval('#result', (e) => (e.hidden ? '' : e.dataset.jobId || ''));
  }, 10_000, 'the result panel never showed the started job');
  log(`job ${jobId} started`);

  run.step = `following job ${jobId}`;
  const seen = new Set();
  const t0 = Date.now();
  const final = await until(async () => {
    const s = await page.$eval('#result', (e) => ({ state: e.dataset.state, progress: e.dataset.progress,
      bar: document.querySelector('#job-progress').value, message: document.querySelector('#job-message').textContent,
      transport: e.dataset.transport || '' }));
    seen.add(`${s.bar}`);
    if (['failed', 'cancelled'].includes(s.state)) {
      const err = await page.textContent('#result-error');
      throw new TestFailure(`job ${jobId} ${s.state}: ${err}`);
    }
    return s.state === 'succeeded' ? s : null;
  }, JOB_TIMEOUT_MS, `job ${jobId} did not succeed within ${JOB_TIMEOUT_MS / 1000} s`, 50);
  const intermediate = [...seen].filter((v) => Number(v) > 0 && Number(v) < 1).length;
  log(`job ${jobId} succeeded in ${((Date.now() - t0) / 1000).toFixed(1)} s; progress values seen: ` +
      `${[...seen].map((v) => Math.round(100 * Number(v)) + '%').join(' ')} (${intermediate} between 0 and 100 %, via ${final.transport || '?'})`);
  check(Number(final.bar) === 1, `progress bar at ${final.bar} after success, expected 1`);
  check(await page.isVisible('#job-progress'), 'progress bar not visible');
  const row = `#jobs-table tr[data-job-id="${jobId}"]`;
  await until(async () => (await page.$(row)) && (await page.$eval(row, (e) => e.dataset.state)) === 'succeeded',
              6000, `job ${jobId} not listed as succeeded in the jobs table`);

  run.step = 'result figures';
  await page.waitForSelector('#result-body:not([hidden])', { timeout: 5000 });
  const jVal = (await page.textContent('#result-j-val')).trim();
  check(/\d/.test(jVal), `J validation not shown (got "${jVal}")`);
  const modelId = await page.$eval('#result-activate', (e) => e.dataset.modelId);
  check(/^m[0-9a-f]{12}$/.test(modelId), `the result names no model id (got "${modelId}")`);
  log(`J est ${(await page.textContent('#result-j-est')).trim()}, J val ${jVal}, model ${modelId}`);
  const modelRow = `#models-table tr[data-model-id="${modelId}"]`;
  await page.waitForSelector(modelRow, { timeout: 8000 });

  // An identified linear model is a plant: neither the result nor the store offers to activate it.
  // The server lists no slot for it (`slots: []`), and the UI offers what the server lists.
  run.step = `no Activate on the plant model ${modelId}`;
  const plantSummary = await (await fetch(`${base}api/models/${modelId}`)).json();
  check(Array.isArray(plantSummary.slots) && plantSummary.slots.length === 0,
        `GET /api/models/${modelId} lists slots ${JSON.stringify(plantSummary.slots)} for a plant`);
  await until(async () => await page.isVisible('#result-plant-note'), 5000, 'the identify-linear result never says its model is a plant');
  check(!(await page.isVisible('#result-activate')), 'the identify-linear result offers Activate on a plant model');
  check(/plant/.test(await page.textContent('#result-plant-note')),
        'the identify-linear result does not say its model is a plant');
  check((await page.$$(`${modelRow} button.activate`)).length === 0, `the models table offers Activate on the plant model ${modelId}`);
  const why = (await page.textContent(`${modelRow} .no-slot-note`)).trim();
  check(why === 'a plant model: design a controller on it', `the models table says of the plant model ${modelId}: "${why}"`);

  run.step = 'fit plot drawn';
  await page.waitForSelector('#plot-fit canvas', { timeout: 5000 });
  const pixels = await page.$eval('#plot-fit canvas', (canvas, series) => {
    const ctx = canvas.getContext('2d');
    const { data } = ctx.getImageData(0, 0, canvas.width, canvas.height);
    let painted = 0, seriesPixels = 0;
    for (let i = 0; i < data.length; i += 4) {
      if (data[i + 3] === 0) continue;
      painted++;
      if (data[i + 3] < 128) continue;
      for (const [r, g, b] of series) {
        if (Math.abs(data[i] - r) + Math.abs(data[i + 1] - g) + Math.abs(data[i + 2] - b) <= 90) {
          seriesPixels++;
          break;
        }
      }
    }
    return { width: canvas.width, height: canvas.height, painted, seriesPixels };
  }, SERIES_RGB);
  log(`fit canvas ${pixels.width}x${pixels.height}: ${pixels.painted} painted pixels, ${pixels.seriesPixels} in the series' colours`);
  check(pixels.width > 100 && pixels.height > 100, 'fit canvas too small');
  check(pixels.seriesPixels >= 300, `fit plot looks blank: only ${pixels.seriesPixels} pixels in the series' colours`);
  const plotsShown = await page.$$eval('#plots [data-plot]', (els) => els.map((e) => e.dataset.plot));
  log(`plots shown: ${plotsShown.join(', ')}`);

  run.step = 'starting a diagnose job';
  await page.selectOption('#job-kind', 'diagnose');
  await page.selectOption('#job-source', '');
  await page.fill('#excite-samples', '3000');
  await page.fill('#excite-validation', '2000');
  await page.fill('#excite-amplitude', '0.8');  // loud enough for the exciter's nonlinearity to show
  await page.selectOption('#diag-baseline-model', modelId);
  await page.fill('#diag-max-findings', '1');
  await page.click('#job-start');
  const diagnoseId = await until(async () => {
    const err = await page.$eval('#job-error', (e) => (e.hidden ? '' : e.textContent));
    if (err) throw new TestFailure(`the server refused the diagnose job: ${err}`);
    const id = await page.$eval('#result', (e) => (e.hidden ? '' : e.dataset.jobId || ''));
    return id && id !== jobId ? id : '';
  }, 10_000, 'the result panel never showed the diagnose job');
  log(`diagnose job ${diagnoseId} started`);

  run.step = `following diagnose job ${diagnoseId}`;
  const t1 = Date.now();
  await until(async () => {
    const s = await page.$eval('#result', (e) => e.dataset.state);
    if (['failed', 'cancelled'].includes(s)) throw new TestFailure(`job ${diagnoseId} ${s}: ${await page.textContent('#result-error')}`);
    return s === 'succeeded';
  }, JOB_TIMEOUT_MS, `diagnose job ${diagnoseId} did not succeed within ${JOB_TIMEOUT_MS / 1000} s`, 100);
  log(`diagnose job ${diagnoseId} succeeded in ${((Date.now() - t1) / 1000).toFixed(1)} s`);

  run.step = 'diagnosis shown';
  await page.waitForSelector('#result-diagnosis:not([hidden])', { timeout: 5000 });
  const diagnosis = await page.evaluate(() => ({
    baseline: document.querySelector('#diag-baseline').textContent.trim(),
    before: document.querySelector('#diag-j-before').textContent.trim(),
    after: document.querySelector('#diag-j-after').textContent.trim(),
    floor: document.querySelector('#diag-noise-floor').textContent.trim(),
    channels: document.querySelector('#diag-channels').textContent.trim(),
    verdict: document.querySelector('#diag-verdict').textContent.trim(),
    findings: Array.from(document.querySelectorAll('#diag-findings tbody tr'))
      .map((tr) => Array.from(tr.children).map((td) => td.textContent.trim())),
    tableShown: !document.querySelector('#diag-findings').hidden,
    noneShown: !document.querySelector('#diag-no-findings').hidden,
    genericHidden: document.querySelector('#result-figures').hidden,
    location: Array.from(document.querySelectorAll('#diag-location li')).map((li) => li.textContent.trim()),
  }));
  log(`diagnosis: baseline ${diagnosis.baseline}; J ${diagnosis.before} → ${diagnosis.after}, noise floor ${diagnosis.floor}; ` +
      `${diagnosis.findings.length} finding(s)${diagnosis.findings.map(([, effect, , j]) => `; ${effect}: ${j}`).join('')}`);
  check(diagnosis.baseline.startsWith('linear'), `baseline not shown (got "${diagnosis.baseline}")`);
  for (const k of ['before', 'after', 'floor']) check(/\d/.test(diagnosis[k]), `J ${k} not shown (got "${diagnosis[k]}")`);
  check(diagnosis.verdict !== '', 'no verdict on the final J against the noise floor');
  check(diagnosis.channels.startsWith('drive, output'), `the channels used not shown (got "${diagnosis.channels}")`);
  check(diagnosis.genericHidden, 'the J estimation/validation figures of other kinds are shown for a diagnosis');
  // At drive 0.8 the exciter's nonlinearity is well above the noise: the linear baseline leaves something out.
  check(diagnosis.findings.length >= 1 && diagnosis.tableShown && !diagnosis.noneShown,
        `no finding shown at drive 0.8: ${JSON.stringify(diagnosis)}`);
  for (const [, effect, explanation, j] of diagnosis.findings) {
    check(/^[a-z_]+$/.test(effect) && explanation.length > 20, `a finding without effect id or explanation: ${effect} / ${explanation}`);
    check(/\d.*→.*\d/.test(j), `a finding without J before → after: "${j}"`);
    check(/(clear|likely|ambiguous between \S+ and)/.test(explanation), `a finding without how sure it is: "${explanation}"`);
  }
  // Where the residual lies: a sentence each on frequency, state and time at least.
  log(`location: ${diagnosis.location.join(' | ')}`);
  for (const topic of ['Frequency:', 'State:', 'Time:']) {
    check(diagnosis.location.some((t) => t.startsWith(topic)), `no "${topic}" sentence on where the residual lies: ${JSON.stringify(diagnosis.location)}`);
  }
  await page.waitForSelector('#plot-residual_spectrum canvas', { timeout: 5000 });
  fs.mkdirSync(artifacts, { recursive: true });
  await page.locator('#result').screenshot({ path: path.join(artifacts, 'ui-diagnosis.png') });
  // The verdicts are the server's (diagnosis_to_json's *_significant and at_noise_floor): the page words them.
  const report = (await (await fetch(`${base}api/jobs/${diagnoseId}`)).json()).result;
  const where = report?.location?.validation ?? {};
  check(typeof report?.at_noise_floor === 'boolean' && typeof where.change_significant === 'boolean'
        && typeof where.peak_significant === 'boolean'
        && (where.states ?? []).every((s) => typeof s.shape_significant === 'boolean' && typeof s.direction_significant === 'boolean'),
        `the diagnose result carries no verdict fields: ${JSON.stringify({ at_noise_floor: report?.at_noise_floor, ...where, states: undefined })}`);
  check(diagnosis.verdict.includes('at the noise floor') === report.at_noise_floor,
        `verdict "${diagnosis.verdict}" against at_noise_floor ${report.at_noise_floor}`);
  const sentence = (topic) => diagnosis.location.find((t) => t.startsWith(topic)) ?? '';
  check(sentence('Time:').includes('changes') === where.change_significant,
        `"${sentence('Time:')}" against change_significant ${where.change_significant}`);
  check(sentence('State:').includes('depends most') === where.states.some((s) => s.shape_significant),
        `"${sentence('State:')}" against the states' shape_significant`);
  check(diagnosis.location.some((t) => t.startsWith('Direction:')) === where.states.some((s) => s.direction_significant),
        'a "Direction:" sentence shown against the states\' direction_significant');
  await page.waitForSelector('#plot-fit canvas', { timeout: 5000 });

  // A NN feedback design needs a NARX plant and an LQ feedforward: both made here, small and quick.
  run.step = 'designing an LQ feedforward';
  await page.selectOption('#job-kind', 'design-lq');
  await page.selectOption('#lq-plant', modelId);
  await page.fill('fieldset[data-kinds="design-lq"] [data-param="max_input"]', '0.3');
  const lqPosted = page.waitForRequest((r) => r.method() === 'POST' && new URL(r.url()).pathname === '/api/jobs', { timeout: 10_000 });
  const lqJob = await runFormJob('design-lq', diagnoseId);
  const lqModel = await resultModel('design-lq');
  const lqBody = (await lqPosted).postDataJSON();
  check(lqBody.params?.max_input === 0.3 && !('r' in lqBody.params),
        `the design-lq request chooses its weight by ${JSON.stringify(lqBody.params)}, expected max_input 0.3 and no r`);
  const lqSummary = await page.$$eval('#result-summary dt', (dts) => dts.map((dt) => dt.textContent.trim()));
  check(lqSummary.includes('R_search.target_noise_amplitude'),
        `the design-lq summary shows no R_search: ${lqSummary.join(', ')}`);

  run.step = `activating the LQ feedforward ${lqModel}`;
  await until(async () => await page.isVisible('#result-activate'), 5000, 'the design-lq result never offers Activate');
  check((await page.textContent('#result-activate')).trim() === 'Activate as feedforward',
        `the design-lq result's button reads "${await page.textContent('#result-activate')}", expected "Activate as feedforward"`);
  await page.click('#result-activate');
  await until(async () => {
    const err = await page.$eval('#result-activate-error', (e) => (e.hidden ? '' : e.textContent));
    if (err) throw new TestFailure(err);
    return (await page.getAttribute('#active-feedforward', 'data-model-id')) === lqModel;
  }, 8000, `status never showed ${lqModel} as the active feedforward model (shows "${await page.textContent('#active-feedforward')}")`);
  const lqRow = `#models-table tr[data-model-id="${lqModel}"]`;
  await until(async () => ((await page.getAttribute(lqRow, 'data-active-in')) || '').includes('feedforward'),
              8000, `models table never showed ${lqModel} active in feedforward`);
  check((await page.textContent(`${lqRow} button.activate`)).trim() === 'Activate as feedforward',
        'the models table does not offer the LQ feedforward "Activate as feedforward"');
  log(`active feedforward: ${(await page.textContent('#active-feedforward')).trim()}`);

  // The plant in its operating regime: the LQ's output for noise and stepped sines, with harmonic weights.
  run.step = 'recording a control excitation';
  await page.selectOption('#job-kind', 'excite');
  await page.selectOption('[data-kinds="excite"] [data-param="signal"]', 'control');
  await until(async () => (await page.$$eval('#excite-ff option', (os) => os.map((o) => o.value))).includes(lqModel),
              8000, `the LQ model ${lqModel} is never offered as the feedforward of a control excitation`);
  await page.selectOption('#excite-ff', lqModel);
  await page.fill('#excite-samples', '3000');
  await page.fill('#excite-validation', '2000');
  await page.fill('[data-kinds="excite"] [data-param="sine_peak"]', '0.5');
  const excitePosted = page.waitForRequest((r) => r.method() === 'POST' && new URL(r.url()).pathname === '/api/jobs', { timeout: 10_000 });
  const controlJob = await runFormJob('control excite', lqJob);
  const exciteBody = (await excitePosted).postDataJSON();
  check(exciteBody.params?.signal === 'control' && exciteBody.params?.feedforward_model === lqModel && exciteBody.params?.sine_peak === 0.5,
        `the control excite request was ${JSON.stringify(exciteBody.params)}`);
  // The record is kept once in the record store, the job's result naming it and its columns.
  const record = await (await fetch(`${base}api/jobs/${controlJob}`)).json();
  log(`control record: ${record.result?.record_id} (${(record.result?.record_columns ?? []).join(", ")})`);
  check((record.result?.record_columns ?? []).includes('w'), `the control excitation's record has no harmonic weights w`);
  const kept = await (await fetch(`${base}api/records/${record.result?.record_id}`)).json();
  check(kept.samples === 5000 && kept.name === `excitation of ${controlJob}`,
        `the control excitation's record is not kept as ${controlJob}'s 3000 + 2000 samples: ${JSON.stringify(kept).slice(0, 200)}`);

  run.step = 'identifying a NARX plant';
  await page.selectOption('#job-kind', 'identify-narx');
  await until(async () => (await page.$$eval('#job-source option', (os) => os.map((o) => o.value))).includes(controlJob),
              8000, `the control excitation ${controlJob} is never offered as data`);
  await page.selectOption('#job-source', controlJob);
  await page.check('#narx-weighted');
  const narx = (param) => `fieldset[data-kinds="identify-narx"] [data-param="${param}"]`;
  await page.fill(narx('hidden'), '3');
  await page.fill(narx('modes'), 'pem');
  await page.fill(narx('max_iterations'), '5');
  await page.fill(narx('friction_units'), '2.5');
  const narxPosted = page.waitForRequest((r) => r.method() === 'POST' && new URL(r.url()).pathname === '/api/jobs', { timeout: 10_000 });
  const narxJob = await runFormJob('identify-narx', controlJob);
  const narxModel = await resultModel('identify-narx');
  const narxBody = (await narxPosted).postDataJSON();
  check(narxBody.params?.record === controlJob && narxBody.params?.weighted === true && !('excite' in narxBody.params),
        `the identify-narx request should train weighted on ${controlJob}: ${JSON.stringify(narxBody.params)}`);
  check(JSON.stringify(narxBody.params?.friction_units) === '[2.5]',
        `params.friction_units in the identify-narx request is ${JSON.stringify(narxBody.params?.friction_units)}, expected [2.5]`);
  const narxSummary = await page.$$eval('#result-summary dt', (dts) => dts.map((dt) => dt.textContent.trim()));
  check(narxSummary.includes('friction_units.gains') && narxSummary.includes('friction_units.velocity_fit_r2'),
        `the identify-narx summary shows no friction_units: ${narxSummary.join(', ')}`);

  // Every design-nn field off its default, so that each one is seen to reach the request body.
  run.step = 'starting a design-nn job';
  await page.selectOption('#job-kind', 'design-nn');
  await until(async () => (await page.$$eval('#nn-plant option', (os) => os.map((o) => o.value))).includes(narxModel),
              8000, `the NARX model ${narxModel} is never offered as the plant of a design-nn job`);
  await page.selectOption('#nn-plant', narxModel);
  await page.selectOption('#nn-feedforward', lqModel);
  const nnFields = { samples: ['#nn-samples', '1000', 1000], max_iterations: ['#nn-max-iterations', '2', 2],
                     hidden: ['#nn-hidden', '3', [3]], nu: ['#nn-nu', '1', 1], nv: ['#nn-nv', '1', 1], ny: ['#nn-ny', '3', 3],
                     sine_share: ['#nn-sine-share', '0.5', 0.5], sine_peak: ['#nn-sine-peak', '0.45', 0.45],
                     program_share: ['#nn-program-share', '0.25', 0.25], restarts: ['#nn-restarts', '2', 2],
                     rail_penalty: ['#nn-rail-penalty', '4', 4], dc_penalty: ['#nn-dc-penalty', '0.5', 0.5],
                     seed: ['#nn-seed', '7', 7] };
  for (const [selector, text] of Object.values(nnFields)) {
    check(await page.isVisible(selector), `design-nn field ${selector} not shown`);
    await page.fill(selector, text);
  }
  const posted = page.waitForRequest((r) => r.method() === 'POST' && new URL(r.url()).pathname === '/api/jobs', { timeout: 10_000 });
  const nnJob = await runFormJob('design-nn', narxJob);
  const body = (await posted).postDataJSON();
  const wanted = { plant_model: narxModel, feedforward_model: lqModel,
                   ...Object.fromEntries(Object.entries(nnFields).map(([k, [, , v]]) => [k, v])) };
  log(`design-nn request: ${JSON.stringify(body)}`);
  check(body.kind === 'design-nn', `request kind "${body.kind}", expected design-nn`);
  for (const [k, v] of Object.entries(wanted)) {
    check(JSON.stringify(body.params?.[k]) === JSON.stringify(v),
          `params.${k} in the request is ${JSON.stringify(body.params?.[k])}, expected ${JSON.stringify(v)}`);
  }

  run.step = 'design-nn summary shown';
  const summary = await page.$$eval('#result-summary dt', (dts) => Object.fromEntries(
    dts.map((dt) => [dt.textContent.trim(), dt.nextElementSibling.textContent.trim()])));
  log(`design-nn ${nnJob} summary: ${Object.entries(summary).map(([k, v]) => `${k}=${v}`).join(', ')}`);
  check(await page.isVisible('#result-figures') && !(await page.isVisible('#result-diagnosis')),
        'the J figures are not shown (or the diagnosis still is) for a design-nn result');
  check(['0', '1'].includes(summary.chosen_restart), `chosen_restart not shown as 0 or 1: ${JSON.stringify(summary.chosen_restart)}`);
  check(/^\[[^,\]]*\d[^,\]]*, [^,\]]*\d[^,\]]*\]$/.test(summary.restart_jc_val_pct || ''),
        `restart_jc_val_pct not shown as two values: ${JSON.stringify(summary.restart_jc_val_pct)}`);
  const shownDesign = { samples: '1,000', max_iterations: '2', hidden: '[3]', nu: '1', nv: '1', ny: '3', sine_share: '0.5',
                        sine_peak: '0.45', program_share: '0.25', restarts: '2', rail_penalty: '4', dc_penalty: '0.5',
                        seed: '7' };
  for (const [k, v] of Object.entries(shownDesign)) {
    check(summary[k] === v, `summary ${k} shown as ${JSON.stringify(summary[k])}, expected "${v}"`);
  }

  // The chain just designed, evaluated on the server's virtual transducer, with the per-term attribution.
  run.step = 'starting an evaluate job';
  const nnModel = await resultModel('design-nn');
  await page.selectOption('#job-kind', 'evaluate');
  await until(async () => (await page.$$eval('#ev-feedback option', (os) => os.map((o) => o.value))).includes(nnModel),
              8000, `the NN controller ${nnModel} is never offered as the feedback of an evaluate job`);
  await page.selectOption('#ev-feedforward', lqModel);
  await page.selectOption('#ev-feedback', nnModel);
  await page.fill('#ev-probes', '80, 160');
  await page.fill('#ev-probe-peak', '0.5');
  await page.fill('#ev-noise-samples', '4096');
  await page.check('#ev-attribute');
  const evPosted = page.waitForRequest((r) => r.method() === 'POST' && new URL(r.url()).pathname === '/api/jobs', { timeout: 10_000 });
  const evJob = await runFormJob('evaluate', nnJob);
  const evBody = (await evPosted).postDataJSON();
  log(`evaluate request: ${JSON.stringify(evBody)}`);
  const evWanted = { feedforward_model: lqModel, feedback_model: nnModel, probes_hz: [80, 160], probe_peak: 0.5,
                     noise_samples: 4096, attribute: true };
  check(evBody.kind === 'evaluate', `request kind "${evBody.kind}", expected evaluate`);
  for (const [k, v] of Object.entries(evWanted)) {
    check(JSON.stringify(evBody.params?.[k]) === JSON.stringify(v),
          `params.${k} in the request is ${JSON.stringify(evBody.params?.[k])}, expected ${JSON.stringify(v)}`);
  }
  run.step = 'evaluate result shown';
  const evSummary = await page.$$eval('#result-summary dt', (dts) => dts.map((dt) => dt.textContent.trim()));
  log(`evaluate ${evJob} summary keys: ${evSummary.join(', ')}`);
  for (const key of ['table.band-pass + feedforward + feedback.ripple_db', 'attribution_thd_pct.friction']) {
    check(evSummary.includes(key), `the evaluate summary shows no ${key}: ${evSummary.join(', ')}`);
  }
  for (const plot of ['response', 'thd']) {
    await until(async () => (await page.$$eval('#plots [data-plot]', (els) => els.map((e) => e.dataset.plot))).includes(plot),
                8000, `the evaluate result shows no "${plot}" figure`);
  }

  // On load the newest finished job's result is shown without a click (the evaluate job's), with the hint.
  run.step = 'newest result shown on load';
  await page.reload({ waitUntil: 'load' });
  await until(async () => (await page.$eval('#result', (e) => (e.hidden ? '' : e.dataset.jobId))) === evJob,
              8000, `after a reload the result panel does not show the newest finished job ${evJob}`);
  await page.waitForSelector('#plots [data-plot="response"] canvas', { timeout: 8000 });
  check(/click another job/i.test(await page.textContent('#result-hint')) && await page.isVisible('#result-hint'),
        'no hint that clicking another job shows its plots');

  await until(async () => (await page.textContent('#active-feedforward')).includes(' · '), 5000,
              'after a reload the active feedforward model is never shown with its name');

  // A recording uploaded from the records form (CSV, its rate given), listed, then taken as a job's data: an FIR
  // identification of y(k) = 0.5·u(k) − 0.25·u(k−1) + 0.125·u(k−2), which its model of order 3 fits exactly,
  // on the record's first 3/4 and judged on its last 1/4; a CSV with a NaN is refused naming its line.
  run.step = 'uploading a record';
  const u = [];
  for (let k = 0, x = 12345; k < 1500; ++k) {  // a seeded LCG's uniform noise, peak 0.5
    x = (x * 1103515245 + 12345) % 2147483648;
    u.push(Number((x / 2147483648 - 0.5).toFixed(6)));
  }
  const y = u.map((v, k) => 0.5 * v - (k >= 1 ? 0.25 * u[k - 1] : 0) + (k >= 2 ? 0.125 * u[k - 2] : 0));
  const csv = 'u,y\n' + u.map((v, k) => `${v},${y[k]}`).join('\n') + '\n';
  await page.setInputFiles('#record-file', { name: 'bench.csv', mimeType: 'text/csv', buffer: Buffer.from(csv) });
  await page.fill('#record-fs', '3000');
  await page.click('#record-upload-button');
  const recordId = await until(async () => {
    const err = await page.$eval('#record-upload-error', (e) => (e.hidden ? '' : e.textContent));
    if (err) throw new TestFailure(`the server refused the record: ${err}`);
    const done = await page.$eval('#record-upload-result', (e) => (e.hidden ? '' : e.textContent));
    return done.match(/stored (r[0-9a-f]{12})/)?.[1] ?? '';
  }, 10_000, 'the record upload never said it was stored');
  const recordRow = `#records-table tr[data-record-id="${recordId}"]`;
  await page.waitForSelector(recordRow, { timeout: 8000 });
  const cells = await page.$$eval(`${recordRow} td`, (tds) => tds.map((td) => td.textContent.trim()));
  check(cells[1] === 'bench' && cells[2] === 'csv' && cells[3] === '1500' && cells[4] === '3000',
        `the records table shows ${JSON.stringify(cells)} for ${recordId}, expected bench, csv, 1500 samples at 3000 Hz`);
  log(`record ${recordId} uploaded and listed: ${cells.slice(0, 6).join(' | ')}`);

  run.step = 'a bad record refused';
  // (The records listed: the upload and the control excitation's record, kept there by its excite job.)
  const listed = (await page.$$('#records-table tbody tr')).length;
  const bad = csv.replace(/\n[^,\n]*,/, '\nnan,');  // line 2's u
  await page.setInputFiles('#record-file', { name: 'bad.csv', mimeType: 'text/csv', buffer: Buffer.from(bad) });
  await page.fill('#record-fs', '3000');
  await page.click('#record-upload-button');
  const refusal = await until(async () => page.$eval('#record-upload-error', (e) => (e.hidden ? '' : e.textContent)),
                              10_000, 'a CSV with a NaN was not refused');
  check(/bad_request: body:2/.test(refusal), `the refusal does not name the line: "${refusal}"`);
  check((await page.$$('#records-table tbody tr')).length === listed, 'a refused record was listed');
  log(`refused: ${refusal}`);

  run.step = 'identifying from the uploaded record';
  await page.selectOption('#job-kind', 'identify-linear');
  await until(async () => (await page.$$eval('#job-source option', (os) => os.map((o) => o.value))).includes(recordId),
              8000, `the record ${recordId} is never offered as a job's data`);
  await page.selectOption('#job-source', recordId);
  check(await page.isHidden('#fs-excite'), 'the excitation fields are shown with an uploaded record chosen');
  await page.fill('#job-val-fraction', '0.25');
  await page.selectOption('#lin-method', 'fir');
  await page.fill('#lin-order', '3');
  await page.fill('#job-form fieldset[data-kinds="identify-linear"] [data-param="delay"]', '0');
  const recPosted = page.waitForRequest((r) => r.method() === 'POST' && new URL(r.url()).pathname === '/api/jobs', { timeout: 10_000 });
  const recJob = await runFormJob('identify from an uploaded record', evJob);
  const recBody = (await recPosted).postDataJSON();
  check(recBody.params.record === recordId && recBody.params.val_fraction === 0.25 && !recBody.params.excite,
        `the request does not name the record and its split: ${JSON.stringify(recBody.params)}`);
  const recResult = (await (await fetch(`${base}api/jobs/${recJob}`)).json()).result;
  // The last quarter validates (375 samples); the fit shows all but the simulation's initial state, its first
  // min(50, 375 / 10) = 37 samples (api/jobs/model_judgement.cpp).
  check(recResult.plots.fit.t.length === 338, `the fit covers ${recResult.plots.fit.t.length} samples, expected 375 − 37`);
  check(recResult.j_val_pct < 1e-3, `J val ${recResult.j_val_pct} % for an exact FIR record`);
  log(`job ${recJob} on record ${recordId}: J val ${recResult.j_val_pct} %`);

  run.step = 'deleting the record';
  await page.click(`${recordRow} button.delete`);
  await page.click(`${recordRow} button.delete`);  // the second click confirms
  await page.waitForSelector(recordRow, { state: 'detached', timeout: 8000 });
  const left = (await page.$$('#records-table tbody tr')).length;
  check(left === listed - 1, `${left} records listed after the delete, expected ${listed - 1}`);
  check((await page.isVisible('#records-empty')) === (left === 0), 'the records list says it is empty when it is not, or not when it is');

  run.step = 'no page errors';
  check(run.pageErrors.length === 0, `${run.pageErrors.length} error(s) in the page`);

  run.step = 'screenshot';
  fs.mkdirSync(path.dirname(screenshotPath), { recursive: true });
  // The top of the page, tall enough for the status, the jobs and the shown result's plots.
  await page.setViewportSize({ width: 1440, height: 1195 });
  await page.evaluate(() => window.scrollTo(0, 0));
  await page.screenshot({ path: screenshotPath });
  log(`screenshot ${screenshotPath}`);
}

run.run(main);

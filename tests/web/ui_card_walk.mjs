// The web Tune walked on a sound card with no sound card (issue #56), by hand, not in ctest (about 90 s of real
// time, most of it the tune playing through the card; the card path's tune is CardPipelineTest's, the page's Tune
// ui_mock_test's):
//   node tests/web/ui_card_walk.mjs --server build/bin/panelbass --artifacts build/test-artifacts [--plant P]
// Starts a JACK server with the dummy driver (its own name), `panelbass transducer --jack --plant P` (panel-exciter
// unless --plant) and `serve --backend alsa` wired to it as docs/engine.md wires them (fresh store, no demo, this
// checkout's web/), then, in Debian's headless Chromium, as a person would: presses Tune and follows its steps (those the job reports)
// to the end; checks that the decision is shown and names the model made active in the feedforward slot (GET
// /api/status), that verify's table has a row per probe and level, and that the THD-versus-level plots are drawn in
// the job's result; then the program panel: a sine of 80 Hz at 0.2 played (GET /api/program), the bypass toggle
// enabled now that a controller is active, ticked → feedforward.bypass true (GET /api/config), unticked → false.
// Saves ARTIFACTS/ui-card-tune.png (after the tune), ui-card-program.png (after the A/B), ui-card-server.log,
// ui-card-console.log, ui-card-jack.log and ui-card-transducer.log. Exit 0 on success; 1 with
// "ui_card_walk: FAIL <step>: <reason>" otherwise; 2 on bad usage.

import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { BrowserRun, check, until } from './harness.mjs';

const argv = process.argv.slice(2);
const opt = (name, fallback) => {
  const i = argv.indexOf(`--${name}`);
  return i >= 0 && i + 1 < argv.length ? argv[i + 1] : fallback;
};
const serverPath = opt('server') && path.resolve(opt('server'));
const artifacts = opt('artifacts') && path.resolve(opt('artifacts'));
const plant = opt('plant', 'panel-exciter');
if (!serverPath || !artifacts) {
  console.error('usage: node tests/web/ui_card_walk.mjs --server PATH_TO_PANELBASS --artifacts DIR [--plant P]');
  process.exit(2);
}

const TUNE_TIMEOUT_MS = 180_000;
const run = new BrowserRun('ui_card_walk', { artifacts, prefix: 'ui-card', timeoutMs: TUNE_TIMEOUT_MS + 90_000 });
const jackName = `pbwalk${process.pid}`;
const env = { ...process.env, JACK_NO_AUDIO_RESERVATION: '1', JACK_DEFAULT_SERVER: jackName };
const helpers = [];
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/** Starts `argv` with the rig's environment, its output into ARTIFACTS/ui-card-`log`.log; killed when the walk ends. */
function startHelper(command, args, log) {
  fs.mkdirSync(artifacts, { recursive: true });
  const out = fs.openSync(path.join(artifacts, `ui-card-${log}.log`), 'w');
  const child = spawn(command, args, { env, stdio: ['ignore', out, out] });
  helpers.push(child);
  return child;
}
process.on('exit', () => { for (const c of helpers.reverse()) c.kill('SIGINT'); });

/** Whether a JACK client's port `name` is listed (jack_lsp), so the next part can connect to it. */
async function portListed(name) {
  return new Promise((resolve) => {
    const lsp = spawn('jack_lsp', [], { env, stdio: ['ignore', 'pipe', 'ignore'] });
    let out = '';
    lsp.stdout.on('data', (d) => { out += d; });
    lsp.on('exit', () => resolve(out.split('\n').includes(name)));
    lsp.on('error', () => resolve(false));
  });
}

async function main() {
  run.step = 'starting the JACK dummy and the transducer';
  startHelper('jackd', ['--no-realtime', '-S', '-n', jackName, '-d', 'dummy', '-r', '48000', '-p', '64'], 'jack');
  await sleep(1500);
  startHelper(serverPath, ['transducer', '--jack', '--plant', plant, '--name', 'tr'], 'transducer');
  await until(() => portListed('tr:current'), 15_000, 'the transducer never registered tr:current (see ui-card-jack.log)', 250);
  const conf = path.join(run.tempDir('ui-card'), 'card.conf');
  fs.writeFileSync(conf, 'pcm.pb_play    { type jack name "pb_play" playback_ports { 0 "tr:drive" 1 "system:playback_1" } }\n'
                       + 'pcm.pb_capture { type jack name "pb_capture" capture_ports { 0 "tr:sensor" 1 "pb_play:out_000" 2 "tr:current" } }\n');

  run.step = 'starting serve --backend alsa';
  // the server inherits JACK_DEFAULT_SERVER through this process's environment
  Object.assign(process.env, env);
  const base = await run.startServer(serverPath, ['--backend', 'alsa', '--alsa-config', conf, '--playback', 'pb_play',
    '--capture', 'pb_capture', '--capture-channels', '3', '--sensor-channel', '0', '--loopback-channel', '1',
    '--current-channel', '2', '--periods', '16', '--no-demo']);
  const getJson = async (route) => {
    const res = await fetch(new URL(route, base));
    check(res.ok, `GET ${route} → ${res.status}`);
    return res.json();
  };
  await until(async () => (await getJson('api/status')).engine.device.state === 'running', 15_000, 'the card never streams');
  const page = await run.openPage(base);

  run.step = 'tune';
  const t = Date.now();
  await page.click('#tune-start');
  const seen = new Set();
  const states = await until(async () => {
    if (await page.isVisible('#tune-error')) throw new Error(`the tune shows an error: ${await page.textContent('#tune-error')}`);
    const s = await page.$$eval('#tune-steps li', (items) => items.map((li) => `${li.dataset.step}:${li.dataset.state}`));
    for (const x of s) if (x.endsWith(':running')) seen.add(x.split(':')[0]);
    return s.length > 0 && s.every((x) => x.endsWith(':succeeded') || x.endsWith(':skipped')) ? s : null;
  }, TUNE_TIMEOUT_MS, 'the tune did not finish its steps', 250);
  // the page lists the steps the job reports, in its order (measure, fit, refine, verify, decide)
  const jobs = (await getJson('api/jobs')).jobs.filter((j) => j.kind === 'tune');
  const job = await getJson(`api/jobs/${jobs[jobs.length - 1].id}`);
  const reported = job.result.steps.map((x) => x.name);
  const shown = states.filter((x) => x.endsWith(':succeeded')).map((x) => x.split(':')[0]);
  check(JSON.stringify(shown) === JSON.stringify(reported),
        `the page shows the steps ${states.join(', ')}, the job reports ${reported.join(', ')}`);
  run.log(`tune: ${states.join(', ')} in ${((Date.now() - t) / 1000).toFixed(1)} s (seen running: ${[...seen].join(', ')})`);
  check(seen.has('measure') && seen.has('verify'), `the page never showed measure and verify running: ${[...seen]}`);
  const times = await page.$$eval('#tune-steps li', (items) => items.map((li) => li.lastChild.textContent));
  run.log(`step times: ${times.join(', ')}`);
  const decision = await page.textContent('#tune-decision');
  run.log(`decision: ${decision}`);
  const status = await getJson('api/status');
  const kept = (await page.getAttribute('#tune-decision', 'data-kept')) === 'true';
  if (kept) {
    check(status.active_models.feedforward && decision.includes(status.active_models.feedforward),
          `the decision "${decision}" does not name the active feedforward ${JSON.stringify(status.active_models)}`);
  } else {
    check(decision.startsWith('left out'), `nothing kept, yet the decision reads "${decision}"`);
  }
  const rows = await page.$$eval('#tune-probes tbody tr', (trs) => trs.map((r) => [...r.cells].map((c) => c.textContent).join(' | ')));
  for (const r of rows) run.log(`  ${r}`);
  check(rows.length === 9, `verify's table has ${rows.length} rows, not 3 probes × 3 levels`);
  await page.waitForSelector('#plots .plot-box canvas', { timeout: 10_000 });
  const plots = await page.$$eval('#plots .plot-box', (boxes) => boxes.map((b) => b.textContent.trim().slice(0, 60)));
  run.log(`plots in the result: ${plots.length} (${plots.join('; ')})`);
  check(plots.length > 0, 'no THD-versus-level plot in the tune job\'s result');
  await page.screenshot({ path: path.join(artifacts, 'ui-card-tune.png'), fullPage: true });

  run.step = 'program panel';
  await page.selectOption('#program-signal', 'sine');
  await page.fill('#program-frequency', '80');
  await page.fill('#program-amplitude', '0.2');
  await page.click('#program-apply');
  await until(async () => (await getJson('api/program')).signal === 'sine:80', 5000, 'the card does not play sine:80 after Play');
  if (kept) {
    await until(async () => !(await page.isDisabled('#program-bypass')), 5000, 'the bypass toggle stays disabled with a controller active');
    await page.check('#program-bypass');
    await until(async () => (await getJson('api/config')).feedforward.bypass === true, 5000, 'ticking bypass does not set feedforward.bypass');
    await page.uncheck('#program-bypass');
    await until(async () => (await getJson('api/config')).feedforward.bypass === false, 5000, 'unticking bypass does not clear it');
    run.log('bypass toggle: ticked → feedforward.bypass true, unticked → false');
  }
  await page.screenshot({ path: path.join(artifacts, 'ui-card-program.png'), fullPage: true });

  run.step = 'no page errors';
  check(run.pageErrors.length === 0, `${run.pageErrors.length} error(s) in the page: ${run.pageErrors.join('; ')}`);
}

run.run(main);

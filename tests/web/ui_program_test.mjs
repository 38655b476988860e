// Browser test of the program panel (web/ui/program.js) against a real `panelbass serve` (or the mock server):
//   node tests/web/ui_program_test.mjs --server build/bin/panelbass --artifacts build/test-artifacts
// Checks, as a person would, by clicking: the panel says what plays (the server's start-up noise); a sine of
// 80 Hz at 0.25 chosen and played → the server plays it (GET /api/program, asked here, not the page) and the
// panel says so; silence hides the frequency and amplitude; noise with a seed → the server plays that seed; an
// amplitude beyond [0, 1] → the server's refusal naming program.amplitude is shown and what plays is unchanged;
// the bypass toggle is off while no controller is active; with an LQ feedforward designed and activated through
// the API it sets the controller's bypass flag (GET /api/config) and unticked clears it, the chain panel following. Saves ARTIFACTS/ui-program-server.log and ui-program-console.log. Exit 0 on success; 1 with
// "ui_program_test: FAIL <step>: <reason>" otherwise; 2 on bad usage.

import { BrowserRun, check, parseArgs, until } from './harness.mjs';

const { server: serverPath, artifacts } = parseArgs('ui_program_test');
const run = new BrowserRun('ui_program_test', { artifacts, prefix: 'ui-program', timeoutMs: 60_000 });

async function main() {
  run.step = 'starting the server';
  const base = await run.startServer(serverPath, serverPath.endsWith('.mjs') ? ['--no-demo'] : ['--no-demo', '--signal', 'noise']);
  const page = await run.openPage(base);
  const getJson = async (route) => {
    const res = await fetch(`${base}${route}`);
    check(res.ok, `GET ${route} → ${res.status}`);
    return res.json();
  };
  const nowText = () => page.textContent('#program-now');

  run.step = 'what plays is shown';
  await until(async () => (await nowText()).startsWith('noise at 0.2'), 10_000,
              `the panel never says the start-up noise plays: "${await nowText()}"`);

  run.step = 'a sine played';
  await page.selectOption('#program-signal', 'sine');
  await page.fill('#program-frequency', '80');
  await page.fill('#program-amplitude', '0.25');
  await page.click('#program-apply');
  let p = await until(async () => { const x = await getJson('api/program'); return x.signal === 'sine:80' ? x : null; }, 5000,
                      'the server does not play sine:80 after Play');
  check(p.amplitude === 0.25 && p.frequency_hz === 80, `the server plays ${JSON.stringify(p)}`);
  await until(async () => (await nowText()).startsWith('sine 80 Hz at 0.25'), 5000, `the panel says "${await nowText()}"`);
  check(/playing sine 80 Hz at 0.25/.test(await page.textContent('#program-result')), 'no confirmation after Play');
  run.log(`sine: ${await nowText()}`);

  run.step = 'fields follow the signal';
  await page.selectOption('#program-signal', 'silence');
  check(await page.isHidden('#program-frequency') && await page.isHidden('#program-amplitude'), 'silence still offers a frequency or an amplitude');
  await page.selectOption('#program-signal', 'noise');
  check(await page.isHidden('#program-frequency') && await page.isVisible('#program-seed'), 'noise offers a frequency or no seed');

  run.step = 'noise with a seed';
  await page.fill('#program-amplitude', '0.1');
  await page.fill('#program-seed', '7');
  await page.click('#program-apply');
  p = await until(async () => { const x = await getJson('api/program'); return x.signal === 'noise' ? x : null; }, 5000,
                  'the server does not play noise after Play');
  check(p.seed === 7 && p.amplitude === 0.1, `the server plays ${JSON.stringify(p)}`);

  run.step = 'a refusal shown';
  await page.fill('#program-amplitude', '1.5');
  await page.click('#program-apply');
  await page.waitForSelector('#program-error:not([hidden])', { timeout: 5000 });
  const refusal = await page.textContent('#program-error');
  check(refusal.includes('program.amplitude'), `the refusal shown reads "${refusal}"`);
  p = await getJson('api/program');
  check(p.signal === 'noise' && p.amplitude === 0.1, `a refused request changed what plays: ${JSON.stringify(p)}`);
  run.log(`refused: ${refusal}`);

  run.step = 'the bypass toggle';
  check(await page.isDisabled('#program-bypass') && await page.isVisible('#program-bypass-note'),
        'the bypass toggle is offered with no controller active (bypassing an empty slot changes nothing)');
  // A controller to bypass, as a user makes one: excite + identify a linear model, design the LQ feedforward on it
  // and activate it (through the API, as the README's curl commands do).
  const post = async (route, body) => {
    const res = await fetch(`${base}${route}`, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
    check(res.ok, `POST ${route} → ${res.status} ${await res.clone().text()}`);
    return res.json();
  };
  const finished = async (id) => until(async () => { const j = await getJson(`api/jobs/${id}`); return ['succeeded', 'failed', 'cancelled'].includes(j.state) ? j : null; },
                                       30_000, `job ${id} did not finish`);
  const identified = await finished((await post('api/jobs', { kind: 'identify-linear', params: { excite: { samples: 3000 }, order: 4 } })).id);
  check(identified.state === 'succeeded', `identify-linear ${identified.state}: ${identified.error ?? ''}`);
  const designed = await finished((await post('api/jobs', { kind: 'design-lq', params: { plant_model: identified.result.model_id }, activate: true })).id);
  check(designed.state === 'succeeded', `design-lq ${designed.state}: ${designed.error ?? ''}`);
  await until(async () => !(await page.isDisabled('#program-bypass')), 10_000, 'the toggle stays off with a controller active');
  check(!(await page.isChecked('#program-bypass')), 'the toggle is ticked while the controller plays');
  await page.check('#program-bypass');
  let c = await until(async () => { const x = await getJson('api/config'); return x.feedforward.bypass ? x : null; }, 5000,
                      'the toggle did not bypass the feedforward');
  await until(async () => page.isChecked('#config-form [name="feedforward.bypass"]'), 5000, 'the chain panel does not show the bypass');
  await page.uncheck('#program-bypass');
  c = await until(async () => { const x = await getJson('api/config'); return !x.feedforward.bypass && !x.feedback.bypass ? x : null; }, 5000,
                  'unticked, the controllers stay bypassed');
  check(!c.band_pass.bypass, 'the toggle bypassed the band-pass');
  run.log('bypass toggled on and off');
}

run.run(main);

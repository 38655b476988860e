// Browser test of what the web UI shows when the server reports trouble, against tests/web/mock_server.mjs (which
// can be made to report it on demand, as the real server cannot):
//   node tests/web/ui_mock_test.mjs --server tests/web/mock_server.mjs --artifacts build/test-artifacts
// ctest runs it under Debian 12's Node 18.20.4 (web.ui_on_debian12_node), so it also proves that playwright-core
// and the test set-up run there. Checks, as a person would, with jobs started through the API (as the README's
// curl commands do) rather than the form:
//   - the mock's start-up demo drives at the limiter (needs_more_drive, 3.2 % of the last second's samples
//     compressed, 0.4 % over range, peak_drive 0.9999): the status shows the limiter's shares and the peak drive
//     since start and says plainly that the program needs more drive than the chain allows; made quieter
//     (POST /mock/program), the message goes while the peak since start stays; a program only compressed gets a
//     milder note; louder again, the message comes back;
//   - a job that finishes is shown without a click (result, plots, and the hint that a click shows another);
//   - an identify-narx job without nk ends with a warning (J_val 100.3 %, nk 1001): shown in its row and
//     prominently on its result;
//   - the Tune button runs the tune job (measure → fit from the current → mirror filter → verify at equal output →
//     decide), its steps followed to the end; the decision, verify's THD alone and with the filter per probe and
//     level (a bound at the noise, a level not reached) are shown, and the mirror filter it kept is active;
//   - plant models (linear, narx) are offered no Activate, in the store or on their result, and the form's
//     "activate when done" is only offered for controllers; an LQ feedforward is offered "Activate as feedforward";
//     when the server refuses an activation its error text is shown; accepted, the status shows the model active;
//     Activate follows the models' `slots` from the server, not their kind (the answer altered on its way: a narx
//     model offered "Activate as feedback", an LQ feedforward with no slot says so and is offered none).
// Saves ARTIFACTS/ui-mock-server.log and ui-mock-console.log. Exit 0 on success; 1 with
// "ui_mock_test: FAIL <step>: <reason>" otherwise; 2 on bad usage.

import { BrowserRun, check, parseArgs, until } from './harness.mjs';

const { server: serverPath, artifacts } = parseArgs('ui_mock_test');
const run = new BrowserRun('ui_mock_test', { artifacts, prefix: 'ui-mock', timeoutMs: 60_000 });

async function main() {
  run.log(`Node ${process.version}`);
  run.step = 'starting the mock server';
  const base = await run.startServer(serverPath, ['--job-step-ms', '50']);  // with its demo: the drive at the limiter
  const page = await run.openPage(base);
  const post = async (route, body) => {
    const res = await fetch(`${base}${route}`, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
    const text = await res.text();
    check(res.ok, `POST ${route} → ${res.status} ${text}`);
    return JSON.parse(text);
  };
  /** Waits for the result panel to show job `id` succeeded with its result, without a click. */
  const shownWithoutClick = async (id, what) => {
    await until(async () => (await page.$eval('#result', (e) => (e.hidden ? '' : `${e.dataset.jobId}/${e.dataset.state}`))) === `${id}/succeeded`,
                10_000, `the ${what} job ${id} started through the API was never shown when it finished`);
    await page.waitForSelector('#result-body:not([hidden])', { timeout: 5000 });
  };

  run.step = 'drive at the limit shown';
  await page.waitForSelector('#conn[data-state="online"]', { timeout: 10_000 });
  /** What the status says of the drive: the note's level and text, the limiter's line, the peak since start. */
  const drive = () => page.evaluate(() => {
    const note = document.querySelector('#status-drive-note');
    return { level: note.dataset.level || '', note: note.hidden ? '' : note.textContent.trim(), box: note.className,
             limiter: document.querySelector('#status-limiter').textContent.trim(),
             peak: document.querySelector('#status-peak-drive').textContent.trim() };
  });
  let d = await until(async () => { const x = await drive(); return x.level === 'limit' ? x : null; }, 8000,
                      `the status never says the program needs more drive than the chain allows: ${JSON.stringify(await drive())}`);
  run.log(`over: limiter "${d.limiter}", peak drive ${d.peak}: ${d.note}`);
  check(d.peak === '0.9999', `peak drive shown as "${d.peak}"`);
  check(d.note.includes('needs more drive than the chain allows') && d.box === 'warn-box',
        `the status does not say plainly, in the warning box, that the program needs more drive than the chain allows: ${JSON.stringify(d)}`);
  check(d.limiter.startsWith('3.2 % of samples compressed, 0.4 % over range'),
        `the limiter's activity over the last second reads "${d.limiter}", expected 3.2 % compressed, 0.4 % over range`);
  check(/since start/.test(await page.$eval('#status-peak-drive', (e) => e.closest('dd').previousElementSibling.textContent)),
        'the peak drive is not labelled as since start');

  run.step = 'the limiter message clears when the program gets quieter';
  const program = async (level) => {
    const res = await fetch(`${base}mock/program`, { method: 'POST', body: JSON.stringify({ level }) });
    check(res.ok, `POST /mock/program ${level} → ${res.status}`);
  };
  await program('quiet');
  d = await until(async () => { const x = await drive(); return x.level === '' ? x : null; }, 5000,
                  `needs_more_drive turned false, but the status still says: ${JSON.stringify(await drive())}`);
  check(d.note === '' && await page.isHidden('#status-drive-note'), `the drive note is still shown: ${JSON.stringify(d)}`);
  check(d.limiter.startsWith('0 % of samples compressed, 0 % over range'), `the quiet program's limiter line reads "${d.limiter}"`);
  check(d.peak === '0.9999', `the peak drive since start went from 0.9999 to "${d.peak}"`);
  run.log(`quiet: limiter "${d.limiter}", peak drive since start ${d.peak}`);
  await program('limiting');
  d = await until(async () => { const x = await drive(); return x.level === 'limiting' ? x : null; }, 5000,
                  `the limiter compresses 1.2 % (no sample over range), but the status says: ${JSON.stringify(await drive())}`);
  check(!d.note.includes('needs more drive') && d.box !== 'warn-box' && d.note.includes('1.2 %'),
        `a program that is only compressed (needs_more_drive false) is told as: ${JSON.stringify(d)}`);
  await program('over');
  await until(async () => (await drive()).level === 'limit', 5000, 'needs_more_drive true again, but no message');
  await program('quiet');
  await until(async () => (await drive()).level === '', 5000, 'needs_more_drive false again, but the message stays');

  run.step = 'a finished job shown without a click';
  const linearJob = (await post('api/jobs', { kind: 'identify-linear', params: { samples: 3000 } })).id;
  await shownWithoutClick(linearJob, 'identify-linear');
  await page.waitForSelector('#plot-fit canvas', { timeout: 5000 });
  check(await page.isVisible('#result-hint') && /click another job/i.test(await page.textContent('#result-hint')),
        'no hint that clicking another job shows its plots');
  const linearModel = await page.$eval('#result-activate', (e) => e.dataset.modelId);

  run.step = 'a plant model offered no Activate';
  await until(async () => await page.isVisible('#result-plant-note'), 8000, 'the identify-linear result never says its model is a plant');
  check(!(await page.isVisible('#result-activate')) && /plant/.test(await page.textContent('#result-plant-note')),
        'the identify-linear result offers Activate on a plant model, or does not say it is a plant');
  await page.selectOption('#job-kind', 'identify-linear');
  check(!(await page.isVisible('#job-activate')), 'the form offers "activate when done" for an identify job');
  await page.selectOption('#job-kind', 'design-lq');
  check(await page.isVisible('#job-activate'), 'the form does not offer "activate when done" for a design-lq job');

  run.step = 'a job warning shown';
  const narxJob = (await post('api/jobs', { kind: 'identify-narx', params: { samples: 3000 } })).id;  // no nk
  await shownWithoutClick(narxJob, 'identify-narx');
  await page.waitForSelector('#result-warnings:not([hidden])', { timeout: 5000 });
  const shownWarning = (await page.textContent('#result-warnings')).trim();
  check(shownWarning.includes('J_val 100.3 % is no better than predicting zero'), `the result's warning reads "${shownWarning}"`);
  const row = `#jobs-table tr[data-job-id="${narxJob}"]`;
  await until(async () => (await page.getAttribute(row, 'data-warnings')) === '1', 5000, `the row of ${narxJob} shows no warning`);
  const rowText = (await page.textContent(`${row} td.message`)).trim();
  check(rowText.startsWith('⚠') && rowText.includes('no better than predicting zero')
        && await page.$eval(`${row} td.message`, (td) => td.classList.contains('warn')),
        `the row of ${narxJob} does not show its warning in the warning style: "${rowText}"`);
  check(await page.getAttribute(`#jobs-table tr[data-job-id="${linearJob}"]`, 'data-warnings') === '0',
        `the row of ${linearJob}, a job without warnings, shows one`);
  run.log(`warning shown: ${rowText}`);

  run.step = 'activating an LQ feedforward';
  const lqJob = (await post('api/jobs', { kind: 'design-lq', params: { plant_model: linearModel } })).id;
  await shownWithoutClick(lqJob, 'design-lq');
  const lqModel = await page.$eval('#result-activate', (e) => e.dataset.modelId);
  await until(async () => await page.isVisible('#result-activate'), 8000, 'the design-lq result never offers Activate');
  check((await page.textContent('#result-activate')).trim() === 'Activate as feedforward',
        `the design-lq result's button reads "${await page.textContent('#result-activate')}"`);
  await until(async () => (await page.$$('#models-table tbody tr')).length === 3, 8000, 'the store never lists the 3 models');
  /** Per model kind in the store: the Activate buttons offered, or the note saying why none is. */
  const offeredInStore = () => page.$$eval('#models-table tbody tr', (trs) => Object.fromEntries(trs.map((tr) =>
    [tr.children[1].textContent, [...tr.querySelectorAll('button.activate')].map((b) => b.textContent).join(', ')
      || `(${tr.querySelector('.no-slot-note')?.textContent ?? ''})`])));
  const offered = await offeredInStore();
  run.log(`Activate offered: ${JSON.stringify(offered)}`);
  const plantNote = '(a plant model: design a controller on it)';
  check(JSON.stringify(offered) === JSON.stringify({ lq_feedforward: 'Activate as feedforward', narx: plantNote, linear: plantNote }),
        `the store offers Activate as ${JSON.stringify(offered)}`);

  // The server refuses (a route of the test's answers this once, as the server would): its text is shown.
  const refusal = 'feedforward: the engine is in a fault; try again when it recovered';
  await page.route('**/api/models/*/activate', (r) => r.fulfill({ status: 409, contentType: 'application/json',
    body: JSON.stringify({ error: { code: 'conflict', message: refusal } }) }), { times: 1 });
  await page.click('#result-activate');
  await page.waitForSelector('#result-activate-error:not([hidden])', { timeout: 5000 });
  const refusedText = (await page.textContent('#result-activate-error')).trim();
  check(refusedText.includes(refusal), `a refused activation shows "${refusedText}", not the server's error`);
  await page.click('#result-activate');
  await until(async () => (await page.getAttribute('#active-feedforward', 'data-model-id')) === lqModel, 8000,
              `status never showed ${lqModel} as the active feedforward model`);
  check(await page.isHidden('#result-activate-error'), 'the refusal is still shown after the activation succeeded');

  // Activate follows the server's `slots`, not the model's kind: the store's answer altered on its way to the page
  // (the narx model said to go into the feedback slot, the LQ feedforward into none), the page reloaded.
  run.step = 'Activate follows the models\' slots';
  await page.route('**/api/models', async (r) => {
    const res = await r.fetch();
    const body = await res.json();
    for (const m of body.models) m.slots = { narx: ['feedback'], lq_feedforward: [] }[m.kind] ?? m.slots;
    await r.fulfill({ response: res, json: body });
  });
  await page.reload({ waitUntil: 'load' });
  const altered = await until(async () => {
    const o = await offeredInStore();
    return Object.keys(o).length === 3 ? o : null;
  }, 8000, 'the store is not listed after the reload');
  run.log(`Activate offered from altered slots: ${JSON.stringify(altered)}`);
  check(JSON.stringify(altered) === JSON.stringify({ lq_feedforward: '(no slot runs this lq_feedforward model)',
                                                     narx: 'Activate as feedback', linear: plantNote }),
        `with slots {narx: [feedback], lq_feedforward: []} the store offers ${JSON.stringify(altered)}`);
  // The newest finished job's result (the design-lq) is shown after the reload: no Activate either.
  await until(async () => (await page.$eval('#result', (e) => e.dataset.jobId)) === lqJob && await page.isVisible('#result-plant-note'),
              8000, `the reloaded page does not show ${lqJob}'s result saying no slot runs its model`);
  check(!(await page.isVisible('#result-activate')), 'the design-lq result offers Activate though the server lists no slot for its model');
  await page.unroute('**/api/models');

  // Tune: one click runs the tune job; its five steps are followed to the end, the decision and verify's points
  // (a cut, a bound at the noise, a level not reached) are shown, and the mirror filter it kept is active.
  run.step = 'tune';
  await page.click('#tune-start');
  const tuned = await until(async () => {
    const s = await page.$$eval('#tune-steps li', (items) => items.map((li) => li.dataset.state));
    return s.length === 5 && s.every((x) => x === 'succeeded') ? s : null;
  }, 30_000, 'the tune job did not finish its five steps');
  run.log(`tune: ${tuned.join(', ')}`);
  const tuneJob = (await (await fetch(new URL('/api/jobs', base))).json()).jobs.find((j) => j.kind === 'tune');
  const mirror = (await (await fetch(new URL(`/api/jobs/${tuneJob.id}`, base))).json()).result.model_id;
  const status = await (await fetch(new URL('/api/status', base))).json();
  check(status.active_models.feedforward === mirror,
        `after the tune the feedforward slot runs ${JSON.stringify(status.active_models)}, not the kept ${mirror}`);
  check(!(await page.isVisible('#tune-error')), 'the tune shows an error');
  const decision = await page.textContent('#tune-decision');
  check(decision.startsWith('kept: it cuts the THD') && decision.includes(mirror), `the tune's decision is not shown: ${decision}`);
  const points = await page.$$eval('#tune-probes tbody tr', (rows) => rows.map((r) => r.textContent));
  check(points.length === 3 && points[0].includes('3.00 %') && points[0].includes('0.30 %') && points[0].includes('20.0 dB'),
        `verify's points are not shown: ${JSON.stringify(points)}`);
  check(points[1].includes('≤ 0.42 % (noise)') && points[1].includes('≥ 26.0 dB'),
        `a THD at the noise is not shown as the bound it gives: ${JSON.stringify(points[1])}`);
  check(points[2].includes("not reached: the chain's limiter acts"), `an unreachable level is not said: ${JSON.stringify(points[2])}`);
  // a level not reached was not played: no output or THD is shown for it (the server's zeros are no readings)
  check(!/\d %/.test(points[2]) && !points[2].includes('0.1500'), `an unreached level shows readings: ${JSON.stringify(points[2])}`);

  // Tune on a card without a sensor: the job runs no verify step, so the page says that step was skipped (not ✓)
  // and shows no verify table; the job's answer is altered on its way to the page as such a server sends it.
  run.step = 'tune without a sensor';
  await page.route('**/api/jobs/*', async (r) => {
    const res = await r.fetch();
    const body = await res.json();
    if (body.kind === 'tune' && body.result) {
      body.result.steps = body.result.steps.filter((x) => x.name !== 'verify');
      body.result.verify = null;
      body.result.plots = null;
      body.result.decision = 'kept without verification: the backend records no sensor, so the cut is not measured';
    }
    await r.fulfill({ response: res, json: body });
  });
  await page.click('#tune-start');
  const unverified = await until(async () => {
    const s = await page.$$eval('#tune-steps li', (items) => items.map((li) => `${li.dataset.step}:${li.dataset.state}`));
    return s.length === 5 && s.every((x) => x.endsWith(':succeeded') || x.endsWith(':skipped')) ? s : null;
  }, 30_000, 'the tune without a sensor did not finish');
  run.log(`tune without a sensor: ${unverified.join(', ')}`);
  check(JSON.stringify(unverified) === JSON.stringify(['measure:succeeded', 'fit:succeeded', 'refine:succeeded',
                                                        'verify:skipped', 'decide:succeeded']),
        `the steps read ${unverified.join(', ')}, not verify skipped and the others done`);
  check((await page.textContent('#tune-steps li[data-step="verify"]')).includes('skipped'), 'the verify step does not say skipped');
  check(await page.isHidden('#tune-probes'), 'a verify table is shown for a tune that verified nothing');
  check((await page.textContent('#tune-decision')).startsWith('kept without verification'), 'the decision is not shown');
  await page.unroute('**/api/jobs/*');

  run.step = 'no page errors';
  check(run.pageErrors.length === 0, `${run.pageErrors.length} error(s) in the page`);
}

run.run(main);

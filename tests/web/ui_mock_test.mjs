// Browser test of what the web UI shows when the server reports trouble, against tests/web/mock_server.mjs (which
// can be made to report it on demand, as the real server cannot):
//   node tests/web/ui_mock_test.mjs --server tests/web/mock_server.mjs --artifacts build/test-artifacts
// ctest runs it under Debian 12's Node 18.20.4 (web.ui_on_debian12_node), so it also proves that playwright-core
// and the test set-up run there. Checks, as a person would, with jobs started through the API (as the README's
// curl commands do) rather than the form:
//   - the mock's start-up demo drives at the limiter (peak_drive 0.9999): the status shows the peak drive and says
//     plainly that the program needs more drive than the chain allows;
//   - a job that finishes is shown without a click (result, plots, and the hint that a click shows another);
//   - an identify-narx job without nk ends with a warning (J_val 100.3 %, nk 1001): shown in its row and
//     prominently on its result;
//   - plant models (linear, narx) are offered no Activate, in the store or on their result, and the form's
//     "activate when done" is only offered for controllers; an LQ feedforward is offered "Activate as feedforward";
//     when the server refuses an activation its error text is shown; accepted, the status shows the model active.
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
  await until(async () => (await page.getAttribute('#status-drive-note', 'data-level')) === 'limit', 8000,
              `the status never says the drive is at its limit (peak drive shown: "${await page.textContent('#status-peak-drive')}")`);
  const peak = (await page.textContent('#status-peak-drive')).trim();
  const note = (await page.textContent('#status-drive-note')).trim();
  run.log(`peak drive ${peak}: ${note}`);
  check(peak === '0.9999', `peak drive shown as "${peak}"`);
  check(await page.isVisible('#status-drive-note') && note.includes('needs more drive than the chain allows'),
        `the status does not say plainly that the program needs more drive than the chain allows: "${note}"`);

  run.step = 'a finished job shown without a click';
  const linearJob = (await post('api/jobs', { kind: 'identify-linear', params: { samples: 3000 } })).id;
  await shownWithoutClick(linearJob, 'identify-linear');
  await page.waitForSelector('#plot-fit canvas', { timeout: 5000 });
  check(await page.isVisible('#result-hint') && /click another job/i.test(await page.textContent('#result-hint')),
        'no hint that clicking another job shows its plots');
  const linearModel = await page.$eval('#result-activate', (e) => e.dataset.modelId);

  run.step = 'a plant model offered no Activate';
  check(!(await page.isVisible('#result-activate')) && await page.isVisible('#result-plant-note'),
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
  check((await page.textContent('#result-activate')).trim() === 'Activate as feedforward',
        `the design-lq result's button reads "${await page.textContent('#result-activate')}"`);
  await until(async () => (await page.$$('#models-table tbody tr')).length === 3, 8000, 'the store never lists the 3 models');
  const offered = await page.$$eval('#models-table tbody tr', (trs) => Object.fromEntries(trs.map((tr) =>
    [tr.children[1].textContent, tr.querySelector('button.activate')?.textContent ?? ''])));
  run.log(`Activate offered: ${JSON.stringify(offered)}`);
  check(JSON.stringify(offered) === JSON.stringify({ lq_feedforward: 'Activate as feedforward', narx: '', linear: '' }),
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

  run.step = 'no page errors';
  check(run.pageErrors.length === 0, `${run.pageErrors.length} error(s) in the page`);
}

run.run(main);

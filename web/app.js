// panelbass dashboard: engine status, chain settings, the program played, jobs with live progress, results
// with plots, the model store and the uploaded records — all through the HTTP API of `panelbass serve`
// (api/ROUTES.md). This file wires the panels (web/ui/, a module each) to the page and starts their polls.

import { initConfig, loadConfig } from './ui/config.js';
import { $, el, every } from './ui/dom.js';
import { startJob, updateJobForm, updatePreview } from './ui/job_form.js';
import { cancelJob, refreshJobs } from './ui/jobs.js';
import { activate, refreshModels, uploadModel } from './ui/models.js';
import { initProgram, loadProgram } from './ui/program.js';
import { refreshRecords, uploadRecord } from './ui/records.js';
import { state } from './ui/state.js';
import { pollStatus } from './ui/status.js';
import { tune } from './ui/tune.js';

const STATUS_PERIOD_MS = 1000;
const JOBS_PERIOD_MS = 2000;
const MODELS_PERIOD_MS = 5000;
const CONFIG_PERIOD_MS = 5000;
const PROGRAM_PERIOD_MS = 2000;

/** Wires the forms and buttons, warns when uPlot is missing, and starts the polls. */
function init() {
  initConfig();
  initProgram();
  $('#upload-form').addEventListener('submit', uploadModel);
  $('#record-form').addEventListener('submit', uploadRecord);
  $('#job-form').addEventListener('submit', startJob);
  $('#job-form').addEventListener('input', updatePreview);
  $('#job-form').addEventListener('change', updateJobForm);
  $('#tune-start').addEventListener('click', tune);
  $('#job-cancel').addEventListener('click', () => state.selected && cancelJob(state.selected));
  $('#result-activate').addEventListener('click', () => {
    const { modelId, slot } = $('#result-activate').dataset;
    if (modelId && slot) activate(modelId, slot, $('#result-activated'));
  });
  updateJobForm();

  if (typeof window.uPlot !== 'function') {
    document.body.prepend(el('div', { class: 'error banner' },
      'uPlot did not load (node_modules/uplot/dist/uPlot.iife.min.js): run scripts/web_setup.sh; plots are off.'));
  }

  every(STATUS_PERIOD_MS, pollStatus);
  every(JOBS_PERIOD_MS, refreshJobs);
  every(MODELS_PERIOD_MS, refreshModels);
  every(MODELS_PERIOD_MS, refreshRecords);
  every(CONFIG_PERIOD_MS, () => (state.configDirty ? null : loadConfig()));
  every(PROGRAM_PERIOD_MS, loadProgram);
}

init();

// What the dashboard last saw of the server, shared by its panels.

/** What the dashboard last saw: status, models, jobs, settings and the selected job. */
export const state = {
  status: null,
  activeKey: '',      // the active models last seen, to refresh what depends on them when they change
  models: [],
  records: [],        // the uploaded records (their summaries)
  jobs: null,         // null until the job list was first read
  config: null,
  configDirty: false,
  selected: null,     // id of the job shown in the result panel
  selectedJob: null,  // its last known record
  follow: null,       // {id, source: EventSource|null, timer}
  renderedResult: null,
  plots: [],
};

/** A model id with its name from the store ("m0123… · name"); "—" for none. */
export function modelLabel(id) {
  if (!id) return '—';
  const m = state.models.find((x) => x.id === id);
  return m && m.name ? `${id} · ${m.name}` : id;
}

/** The slots that run model `m` (its summary from the store), as the server lists them (`slots`); [] for none. */
export function slotsOf(m) {
  return Array.isArray(m?.slots) ? m.slots.filter((s) => s === 'feedforward' || s === 'feedback') : [];
}

/** The plant kinds: models of the transducer, which controllers are designed on. */
const PLANT_KINDS = new Set(['linear', 'narx']);

/** Why no slot runs model `m` (a summary with `slots: []`): short, and the longer explanation. */
export function whyNoSlot(m) {
  if (PLANT_KINDS.has(m?.kind)) {
    return { short: 'a plant model: design a controller on it',
             long: 'A plant model: design a controller on it (Design LQ feedforward / NN feedback) and activate that; '
               + 'no slot takes a plant.' };
  }
  const what = m?.kind ? `this ${m.kind} model` : 'this model';
  return { short: `no slot runs ${what}`, long: `No slot runs ${what}: the server lists no slot that accepts it.` };
}

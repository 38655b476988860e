// What the dashboard last saw of the server, shared by its panels.

/** What the dashboard last saw: status, models, jobs, settings and the selected job. */
export const state = {
  status: null,
  activeKey: '',      // the active models last seen, to refresh what depends on them when they change
  models: [],
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

/** The engine slot a model of `kind` goes into: controllers only (a `linear` or `narx` model is a plant, which
 *  controllers are designed on, and no slot takes one); null for a plant or an unknown kind. */
export function slotForKind(kind) {
  return { lq_feedforward: 'feedforward', neural_feedback: 'feedback' }[kind] ?? null;
}

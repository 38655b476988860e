// What the dashboard last saw of the server, shared by its panels.

/** What the dashboard last saw: status, models, jobs, settings and the selected job. */
export const state = {
  status: null,
  activeKey: '',      // the active models last seen, to refresh what depends on them when they change
  models: [],
  jobs: [],
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

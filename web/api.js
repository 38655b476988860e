// The HTTP API of `panelbass serve` (api/ROUTES.md), as small async functions.
// Every failure becomes an ApiError carrying the server's {"error":{"code","message"}}.

/** An API error: HTTP status, the server's error code and its message. */
export class ApiError extends Error {
  constructor(status, code, message) {
    super(message);
    this.status = status;
    this.code = code;
  }
  /** "bad_request: params.order: must be …" — what the UI shows next to a form. */
  toString() {
    return this.code ? `${this.code}: ${this.message}` : this.message;
  }
}

/** A request to the API; JSON out. `body` is sent as JSON unless it is already a string, or as it is with its own
 *  type when it is a file (a Blob: a recording's WAV or CSV). */
export async function request(method, path, body) {
  const init = { method, headers: { Accept: 'application/json' } };
  if (body !== undefined) {
    const file = typeof Blob !== 'undefined' && body instanceof Blob;
    init.headers['Content-Type'] = file ? (body.type || 'application/octet-stream') : 'application/json';
    init.body = file || typeof body === 'string' ? body : JSON.stringify(body);
  }
  let response;
  try {
    response = await fetch(path, init);
  } catch (e) {
    throw new ApiError(0, 'unreachable', `server unreachable (${e.message})`);
  }
  if (response.status === 204) return null;
  const text = await response.text();
  let json = null;
  if (text) {
    try {
      json = JSON.parse(text);
    } catch {
      if (!response.ok) throw new ApiError(response.status, `http_${response.status}`, text.slice(0, 300));
      throw new ApiError(response.status, 'bad_response', `${method} ${path}: response is not JSON`);
    }
  }
  if (!response.ok) {
    const err = json && json.error;
    throw new ApiError(response.status, err?.code ?? `http_${response.status}`,
                       err?.message ?? `${method} ${path} failed with HTTP ${response.status}`);
  }
  return json;
}

export const api = {
  health: () => request('GET', '/api/health'),
  status: () => request('GET', '/api/status'),
  config: () => request('GET', '/api/config'),
  patchConfig: (patch) => request('PATCH', '/api/config', patch),

  models: () => request('GET', '/api/models'),
  model: (id) => request('GET', `/api/models/${encodeURIComponent(id)}`),
  uploadModel: (text, name) =>
    request('POST', '/api/models' + (name ? `?name=${encodeURIComponent(name)}` : ''), text),
  deleteModel: (id) => request('DELETE', `/api/models/${encodeURIComponent(id)}`),
  activateModel: (id, slot) =>
    request('POST', `/api/models/${encodeURIComponent(id)}/activate`, slot ? { slot } : {}),

  records: () => request('GET', '/api/records?limit=1000'),
  /** Uploads a WAV or CSV file; `query` holds fs, input, output, current and name (empty ones left out). */
  uploadRecord: (file, query) => {
    const q = new URLSearchParams(Object.entries(query).filter(([, v]) => v !== '' && v !== undefined)).toString();
    return request('POST', `/api/records${q ? `?${q}` : ''}`, file);
  },
  deleteRecord: (id) => request('DELETE', `/api/records/${encodeURIComponent(id)}`),

  jobs: () => request('GET', '/api/jobs'),
  job: (id) => request('GET', `/api/jobs/${encodeURIComponent(id)}`),
  startJob: (kind, params, activate) => request('POST', '/api/jobs', { kind, params, activate: !!activate }),
  cancelJob: (id) => request('DELETE', `/api/jobs/${encodeURIComponent(id)}`),
  jobEventsUrl: (id) => `/api/jobs/${encodeURIComponent(id)}/events`,
};

/** Job states after which nothing changes any more. */
export const FINISHED_STATES = new Set(['succeeded', 'failed', 'cancelled']);

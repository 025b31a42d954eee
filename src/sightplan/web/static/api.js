// Talking to sightplan's REST API: JSON requests whose errors carry the server's one-line message, uploads with
// byte progress, and the Server-Sent Events of a background job.

export class ApiError extends Error {
  constructor(status, detail, violations = null) {
    super(detail);
    this.status = status;
    this.detail = detail;
    this.violations = violations;  // an export refused for its flight checks: each violation
  }
}

async function errorOf(response) {
  let detail = `${response.status} ${response.statusText}`;
  let violations = null;
  try {
    const body = await response.json();
    if (body && typeof body.detail === 'string') detail = body.detail;
    if (body && Array.isArray(body.violations)) violations = body.violations;
  } catch {
    // not JSON: keep the status line
  }
  return new ApiError(response.status, detail, violations);
}

let onUnauthorized = null;
export function setUnauthorizedHandler(fn) { onUnauthorized = fn; }

export async function request(method, url, body, { raw = false } = {}) {
  // every request says it comes from this page: the server refuses cookie-authenticated changes without it
  const init = { method, headers: { 'X-Sightplan-Request': '1' } };
  if (body !== undefined) {
    init.headers['Content-Type'] = 'application/json';
    init.body = JSON.stringify(body);
  }
  let response;
  try {
    response = await fetch(url, init);
  } catch (err) {
    throw new ApiError(0, `the server does not answer (${err.message}); is sightplan serve still running?`);
  }
  if (!response.ok) {
    const err = await errorOf(response);
    if (response.status === 401 && onUnauthorized) onUnauthorized(err);
    throw err;
  }
  if (raw) return response;
  if (response.status === 204) return null;
  return response.json();
}

export const get = (url) => request('GET', url);
export const post = (url, body) => request('POST', url, body);
export const put = (url, body) => request('PUT', url, body);
export const del = (url) => request('DELETE', url);

export async function getBinary(url) {
  const response = await request('GET', url, undefined, { raw: true });
  return response.arrayBuffer();
}

// A download: the file is fetched first so that a refusal shows the server's message instead of a broken file.
export async function download(url) {
  const response = await request('GET', url, undefined, { raw: true });
  const disposition = response.headers.get('content-disposition') || '';
  const m = /filename\*?=(?:UTF-8'')?"?([^";]+)"?/i.exec(disposition);
  const name = m ? decodeURIComponent(m[1]) : url.split('/').pop();
  const blob = await response.blob();
  const href = URL.createObjectURL(blob);
  const a = document.createElement('a');
  a.href = href;
  a.download = name;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(href), 60000);
  return { name, size: blob.size, headers: response.headers };
}

// Multipart upload with progress of the bytes sent (fetch cannot report it).
export function upload(url, formData, onProgress) {
  return new Promise((resolve, reject) => {
    const xhr = new XMLHttpRequest();
    xhr.open('POST', url);
    xhr.setRequestHeader('X-Sightplan-Request', '1');
    xhr.responseType = 'json';
    xhr.upload.onprogress = (ev) => { if (ev.lengthComputable && onProgress) onProgress(ev.loaded / ev.total); };
    xhr.onload = () => {
      if (xhr.status >= 200 && xhr.status < 300) resolve(xhr.response);
      else {
        const detail = xhr.response && typeof xhr.response.detail === 'string' ? xhr.response.detail
          : `${xhr.status} ${xhr.statusText}`;
        if (xhr.status === 401 && onUnauthorized) onUnauthorized(new ApiError(401, detail));
        reject(new ApiError(xhr.status, detail));
      }
    };
    xhr.onerror = () => reject(new ApiError(0, 'the upload was cut off; is sightplan serve still running?'));
    xhr.send(formData);
  });
}

// Follow a job until it is done or failed: onProgress(job) on each change, resolves with the final job.
export function followJob(jobId, onProgress) {
  return new Promise((resolve, reject) => {
    const source = new EventSource(`/api/jobs/${jobId}/events`);
    let settled = false;
    const finish = (fn, value) => {
      if (settled) return;
      settled = true;
      source.close();
      fn(value);
    };
    source.addEventListener('progress', (ev) => onProgress(JSON.parse(ev.data)));
    source.addEventListener('done', (ev) => {
      const job = JSON.parse(ev.data);
      onProgress(job);
      finish(resolve, job);
    });
    source.addEventListener('failed', (ev) => {
      const job = JSON.parse(ev.data);
      finish(reject, new ApiError(0, job.error || job.detail || 'the job failed'));
    });
    source.onerror = async () => {
      // the stream broke (server restart, network): ask once where the job stands
      if (settled) return;
      try {
        const job = await get(`/api/jobs/${jobId}`);
        if (job.status === 'done') finish(resolve, job);
        else if (job.status === 'failed') finish(reject, new ApiError(0, job.error || 'the job failed'));
      } catch (err) {
        finish(reject, err);
      }
    };
  });
}

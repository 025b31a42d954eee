// What every part of the page uses to draw: $ and $$ (querySelector), el (an element with attributes, listeners and
// children), fillSelect, progress bars (set, or marked failed), and messages (act runs a user action, any failure shown as one message).

export const $ = (sel) => document.querySelector(sel);
export const $$ = (sel) => [...document.querySelectorAll(sel)];

export const el = (tag, attrs = {}, ...children) => {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'class') node.className = v;
    else if (k === 'dataset') Object.assign(node.dataset, v);
    else if (k === 'style') node.style.cssText = v;  // through the CSSOM: the page's policy forbids style attributes
    else if (k.startsWith('on')) node.addEventListener(k.slice(2), v);
    else if (v !== undefined && v !== null && v !== false) node.setAttribute(k, v === true ? '' : v);
  }
  node.append(...children.filter((c) => c !== null && c !== undefined));
  return node;
};

export function fillSelect(select, options, value) {
  select.replaceChildren(...options.map(([v, label]) => el('option', { value: String(v) }, label)));
  if (value !== undefined && value !== null && options.some(([v]) => String(v) === String(value))) {
    select.value = String(value);
  }
}

export function setProgress(box, fraction, label) {
  box.hidden = false;
  const pct = Math.max(0, Math.min(100, Math.round(fraction * 100)));
  box.setAttribute('aria-valuenow', String(pct));
  box.querySelector('.bar').style.width = `${pct}%`;
  box.querySelector('.label').textContent = label ?? `${pct} %`;
  box.classList.remove('failed');
}

// a progress bar marked failed, with what went wrong in a word or two
export function markFailed(box, label) {
  box.classList.add('failed');
  box.querySelector('.label').textContent = label;
}

export function showMessage(text, kind = 'info') {
  const box = $('#messages');
  const close = el('button', { type: 'button', title: 'close', onclick: () => msg.remove() }, '×');
  const msg = el('div', { class: `msg ${kind}`, role: kind === 'error' ? 'alert' : 'status' }, text, close);
  box.append(msg);
  while (box.children.length > 5) box.firstChild.remove();
  if (kind !== 'error') setTimeout(() => msg.remove(), 5000);
  return msg;
}

export const errorText = (err) => (err && (err.detail || err.message)) || String(err);

// run a user action: any failure becomes one readable message
export async function act(what, fn) {
  try {
    return await fn();
  } catch (err) {
    console.error(what, err);
    showMessage(`${what}: ${errorText(err)}`, 'error');
    return undefined;
  }
}

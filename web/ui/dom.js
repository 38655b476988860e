// DOM helpers of the dashboard: element lookup and creation, text and messages, table rows kept in
// step with a list, a two-click button (and a Delete one) and a self-rescheduling poll.

import { errorText } from './format.js';

/** The first element matching `selector` under `root`. */
export const $ = (selector, root = document) => root.querySelector(selector);
/** Every element matching `selector` under `root`, as an array. */
export const $$ = (selector, root = document) => Array.from(root.querySelectorAll(selector));

/** Creates an element: el('td', {class: 'mono'}, 'text', child, …). */
export function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null || v === false) continue;
    if (k === 'class') node.className = v;
    else if (k === 'dataset') Object.assign(node.dataset, v);
    else if (k.startsWith('on')) node.addEventListener(k.slice(2), v);
    else node.setAttribute(k, v === true ? '' : v);
  }
  for (const c of children) if (c !== null && c !== undefined) node.append(c);
  return node;
}

/** Sets an element's text (only when it differs, so a selection in it survives the polls). */
export function setText(selector, text) {
  const node = $(selector);
  if (node && node.textContent !== String(text)) node.textContent = String(text);
}

/** Shows `text` in a message element, or hides the element when there is none. */
export function showMessage(selector, text) {
  const node = $(selector);
  node.textContent = text || '';
  node.hidden = !text;
}

/** Runs `fn` now and then every `period` ms after it finished (never two at once). */
export function every(period, fn) {
  const tick = async () => {
    try {
      await fn();
    } finally {
      setTimeout(tick, period);
    }
  };
  tick();
}

/** Keeps a table body's rows in step with `items` (keyed by `key`), creating and updating rows in place. */
export function syncRows(tbody, items, key, create, update) {
  const existing = new Map($$('tr', tbody).map((tr) => [tr.dataset.key, tr]));
  let previous = null;
  for (const item of items) {
    const k = key(item);
    let tr = existing.get(k);
    if (!tr) {
      tr = create(item);
      tr.dataset.key = k;
    }
    existing.delete(k);
    update(tr, item);
    const wanted = previous ? previous.nextSibling : tbody.firstChild;
    if (wanted !== tr) tbody.insertBefore(tr, wanted);
    previous = tr;
  }
  for (const tr of existing.values()) tr.remove();
}

/** A button that asks for a second click within 3 s before it does `action`. */
export function confirmButton(label, action) {
  const button = el('button', { type: 'button', class: 'danger small' }, label);
  let armed = null;
  button.addEventListener('click', async () => {
    if (!armed) {
      button.textContent = 'Sure?';
      armed = setTimeout(() => { armed = null; button.textContent = label; }, 3000);
      return;
    }
    clearTimeout(armed);
    armed = null;
    button.textContent = label;
    await action();
  });
  return button;
}

/** A confirmed Delete button (class "delete") that calls `remove()`, then `refresh()`; a failure is shown in
 *  `errorSelector`, naming `id`. */
export function deleteButton(id, remove, refresh, errorSelector) {
  const button = confirmButton('Delete', async () => {
    try {
      await remove();
      showMessage(errorSelector, '');
      refresh();
    } catch (e) {
      showMessage(errorSelector, `delete ${id}: ${errorText(e)}`);
    }
  });
  button.classList.add('delete');
  return button;
}

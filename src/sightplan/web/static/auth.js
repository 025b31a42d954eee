// Who uses the page: the server's mode (single-user or team), the login dialog, logging out, changing the
// password, the user's name and role in the top bar, and what that role may do (controls a viewer may not use are
// disabled, editing panels hidden).
import * as api from './api.js';
import { $, $$, act, errorText } from './dom.js';
import { canEdit, isOwner, projectRole } from './context.js';
import { set, state, subscribe } from './store.js';
import { loadTokens } from './team.js';

// the server's mode and, in team mode, who is logged in; false while the login dialog is open
export async function readSession() {
  const info = await api.get('/api/info');
  set({ info });
  let loggedIn = true;
  const badge = $('#mode-badge');
  if (info.login) {
    badge.textContent = 'team mode';
    badge.classList.add('team');
    try {
      set({ me: await api.get('/api/auth/me') });
    } catch (err) {
      if (err.status !== 401) throw err;
      loggedIn = false;  // the page opens the login dialog once it has settled
    }
  } else {
    badge.textContent = 'single-user · no login';
  }
  badge.title = info.message;
  return loggedIn;
}

export function showLogin() {
  const dialog = $('#login-dialog');
  if (dialog.open) return;
  $('#login-error').hidden = true;
  dialog.showModal();
  $('#login-user').focus();
}

async function logIn() {
  const username = $('#login-user').value.trim();
  const password = $('#login-password').value;
  if (!username || !password) {
    $('#login-error').textContent = 'Give your user name and password.';
    $('#login-error').hidden = false;
    return;
  }
  $('#login-submit').disabled = true;
  try {
    await api.post('/api/auth/login', { username, password });
  } catch (err) {
    $('#login-error').textContent = errorText(err);
    $('#login-error').hidden = false;
    return;
  } finally {
    $('#login-submit').disabled = false;
  }
  $('#login-password').value = '';
  $('#login-dialog').close();
  window.location.reload();  // everything read again, as this user
}

// the account dialog: password change (here) and API tokens (team.js)
async function openAccount() {
  $('#pw-error').hidden = true;
  $('#token-new').hidden = true;
  $('#account-dialog').showModal();
  await loadTokens();
}

async function changePassword() {
  const body = { old_password: $('#pw-old').value, new_password: $('#pw-new').value };
  try {
    await api.post('/api/auth/password', body);
  } catch (err) {
    $('#pw-error').textContent = errorText(err);
    $('#pw-error').hidden = false;
    return;
  }
  $('#pw-old').value = '';
  $('#pw-new').value = '';
  $('#account-dialog').close();
  window.location.reload();  // the sessions ended: log in again with the new password
}

async function logOut() {
  await api.post('/api/auth/logout');
  set({ me: null });
  window.location.reload();
}

// in team mode: who is logged in, and their role in the project shown
function renderUser() {
  const box = $('#user-box');
  box.hidden = !(state.info && state.info.login && state.me);
  if (box.hidden) return;
  $('#user-name').textContent = state.me.username;
  const role = projectRole();
  $('#user-role').textContent = role || 'no project';
  $('#user-role').dataset.role = role || '';
}

// a viewer is not offered what the server would refuse: controls disabled, editing panels hidden
function applyRole() {
  const allowed = { editor: canEdit(), owner: isOwner() };
  document.body.dataset.role = projectRole() || (state.info && state.info.login ? 'none' : 'single-user');
  for (const node of $$('[data-needs]')) {
    const ok = allowed[node.dataset.needs];
    if (node.matches('button, input, select, textarea')) {
      if (node.dataset.title === undefined) node.dataset.title = node.title;
      node.disabled = !ok;
      node.title = ok ? node.dataset.title : `your role in this project (${projectRole()}) cannot do this`;
    } else node.hidden = !ok;
  }
  renderUser();
}

export function bindAuth() {
  subscribe(['info', 'me', 'project'], applyRole);
  $('#login-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Logging in', logIn);
  });
  // the dialog stays until a login succeeds: every request would be refused without one
  $('#login-dialog').addEventListener('cancel', (ev) => ev.preventDefault());
  $('#logout').addEventListener('click', () => act('Logging out', logOut));
  $('#account').addEventListener('click', () => act('Reading your API tokens', openAccount));
  $('#password-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Changing the password', changePassword);
  });
}

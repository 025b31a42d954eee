// Team mode's sharing: the project's members and their roles (owners change them), the user's API tokens (in the
// account dialog), and read-only share links to a plan (made and revoked by editors).
import * as api from './api.js';
import { $, act, el, showMessage } from './dom.js';
import { canEdit, isOwner, projectUrl } from './context.js';
import { set, state, subscribe } from './store.js';

let projectLeft = null;  // bindTeam's: what opens once the user left the project shown

// ---------------------------------------------------------------------------------------------- members
export async function loadMembers() {
  const card = $('#sec-team');
  card.hidden = !(state.info && state.info.login && state.project);
  if (card.hidden) return;
  const project = state.project.id;
  const members = await act('Listing the members', () => api.get(projectUrl('/members')));
  if (!members || !state.project || state.project.id !== project) return;
  set({ members });
}

function renderMembers() {
  const owner = isOwner();
  const rows = state.members.map((m) => {
    const self = state.me && m.username === state.me.username;
    const role = owner ? el('select', { 'aria-label': `role of ${m.username}`, onchange: (ev) => act('Changing the role', async () => {
      await api.request('PATCH', projectUrl(`/members/${m.user_id}`), { role: ev.target.value });
      showMessage(`${m.username} is now ${ev.target.value}.`, 'ok');
      await afterMembership();
    }) }, ...['viewer', 'editor', 'owner'].map((r) => el('option', { value: r, selected: r === m.role }, r)))
      : el('span', {}, m.role);
    const remove = owner || self ? el('button', { type: 'button', class: 'icon', title: self ? 'leave the project' : `remove ${m.username}`,
      onclick: () => act('Removing the member', async () => {
        await api.del(projectUrl(`/members/${m.user_id}`));
        showMessage(self ? 'You left the project.' : `${m.username} removed.`, 'ok');
        if (self) await projectLeft();
        else await afterMembership();
      }) }, self ? 'leave' : '✕') : '';
    return el('tr', { dataset: { member: m.username, role: m.role } }, el('td', {}, m.username + (self ? ' (you)' : '')),
      el('td', {}, role), el('td', {}, remove));
  });
  $('#members-table tbody').replaceChildren(...rows);
}

// a role changed: my own may have too (what depends on the role follows the project)
async function afterMembership() {
  const [fresh, members] = await Promise.all([api.get(projectUrl('')), api.get(projectUrl('/members'))]);
  const project = { ...state.project, ...fresh };
  set({ project, projects: state.projects.map((p) => (p.id === project.id ? project : p)), members });
}

async function addMember() {
  const username = $('#member-name').value.trim();
  if (!username) throw new Error('give the user name of an account (made with sightplan users add)');
  const m = await api.post(projectUrl('/members'), { username, role: $('#member-role').value });
  $('#member-name').value = '';
  showMessage(`${m.username} is a ${m.role} of this project now.`, 'ok');
  await afterMembership();
}

// ---------------------------------------------------------------------------------------------- API tokens
export async function loadTokens() {
  const tokens = await api.get('/api/auth/tokens');
  const rows = tokens.map((t) => {
    const li = el('li', { 'data-token': String(t.id) });
    const used = t.last_used_at ? `last used ${new Date(t.last_used_at).toLocaleString()}` : 'never used';
    li.append(el('span', {}, `${t.name || '(no name)'} · created ${new Date(t.created_at).toLocaleDateString()} · ${used} `));
    const revoke = el('button', { type: 'button' }, 'Revoke');
    revoke.addEventListener('click', () => act('Revoking the token', async () => {
      await api.del(`/api/auth/tokens/${t.id}`);
      await loadTokens();
    }));
    li.append(revoke);
    return li;
  });
  if (!rows.length) rows.push(el('li', { class: 'hint' }, 'No API tokens.'));
  $('#token-list').replaceChildren(...rows);
}

async function createToken() {
  const t = await api.post('/api/auth/tokens', { name: $('#token-name').value.trim() });
  $('#token-secret').value = t.token;
  $('#token-secret').dataset.token = String(t.id);
  $('#token-new').hidden = false;
  $('#token-name').value = '';
  await loadTokens();
}

// ---------------------------------------------------------------------------------------------- share links
export async function loadLinks() {
  const list = $('#share-links');
  if (!state.plan || !canEdit() || !$('#share-box').open) {
    list.replaceChildren();
    return;
  }
  const plan = state.plan.id;
  const all = await api.get(projectUrl('/links'));
  if (!state.plan || state.plan.id !== plan) return;
  const links = all.filter((l) => l.plan_id === plan);
  set({ links });
  const when = (t) => new Date(t).toLocaleString('en-GB', { dateStyle: 'short', timeStyle: 'short' });
  list.replaceChildren(...links.map((l) => el('li', { dataset: { link: l.id, state: l.revoked_at ? 'revoked' : 'active' } },
    el('span', {}, `link #${l.id}, made ${when(l.created_at)}`),
    l.revoked_at ? el('span', { class: 'hint' }, ` revoked ${when(l.revoked_at)}`)
      : el('button', { type: 'button', class: 'danger', onclick: () => act('Revoking the link', async () => {
        await api.del(projectUrl(`/links/${l.id}`));
        showMessage(`Link #${l.id} revoked: it answers 404 from now on.`, 'ok');
        await loadLinks();
      }) }, 'Revoke'))));
  if (!links.length) list.append(el('li', { class: 'hint' }, 'No link to this plan yet.'));
}

async function createLink() {
  if (!state.plan) throw new Error('create or choose a plan first');
  const link = await api.post(projectUrl(`/plans/${state.plan.id}/links`), {});
  $('#share-new').hidden = false;
  $('#share-url').value = link.url;
  $('#share-url').dataset.link = String(link.id);
  $('#share-url').select();
  showMessage(`Share link #${link.id} made: copy it now, it is shown only once.`, 'ok');
  await loadLinks();
}

// projectLeft(): what to open once the user left the project shown
export function bindTeam(callbacks) {
  projectLeft = callbacks.projectLeft;
  subscribe(['members', 'me', 'info', 'project'], renderMembers);
  $('#member-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Adding the member', addMember);
  });
  $('#token-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    act('Creating an API token', createToken);
  });
  $('#share-box').addEventListener('toggle', () => act('Listing the share links', loadLinks));
  $('#share-create').addEventListener('click', () => act('Making a share link', createLink));
}

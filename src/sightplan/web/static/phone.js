// The page on a phone or a tablet (app.css's narrow layout, up to 900 px wide): the 3D view fills the screen and the
// panels are sheets over it, one at a time, opened from the bottom bar (#phone-bar): Plan (the sidebar's cards but
// Evaluate), Evaluate, Frame (the inspector, with the frame editing card moved into it), Metrics and Checks (the bottom
// tabs, open at that tab). The view's toolbars fold behind one button (#view.tools-open); the 3D | Map switch sets
// #view.show-map (its Map button shows where the page has a #map-box). While points are picked in the 3D view the
// sheet steps aside, and comes back when the picking stops. A stacked table (table.stack: the plan metrics, the flight
// checks) shows each cell under its column's heading, copied into td[data-label].
//
// Interface: bindPhoneLayout() wires it once; body[data-sheet] names the sheet open ('' for none).
import { $, $$ } from './dom.js';

const NARROW = window.matchMedia('(max-width: 900px)');
const TABS = { metrics: 'metrics', checks: 'checks' };  // sheet → the bottom tab it opens at

function openSheet(name) {
  document.body.dataset.sheet = name;
  for (const b of $$('#phone-bar button')) b.setAttribute('aria-pressed', String(b.dataset.sheet === name));
  if (!TABS[name]) return;
  const tab = $(`#bottom .tabs button[data-tab="${TABS[name]}"]`);
  tab.click();
  const strip = tab.parentElement;  // the tab in sight where the strip scrolls sideways
  strip.scrollLeft += tab.getBoundingClientRect().left - strip.getBoundingClientRect().left - 8;
}

// the frame editing card: in the sidebar on a wide screen, in the Frame sheet below the frame's card on a narrow one
function placeEditCard() {
  const card = $('#sec-edit');
  if (NARROW.matches) $('#inspector').append(card);
  else $('#sec-eval').before(card);
}

// each cell's column heading, for the stacked rows of a narrow screen (a cell over several columns has none)
function labelCells(table) {
  const heads = [...table.querySelectorAll('thead th')].map((th) => th.textContent.trim());
  for (const tr of table.tBodies[0].rows) {
    let column = 0;
    for (const td of tr.cells) {
      if (td.colSpan === 1 && heads[column]) td.dataset.label = heads[column];
      column += td.colSpan;
    }
  }
}

export function bindPhoneLayout() {
  for (const b of $$('#phone-bar button')) {
    b.addEventListener('click', () => openSheet(document.body.dataset.sheet === b.dataset.sheet ? '' : b.dataset.sheet));
  }
  openSheet('');
  $('#tools-toggle').addEventListener('click', () => {
    $('#tools-toggle').setAttribute('aria-expanded', String($('#view').classList.toggle('tools-open')));
  });
  const views = $$('#view-switch button');
  for (const b of views) {
    b.addEventListener('click', () => {
      $('#view').classList.toggle('show-map', b.dataset.view === 'map');
      for (const other of views) other.setAttribute('aria-selected', String(other === b));
    });
  }
  $('#view-switch [data-view=map]').hidden = !document.getElementById('map-box');
  NARROW.addEventListener('change', placeEditCard);
  placeEditCard();
  for (const table of $$('table.stack')) {
    new MutationObserver(() => labelCells(table)).observe(table, { childList: true, subtree: true });
    labelCells(table);
  }
  let stepped = '';  // the sheet that stepped aside for the picking
  new MutationObserver(() => {
    const picking = Boolean(document.body.dataset.picking);
    if (picking && NARROW.matches && document.body.dataset.sheet) {
      stepped = document.body.dataset.sheet;
      openSheet('');
    } else if (!picking && stepped) {
      openSheet(stepped);
      stepped = '';
    }
  }).observe(document.body, { attributes: true, attributeFilter: ['data-picking'] });
}

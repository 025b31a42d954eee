// Loaded before the page's modules: if one of them cannot be loaded (three.js not installed), say so on the page.
window.addEventListener('error', (event) => {
  const el = event.target;
  if (!(el instanceof HTMLScriptElement)) return;
  document.body.dataset.state = 'error';
  const empty = document.getElementById('view-empty');
  if (empty) {
    empty.textContent = 'The page’s scripts could not be loaded (is three.js installed? run make setup, '
      + 'which runs npm ci --prefix web).';
  }
}, true);

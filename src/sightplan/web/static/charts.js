// Small canvas charts: the histogram of a per-element metric, and ν_f (stable features) along the path.
import { rgbCss } from './colours.js';

function setup(canvas) {
  const dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth || 600;
  const h = canvas.clientHeight || 160;
  canvas.width = Math.round(w * dpr);
  canvas.height = Math.round(h * dpr);
  const ctx = canvas.getContext('2d');
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  ctx.font = '11px system-ui, sans-serif';
  return { ctx, w, h };
}

function niceTicks(lo, hi, count = 5) {
  const span = hi - lo || 1;
  const step0 = span / count;
  const mag = 10 ** Math.floor(Math.log10(step0));
  const step = [1, 2, 2.5, 5, 10].map((s) => s * mag).find((s) => span / s <= count) || 10 * mag;
  const ticks = [];
  for (let t = Math.ceil(lo / step) * step; t <= hi + 1e-12 * span; t += step) ticks.push(Number(t.toPrecision(12)));
  return ticks;
}

export function formatNumber(v, digits = 3) {
  if (v === null || v === undefined || !Number.isFinite(v)) return '—';
  if (v !== 0 && (Math.abs(v) < 0.01 || Math.abs(v) >= 1e5)) return v.toExponential(digits - 1);
  return String(Number(v.toPrecision(digits)));
}

function axes(ctx, box, yMax, xLabel, yLabel) {
  const { left, top, right, bottom } = box;
  ctx.strokeStyle = '#8a94a3';
  ctx.fillStyle = '#4a5564';
  ctx.beginPath();
  ctx.moveTo(left, top);
  ctx.lineTo(left, bottom);
  ctx.lineTo(right, bottom);
  ctx.stroke();
  ctx.textAlign = 'right';
  ctx.textBaseline = 'middle';
  for (const t of niceTicks(0, yMax, 4)) {
    const y = bottom - (t / yMax) * (bottom - top);
    ctx.fillText(formatNumber(t, 3), left - 4, y);
    ctx.strokeStyle = '#e3e7ed';
    ctx.beginPath();
    ctx.moveTo(left + 1, y);
    ctx.lineTo(right, y);
    ctx.stroke();
  }
  ctx.save();
  ctx.translate(10, (top + bottom) / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.textAlign = 'center';
  ctx.fillText(yLabel, 0, 0);
  ctx.restore();
  ctx.textAlign = 'center';
  ctx.textBaseline = 'top';
  ctx.fillText(xLabel, (left + right) / 2, bottom + 16);
}

// values of the visible target elements; bins coloured by the gradient at their centre
export function drawHistogram(canvas, { metric, values, lo, hi, colourAt, label, unit, classes }) {
  const { ctx, w, h } = setup(canvas);
  const box = { left: 48, top: 10, right: w - 12, bottom: h - 34 };
  if (metric === 'visibility') {
    const counts = classes.counts;
    const yMax = Math.max(...counts, 1);
    axes(ctx, box, yMax, 'visibility class of the target elements', 'elements');
    const bw = (box.right - box.left) / counts.length;
    counts.forEach((c, k) => {
      const x = box.left + k * bw + bw * 0.15;
      const y = box.bottom - (c / yMax) * (box.bottom - box.top);
      ctx.fillStyle = rgbCss(classes.colours[k]);
      ctx.fillRect(x, y, bw * 0.7, box.bottom - y);
      ctx.fillStyle = '#1d2633';
      ctx.textAlign = 'center';
      ctx.textBaseline = 'bottom';
      ctx.fillText(`${classes.labels[k]}: ${c}`, x + bw * 0.35, Math.max(y - 2, box.top + 10));
    });
    return { bins: counts };
  }
  const finite = values.filter((v) => v !== null && Number.isFinite(v));
  const nBins = 24;
  const bins = new Array(nBins).fill(0);
  const span = hi - lo || 1;
  for (const v of finite) bins[Math.min(nBins - 1, Math.max(0, Math.floor(((v - lo) / span) * nBins)))]++;
  const yMax = Math.max(...bins, 1);
  axes(ctx, box, yMax, `${label}${unit ? ` (${unit})` : ''} — ${finite.length} visible target elements`, 'elements');
  const bw = (box.right - box.left) / nBins;
  bins.forEach((c, k) => {
    if (!c) return;
    const y = box.bottom - (c / yMax) * (box.bottom - box.top);
    ctx.fillStyle = rgbCss(colourAt(lo + ((k + 0.5) / nBins) * span));
    ctx.fillRect(box.left + k * bw + 0.5, y, bw - 1, box.bottom - y);
  });
  ctx.fillStyle = '#4a5564';
  ctx.textBaseline = 'top';
  ctx.textAlign = 'center';
  for (const t of niceTicks(lo, hi, 6)) {
    const x = box.left + ((t - lo) / span) * (box.right - box.left);
    ctx.fillText(formatNumber(t, 3), x, box.bottom + 3);
  }
  return { bins };
}

// ν_f per frame along the path, stable frames green, unstable red, Λ dashed, missions separated
export function drawStability(canvas, { nu, stable, lambda, missions, selected, colours }) {
  const { ctx, w, h } = setup(canvas);
  const box = { left: 48, top: 14, right: w - 12, bottom: h - 34 };
  const n = nu.length;
  const yMax = Math.max(...nu, lambda, 1) * 1.08;
  axes(ctx, box, yMax, `frame along the path (${n} frames)`, 'ν_f');
  const bw = (box.right - box.left) / Math.max(n, 1);
  for (let i = 0; i < n; i++) {
    const y = box.bottom - (nu[i] / yMax) * (box.bottom - box.top);
    ctx.fillStyle = rgbCss(stable[i] ? colours.stable : colours.unstable);
    ctx.fillRect(box.left + i * bw, y, Math.max(bw - (bw > 3 ? 1 : 0), 0.6), box.bottom - y);
  }
  const yl = box.bottom - (lambda / yMax) * (box.bottom - box.top);
  ctx.setLineDash([5, 4]);
  ctx.strokeStyle = '#1d2633';
  ctx.beginPath();
  ctx.moveTo(box.left, yl);
  ctx.lineTo(box.right, yl);
  ctx.stroke();
  ctx.setLineDash([]);
  ctx.fillStyle = '#1d2633';
  ctx.textAlign = 'right';
  ctx.textBaseline = 'bottom';
  ctx.fillText(`Λ = ${lambda}`, box.right, yl - 2);
  ctx.strokeStyle = '#9aa3b0';
  ctx.textAlign = 'center';
  ctx.textBaseline = 'top';
  for (const m of missions) {
    const x = box.left + m.start * bw;
    if (m.start > 0) {
      ctx.setLineDash([2, 3]);
      ctx.beginPath();
      ctx.moveTo(x, box.top);
      ctx.lineTo(x, box.bottom);
      ctx.stroke();
      ctx.setLineDash([]);
    }
    ctx.fillStyle = '#4a5564';
    ctx.fillText(m.name, box.left + ((m.start + m.stop) / 2) * bw, 1);
  }
  if (selected !== null && selected !== undefined && selected < n) {
    ctx.strokeStyle = '#ff00aa';
    ctx.lineWidth = 2;
    const x = box.left + (selected + 0.5) * bw;
    ctx.beginPath();
    ctx.moveTo(x, box.top);
    ctx.lineTo(x, box.bottom);
    ctx.stroke();
    ctx.lineWidth = 1;
  }
  return { frameAt: (clientX) => {
    const rect = canvas.getBoundingClientRect();
    const i = Math.floor((clientX - rect.left - box.left) / bw);
    return i >= 0 && i < n ? i : null;
  } };
}

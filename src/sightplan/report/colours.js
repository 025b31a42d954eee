// Element and frame colours, shared by the HTML report's viewer (viewer.js, inlined by html.py) and the web page
// (served as /static/colours.js). Both read the data of html.py's viewer_data: the colours and default bounds of
// report/gltf.py, a traffic-light gradient between two bounds (green good → yellow → red bad), unseen targets red,
// occluders grey. Colours here are sRGB in [0, 1].

export function hexToRgb(hex) {
  const n = parseInt(hex.slice(1), 16);
  return [((n >> 16) & 255) / 255, ((n >> 8) & 255) / 255, (n & 255) / 255];
}

export const rgbCss = (rgb) => `rgb(${rgb.map((c) => Math.round(c * 255)).join(',')})`;

export const NEUTRAL_TARGET = [0.78, 0.81, 0.86];
export const NEUTRAL_OCCLUDER = [0.72, 0.72, 0.72];
export const IN_PROGRESS = [0.96, 0.55, 0.12];
export const NOT_YET = [0.80, 0.82, 0.86];
export const STABLE = [0.20, 0.66, 0.33];
export const UNSTABLE = [0.86, 0.20, 0.18];
export const MISSION_PALETTE = ['#1f6fd1', '#8e44ad', '#0e9aa7', '#d35400', '#2c3e50', '#16a085', '#c0392b', '#7f8c8d',
  '#b7950b', '#5d6d7e'].map(hexToRgb);

export class Colourer {
  constructor(feedback) {
    this.fb = feedback;
    const c = feedback.colours;
    this.stops = c.gradient_rgb || c.gradient.map(hexToRgb);
    this.classes = c.classes_rgb || c.classes.map(hexToRgb);
    this.unseen = c.unseen_rgb || hexToRgb(c.unseen);
    this.occluder = c.occluder_rgb || hexToRgb(c.occluder);
  }

  // 0 good (green) → 0.5 yellow → 1 bad (red), interpolated in sRGB like the report's colours
  gradient(t) {
    const s = this.stops;
    const x = Math.min(1, Math.max(0, t)) * (s.length - 1);
    const k = Math.min(s.length - 2, Math.floor(x));
    const f = x - k;
    return s[k].map((c, j) => c + (s[k + 1][j] - c) * f);
  }

  label(metric) { return this.fb.labels[metric]; }

  defaultBounds(metric) { return this.fb.labels[metric].bounds; }

  // badness in [0, 1] of a value, or null where the metric is undefined for it
  badness(metric, v, lo, hi) {
    if (v === null || v === undefined) return null;
    return this.fb.labels[metric].higher_better ? (hi - v) / (hi - lo) : (v - lo) / (hi - lo);
  }

  colourOf(metric, i, lo, hi) {
    if (!this.fb.elements.target[i]) return this.occluder;
    const v = this.fb.metrics[metric][i];
    if (metric === 'visibility') return this.classes[v];
    const t = this.badness(metric, v, lo, hi);
    return t === null ? this.unseen : this.gradient(t);
  }
}

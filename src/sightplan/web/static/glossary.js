// What each metric means: the server's definitions (from sightplan.metrics.glossary), shown as the tooltip of every
// metric label on the page, with the thresholds in force: the shown evaluation's (its feedback's metric_help), else
// the defaults (GET /api/info: metric_help).
import { state } from './store.js';

const ALIASES = { R_i_m_per_px: 'R_i', O_i_deg: 'O_i' };

/** The definition of metric ``key`` (a report key: VC_pct, VR, R_m_per_px, …, VR_i, R_i_m_per_px, O_i_deg), or ''. */
export function metricHelp(key) {
  const help = (state.feedback && state.feedback.metric_help) || (state.info && state.info.metric_help);
  const d = help && help[ALIASES[key] || key];
  return d ? d.text : '';
}

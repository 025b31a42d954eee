"""The reliability plot of held-out predictions, beside the paper's Table 2 correlations."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .model import HeldOut, calibration

#: The paper's plan metrics set beside the predictor, with the quality each is read against (Table 2).
PAPER_PAIRS = (("VR", "Ce"), ("VR", "Cv"), ("VC", "Cv"), ("R", "Cv"), ("O", "Cv"))


def plot_reliability(held: list[HeldOut], predicted, measured, groups, out: str | Path, *, paper=None,
                     title: str = "") -> Path:
    """``out`` (PNG): left, the reliability diagram of the held-out predictions (mean measured against mean
    predicted completeness in tenths of the prediction, per held-out model and pooled, with the diagonal); right,
    Pearson r on each held-out model of the predictor and of the best single metric (signed so that positive is
    the direction it had on the fitted models), beside the paper's Table 2 r
    (a :class:`sightplan.study.Study`, when given) of its plan metrics against Ce and Cv."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    p, c, g = np.asarray(predicted, float), np.asarray(measured, float), np.asarray(groups).astype(str)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11.5, 4.6), gridspec_kw={"width_ratios": [1, 1.25]})
    ax.plot([0, 1], [0, 1], color="#888", lw=1, ls="--", label="calibrated")
    colours = plt.get_cmap("tab10")
    for k, h in enumerate(held):
        s = g == h.group
        bins = calibration(p[s], c[s]).bins
        slope = "n/a" if h.calibration.slope is None else f"{h.calibration.slope:.2f}"
        ax.plot([b["predicted"] for b in bins], [b["measured"] for b in bins], "o-", ms=4, lw=1, color=colours(k),
                label=f"{h.group} (n = {h.n}, slope {slope})")
    pooled = calibration(p, c)
    ax.plot([b["predicted"] for b in pooled.bins], [b["measured"] for b in pooled.bins], "s-", ms=5, lw=2,
            color="black", label=f"all held out (slope {pooled.slope:.2f})" if pooled.slope is not None else "all")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_xlabel("predicted completeness (fitted without the model)")
    ax.set_ylabel("measured completeness (mean per bin)")
    ax.set_title("reliability, leave one model out", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")

    labels, ours, single = [], [], []
    for h in held:
        labels.append(h.group)
        ours.append(np.nan if h.calibration.r is None else h.calibration.r)
        single.append(np.nan if h.best_single_aligned is None else h.best_single_aligned)
    x = np.arange(len(labels))
    bx.bar(x - 0.2, ours, 0.4, color="#1f4e9e", label="predictor, held out")
    bx.bar(x + 0.2, single, 0.4, color="#9ab", label="best single metric on the fitted models, held out "
                                                     "(signed as fitted)")
    for k, h in enumerate(held):
        if h.best_single is not None:
            y = single[k] if np.isfinite(single[k]) else 0.0
            bx.text(x[k] + 0.2, y + 0.03 if y >= 0 else y - 0.03, h.best_single, ha="center",
                    va="bottom" if y >= 0 else "top", fontsize=7)
    names = list(labels)
    if paper is not None:
        pr = []
        for metric, quality in PAPER_PAIRS:
            if metric in paper.metrics and quality in paper.qualities and paper.pair(metric, quality).r is not None:
                pr.append((f"paper {metric}–{quality}", paper.pair(metric, quality).r))
        xp = np.arange(len(labels), len(labels) + len(pr)) + 0.5
        bx.bar(xp, [r for _, r in pr], 0.5, color="#c27c0e", label="paper Table 2 (13 data sets)")
        x = np.r_[x, xp]
        names += [n for n, _ in pr]
    bx.set_xticks(x)
    bx.set_xticklabels(names, rotation=30, ha="right", fontsize=8)
    bx.axhline(0, color="#444", lw=0.8)
    bx.set_ylim(-1, 1)
    bx.set_ylabel("Pearson r with completeness")
    bx.set_title("r on each held-out model, beside the paper's", fontsize=10)
    bx.grid(alpha=0.3, axis="y")
    bx.legend(fontsize=7, loc="lower left")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out

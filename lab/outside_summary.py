"""Summary: the shipped models on every open outside set of ``bench.outside``, per recover setting, with the
worst set and the mean beside them, from the committed ``bench/outside`` results (it runs no model):
detector recall and precision, ``recover --repair all`` RMSE change, mask F1 and clean pixels changed; as a table
(printed, Markdown) and a plot (``--plot``) with issue 13's bars.

Run:  python -m lab.outside_summary --json docs/results/outside_sets.json \
          --plot docs/results/outside_sets.png
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from bench.harness import check_output, output_args
from bench.outside.sets import open_sets
from tools.results import OUTSIDE

from d2sr.atomic import write_result
from d2sr.eval.plots import plt, save  # Agg, set there

ROOT = Path(__file__).resolve().parent.parent
# recover setting: the suffix of its bench/outside result files (``make outside``: outside/SET-SUFFIX.json).
SETTINGS = {
    "default (auto)": "auto",
    "--model unet8": "unet8",
    "--model unet16": "unet16",
    "--model unet32": "unet32",
}
FIGURES = ("detector_recall", "detector_precision", "rmse_change", "mask_f1", "clean_changed")
BARS = {"detector_recall": 0.90, "detector_precision": 0.95, "rmse_change": -0.70, "mask_f1": 0.80}


def _file(which: str, suffix: str) -> Path:
    return ROOT / OUTSIDE.format(set=which, setting=suffix)


def gather(sets: list[str]) -> dict:
    """Per setting: each set's figures, then the worst (the bar's side of each figure) and the mean."""
    out: dict = {}
    for name, suffix in SETTINGS.items():
        rows = {}
        for which in sets:
            path = _file(which, suffix)
            if not path.is_file():
                raise SystemExit(f"{path}: missing; bench/outside --set {which} writes it")
            l515 = json.loads(path.read_text())["l515"]
            rows[f"set {which}"] = {k: l515[k] for k in FIGURES}
        worst = {
            k: (max if k in ("rmse_change", "clean_changed") else min)(r[k] for r in rows.values())
            for k in FIGURES
        }
        mean = {k: round(sum(r[k] for r in rows.values()) / len(rows), 4) for k in FIGURES}
        out[name] = rows | {"worst": worst, "mean": mean}
    return out


def table(summary: dict) -> str:
    head = "| setting | | detector R | detector P | RMSE change | mask F1 | clean changed |"
    lines = [head, "|---|---|---|---|---|---|---|"]
    for name, rows in summary.items():
        for i, (where, r) in enumerate(rows.items()):
            det = f"{r['detector_recall']:.2f} | {r['detector_precision']:.2f}"
            rec = f"{100 * r['rmse_change']:.1f}% | {r['mask_f1']:.2f} | {100 * r['clean_changed']:.2f}%"
            lines.append(f"| {name if i == 0 else ''} | {where} | {det} | {rec} |")
    return "\n".join(lines)


def plot(summary: dict, path: Path) -> Path:
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    names = list(summary)
    cols = list(next(iter(summary.values())))
    width = 0.8 / len(names)
    for ax, key, label in zip(
        axes,
        ("rmse_change", "mask_f1", "detector_recall"),
        ("recover --repair all: RMSE change (%)", "mask F1", "detector recall (same for every setting)"),
        strict=True,
    ):
        scale = 100 if key == "rmse_change" else 1
        for j, name in enumerate(names):
            vals = [scale * summary[name][c][key] for c in cols]
            ax.bar(
                [i + (j - (len(names) - 1) / 2) * width for i in range(len(cols))], vals, width, label=name
            )
        ax.axhline(scale * BARS[key], color="k", ls="--", lw=1)
        ax.set_xticks(range(len(cols)), cols)
        ax.set_title(label, fontsize=10)
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_ylim(-80, 0)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="lower center", ncol=len(names), fontsize=9)
    fig.suptitle("Shipped models on interference written apart from the generator (dashed: issue 13's bar)")
    fig.subplots_adjust(bottom=0.18)
    return save(fig, path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    output_args(ap, plot="also write the plot (PNG) here")
    args = ap.parse_args()
    check_output(ap, args)
    sets = open_sets()
    summary = gather(sets)
    print(table(summary))
    if args.plot is not None:
        plot(summary, args.plot)
    sources = [OUTSIDE.format(set=w, setting=x) for w in sets for x in SETTINGS.values()]
    result = {"bars": BARS, "settings": summary, "sources": sources}
    print(write_result(result, args.json, data="every open outside set of bench/outside (see sources)"))


if __name__ == "__main__":
    main()

"""What a recording job did, for a person to look at (``report.html``): every frame d2sr flagged or whose flag
its scene dropped, with the detector's score and the reason, the pixels it repaired and the pixels with no
return it gave a depth; and, for the frames it changed most, the frame before and after, the mask and the
difference, with colour bars in metres. One self-contained file (images inline), written beside the output.
"""

from __future__ import annotations

import base64
import heapq
import html
import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from d2sr.atomic import atomic_write
from d2sr.atomic.naming import HTML_MARK
from d2sr.runtime.loop import Result

__all__ = ["ROWS", "WORST", "Report"]

WORST = 3  # frames shown as images: the most changed
ROWS = 1000  # frames listed in the table (the rest counted)


@dataclass(frozen=True)
class _Row:
    name: str
    score: float
    flagged: bool
    reason: str
    repaired: int  # pixels
    filled: int  # of them, pixels that had no return
    largest_m: float  # the largest change (m)


@dataclass
class Report:
    """Collects ``add``-ed results of one recording (each in its own units) and writes ``report.html``."""

    title: str = "d2sr"
    frames: int = 0
    flagged: int = 0
    repaired_px: int = 0
    filled_px: int = 0
    rows: list[_Row] = field(default_factory=list)
    more: int = 0  # rows past ``ROWS``
    _worst: list[tuple[int, int, str, float, np.ndarray, np.ndarray, np.ndarray]] = field(
        default_factory=list
    )

    def add(self, res: Result, label: str | None = None) -> None:
        """A result, in frame order: counted, listed if flagged or cleared, kept if among the most changed.
        ``label``: how the page names the frame (default: its name; a run of several sensors names each)."""
        name = res.capture.name if label is None else label
        self.frames += 1
        self.flagged += res.flagged
        raw, out, mask = res.capture.frame.depth, res.depth, res.mask
        metres = 1.0 if raw.dtype.kind == "f" else float(res.capture.scale)
        n = int(np.count_nonzero(mask))
        empty = ~(raw > 0) if raw.dtype.kind == "f" else raw == 0
        filled = int(np.count_nonzero(mask & empty & (out > 0)))
        self.repaired_px += n
        self.filled_px += filled
        if not (res.flagged or res.reason or n):
            return
        diff = np.abs(out[mask].astype(np.float64) - np.nan_to_num(raw[mask].astype(np.float64))) / metres
        row = _Row(name, res.score, res.flagged, res.reason, n, filled, float(diff.max(initial=0)))
        if len(self.rows) < ROWS:
            self.rows.append(row)
        else:
            self.more += 1
        full = len(self._worst) >= WORST
        if n and (not full or (n, -self.frames) > self._worst[0][:2]):  # copied only when kept
            item = (n, -self.frames, name, metres, np.array(raw), np.array(out), np.array(mask))
            (heapq.heapreplace if full else heapq.heappush)(self._worst, item)

    def html(self) -> str:
        """The report, one self-contained page."""
        e = html.escape
        head = (
            f"<p>{self.frames} frames; {self.flagged} flagged; {self.repaired_px} pixels repaired, "
            f"{self.filled_px} of them pixels with no return given a depth.</p>"
        )
        reasons = (
            "<p>reason: <b>detector</b>, its score reached the threshold; <b>scene</b>, the sensor's own "
            "scene found fresh interference; <b>detector+scene</b>, both; <b>cleared by scene</b>, the score "
            "reached the threshold but the frame matches the sensor's clean frames, so it was left as it "
            "was. A score of <b>-</b>: the scene's evidence decided alone and the detector was not run.</p>"
        )
        cells = "".join(
            f"<tr><td>{e(r.name)}</td><td>{_score(r.score)}</td><td>{int(r.flagged)}</td><td>{e(r.reason)}</td>"
            f"<td>{r.repaired}</td><td>{r.filled}</td><td>{r.largest_m:.3f}</td></tr>"
            for r in self.rows
        )
        more = f"<p>and {self.more} more frames, not listed.</p>" if self.more else ""
        table = (
            "<table><tr><th>frame</th><th>score</th><th>flagged</th><th>reason</th><th>pixels repaired</th>"
            f"<th>no return given a depth</th><th>largest change (m)</th></tr>{cells}</table>{more}"
        )
        shown = sorted(self._worst, key=lambda w: (w[0], w[1]), reverse=True)  # most changed first
        figures = "".join(
            f"<h3>{e(name)}: {n} pixels repaired</h3><img alt='{e(name)}' src='data:image/png;base64,"
            f"{self._figure(raw, out, mask, per_m)}'>"
            for n, _, name, per_m, raw, out, mask in shown
        )
        style = "body{font-family:sans-serif;margin:2em}td,th{border:1px solid #ccc;padding:2px 6px}"
        return (
            f"<!doctype html><html><head>{HTML_MARK.decode()}<meta charset='utf-8'>"
            f"<title>{e(self.title)}</title>"
            f"<style>{style}</style></head><body><h1>{e(self.title)}</h1>{head}{reasons}"
            f"<h2>Frames flagged or cleared</h2>{table}"
            f"<h2>The frames changed most</h2>{figures or '<p>none</p>'}"
            "</body></html>\n"
        )

    def write(self, path: Path) -> None:
        atomic_write(path, self.html())

    def _figure(self, raw: np.ndarray, out: np.ndarray, mask: np.ndarray, per_m: float) -> str:
        """Before, after, mask and difference, colour bars in metres: a PNG, base64."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        before = np.nan_to_num(raw.astype(np.float32)) / per_m
        after = np.nan_to_num(out.astype(np.float32)) / per_m
        valid = before[before > 0]
        lo, hi = np.percentile(valid, [2, 98]) if valid.size else (0.0, 1.0)
        diff = np.where(mask, after - before, 0)
        reach = float(max(np.abs(diff).max(), 1e-3))
        fig, axes = plt.subplots(1, 4, figsize=(16, 3.4))
        panels = (
            (before, "before (m)", "viridis", lo, hi),
            (after, "after (m)", "viridis", lo, hi),
            (mask.astype(np.float32), "repaired pixels", "gray", 0, 1),
            (diff, "after - before (m)", "coolwarm", -reach, reach),
        )
        for ax, (img, title, cmap, vmin, vmax) in zip(axes, panels, strict=True):
            shown = np.ma.masked_where((img == 0) & (title != "repaired pixels"), img)
            im = ax.imshow(shown, cmap=cmap, vmin=vmin, vmax=vmax)
            ax.set_title(title)
            ax.axis("off")
            if title != "repaired pixels":
                fig.colorbar(im, ax=ax, fraction=0.046, pad=0.02)
        fig.tight_layout()
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=72, metadata={"Software": "d2sr"})
        plt.close(fig)
        return base64.b64encode(buf.getvalue()).decode("ascii")


def _score(score: float) -> str:
    """The detector's score as the table shows it; "-" where it was not run (NaN)."""
    return "-" if np.isnan(score) else f"{score:.3f}"

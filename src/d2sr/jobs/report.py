"""What a recording job did, for a person to look at (``report.html``): every frame d2sr flagged or whose flag
its scene dropped, with the detector's score and the reason, the returns it moved and the pixels with no
return it gave a depth; and, for the frames it changed most, the frame before and after, the mask, and the
two kinds of change apart, each with its own colour bar in metres (a centimetre's correction stays visible
beside a depth invented for an empty pixel); a recording where nothing changed says so and shows one frame.
One self-contained file (images inline), written beside the output.
"""

from __future__ import annotations

import base64
import heapq
import html
from dataclasses import dataclass, field
from pathlib import Path

import cv2
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
    largest_m: float  # the largest change of a return (m)


@dataclass
class Report:
    """Collects ``add``-ed results of one recording (each in its own units) and writes ``report.html``."""

    title: str = "d2sr"
    frames: int = 0
    flagged: int = 0
    repaired_px: int = 0
    filled_px: int = 0
    alone: int = 0  # frames the scene decided without the detector (score NaN)
    rows: list[_Row] = field(default_factory=list)
    more: int = 0  # rows past ``ROWS``
    _worst: list[tuple[int, int, str, float, np.ndarray, np.ndarray, np.ndarray]] = field(
        default_factory=list
    )
    _first: tuple[str, float, np.ndarray] | None = None  # a frame to show when nothing changed

    def add(self, res: Result, label: str | None = None) -> None:
        """A result, in frame order: counted, listed if flagged or cleared, kept if among the most changed.
        ``label``: how the page names the frame (default: its name; a run of several sensors names each)."""
        name = res.capture.name if label is None else label
        self.frames += 1
        self.flagged += res.flagged
        self.alone += bool(np.isnan(res.score)) and res.scene is True
        raw, out, mask = res.capture.frame.depth, res.depth, res.mask
        metres = 1.0 if raw.dtype.kind == "f" else float(res.capture.scale)
        if self._first is None:
            self._first = (name, metres, np.array(raw))
        n = int(np.count_nonzero(mask))
        empty = _empty(raw)
        filled = int(np.count_nonzero(mask & empty & (out > 0)))
        self.repaired_px += n
        self.filled_px += filled
        if not (res.flagged or res.reason or n):
            return
        moved = mask & ~empty
        diff = np.abs(out[moved].astype(np.float64) - raw[moved].astype(np.float64)) / metres
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
        e = _text
        moved = self.repaired_px - self.filled_px
        head = (
            f"<p>{self.frames} frames; {self.flagged} flagged; {self.repaired_px} pixels repaired: {moved} "
            f"returns moved and {self.filled_px} pixels with no return given a depth.</p>"
        )
        alone = (
            f"<p>{self.alone} frames were judged by the sensor's own scene alone, without the detector "
            "(score <b>-</b>): a frame the detector would have flagged and the scene cleared is not listed "
            "as cleared here (<code>d2sr detect</code> scores every frame and lists those).</p>"
            if self.alone
            else ""
        )
        reasons = (
            "<p>reason: <b>detector</b>, its score reached the threshold; <b>scene</b>, the sensor's own "
            "scene found fresh interference; <b>detector+scene</b>, both; <b>cleared by scene</b>, the score "
            "reached the threshold but the frame matches the sensor's clean frames, so it was left as it "
            "was. A score of <b>-</b>: the scene's evidence decided alone and the detector was not run.</p>"
        )
        shown = sorted(self._worst, key=lambda w: (w[0], w[1]), reverse=True)  # most changed first
        if not self.rows and not shown:
            body = (
                "<h2>Nothing changed</h2><p>No frame was flagged and every frame came out exactly as it went "
                "in. One of them, as the sensor delivered it:</p>"
            )
            if self._first is not None:
                name, per_m, raw = self._first
                body += f"<h3>{e(name)}</h3>{_panels(raw, raw, np.zeros(raw.shape, bool), per_m, alone=True)}"
        else:
            cells = "".join(
                f"<tr><td>{e(r.name)}</td><td>{_score(r.score)}</td><td>{int(r.flagged)}</td>"
                f"<td>{e(r.reason)}</td><td>{r.repaired - r.filled}</td><td>{r.filled}</td>"
                f"<td>{r.largest_m:.3f}</td></tr>"
                for r in self.rows
            )
            more = f"<p>and {self.more} more frames, not listed.</p>" if self.more else ""
            table = (
                "<table><tr><th>frame</th><th>score</th><th>flagged</th><th>reason</th><th>returns moved</th>"
                "<th>no return given a depth</th><th>largest move of a return (m)</th></tr>"
                f"{cells}</table>{more}"
            )
            figures = "".join(
                f"<h3>{e(name)}: {n} pixels repaired</h3>{_panels(raw, out, mask, per_m)}"
                for n, _, name, per_m, raw, out, mask in shown
            )
            body = (
                f"<h2>Frames flagged or cleared</h2>{table}"
                f"<h2>The frames changed most</h2>{figures or '<p>none: no pixel was repaired</p>'}"
            )
        style = (
            "body{font-family:sans-serif;margin:2em}td,th{border:1px solid #ccc;padding:2px 6px}"
            ".row{display:flex;flex-wrap:wrap;gap:12px}figure{margin:0}figcaption{font-size:90%}"
            "figure>img{width:300px}.bar img{width:200px;height:10px}"
            ".bar{display:flex;align-items:center;gap:4px;font-size:80%}"
        )
        return (
            f"<!doctype html><html><head>{HTML_MARK.decode()}<meta charset='utf-8'>"
            f"<title>{e(self.title)}</title>"
            f"<style>{style}</style></head><body><h1>{e(self.title)}</h1>{head}{alone}{reasons}{body}"
            "</body></html>\n"
        )

    def write(self, path: Path) -> None:
        atomic_write(path, self.html())


def _text(name: str) -> str:
    """A name as HTML text in a page declared UTF-8: escaped, and bytes that are not UTF-8 (a file name
    read with surrogateescape) shown as escapes rather than written raw."""
    return html.escape(name.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace"))


def _empty(depth: np.ndarray) -> np.ndarray:
    """Pixels with no return (0, or NaN in metres)."""
    out: np.ndarray = ~(depth > 0) if depth.dtype.kind == "f" else depth == 0
    return out


def _panels(raw: np.ndarray, out: np.ndarray, mask: np.ndarray, per_m: float, alone: bool = False) -> str:
    """Before, after, the repaired pixels, then apart, each on its own scale: how far the repair moved the
    returns (after - before), and the depth it gave pixels that had none. Images drawn with OpenCV (a few
    milliseconds each), colour bars in metres under them."""
    before = np.nan_to_num(raw.astype(np.float32)) / np.float32(per_m)
    after = np.nan_to_num(out.astype(np.float32)) / np.float32(per_m)
    valid = before[before > 0]
    lo, hi = (float(v) for v in np.percentile(valid, [2, 98])) if valid.size else (0.0, 1.0)
    hi = max(hi, lo + 1e-3)
    if alone:
        return f"<div class='row'>{_panel(before, before > 0, VIRIDIS, lo, hi, 'depth (m)')}</div>"
    empty = _empty(raw)
    moved, filled = mask & ~empty, mask & empty & (after > 0)
    parts = [
        _panel(before, before > 0, VIRIDIS, lo, hi, "before (m)"),
        _panel(after, after > 0, VIRIDIS, lo, hi, "after (m)"),
        _panel(
            mask.astype(np.float32), np.ones(mask.shape, bool), GREY, 0.0, 1.0, "repaired pixels", bar=False
        ),
    ]
    if moved.any():
        diff = np.where(moved, after - before, 0)
        reach = float(max(np.abs(diff).max(), 1e-3))
        parts.append(
            _panel(
                diff,
                moved,
                COOLWARM,
                -reach,
                reach,
                f"returns moved: after - before (m), {int(moved.sum())} px",
            )
        )
    if filled.any():
        f_lo, f_hi = (float(v) for v in np.percentile(after[filled], [0, 100]))
        parts.append(
            _panel(after, filled, VIRIDIS, f_lo, max(f_hi, f_lo + 1e-3),
                   f"no return given a depth (m), {int(filled.sum())} px")
        )  # fmt: skip
    return f"<div class='row'>{''.join(parts)}</div>"


def _lut(stops: list[tuple[float, float, float]]) -> np.ndarray:
    """A 256-entry BGR colour table through ``stops`` (RGB, 0-255), evenly spaced."""
    at = np.linspace(0, 1, len(stops))
    x = np.linspace(0, 1, 256)
    rgb = np.stack([np.interp(x, at, [s[c] for s in stops]) for c in range(3)], axis=1)
    out: np.ndarray = np.rint(rgb[:, ::-1]).astype(np.uint8)
    return out


VIRIDIS = _lut([(68, 1, 84), (59, 82, 139), (33, 145, 140), (94, 201, 98), (253, 231, 37)])
COOLWARM = _lut([(59, 76, 192), (221, 221, 221), (180, 4, 38)])
GREY = _lut([(0, 0, 0), (255, 255, 255)])
NODATA = (235, 235, 235)  # BGR: pixels a panel has nothing for


def _png(bgr: np.ndarray) -> str:
    ok, buf = cv2.imencode(".png", bgr)
    if not ok:  # an image of our own making: cannot happen
        raise RuntimeError("PNG encoding failed")
    return base64.b64encode(buf.tobytes()).decode("ascii")


def _panel(
    img: np.ndarray, shown: np.ndarray, lut: np.ndarray, lo: float, hi: float, title: str, bar: bool = True
) -> str:
    """One image (``img`` where ``shown``, on ``lut`` from ``lo`` to ``hi``) with its title and colour bar."""
    idx = np.clip((img - lo) / (hi - lo) * 255, 0, 255)
    bgr = lut[np.nan_to_num(idx).astype(np.uint8)]
    bgr[~shown] = NODATA
    e = html.escape
    figure = f"<img alt='{e(title)}' src='data:image/png;base64,{_png(bgr)}'>"
    if bar:
        strip = np.repeat(lut[None], 12, axis=0)
        figure += (
            f"<div class='bar'>{lo:.3f}<img alt='colour bar' src='data:image/png;base64,{_png(strip)}'>"
            f"{hi:.3f}</div>"
        )
    return f"<figure>{figure}<figcaption>{e(title)}</figcaption></figure>"


def _score(score: float) -> str:
    """The detector's score as the table shows it; "-" where it was not run (NaN)."""
    return "-" if np.isnan(score) else f"{score:.3f}"

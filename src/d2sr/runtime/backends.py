"""The inference protocol the runtime runs on; its torch-free implementation, ``OnnxBackend``
(``pip install '.[edge]'``); ``Gated`` (``--model auto``); and ``open_backend``, which opens the shipped
or a given folder's models on onnxruntime or on ``d2sr.models.inference.TorchBackend`` (found by name).
Both work in metres (``d2sr.contract.catalog``)."""

from __future__ import annotations

import importlib.util
import os
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, Protocol, TypeVar

import numpy as np

from d2sr.contract.catalog import (
    ALONE,
    AUTO_RECOVERY,
    AUTO_TEMPORAL_LOGIT,
    CATALOG,
    DEFAULT_RECOVERY,
    DETECTOR,
    PAIR_INPUTS,
    SHIPPED_RECOVERY,
    STREAM_INPUTS,
    TEMPORAL_RECOVERY,
    THRESHOLD,
    WEIGHTS,
    check_size,
    code_path,
    detector_input,
    gate,
    model_input,
    pair_path,
)
from d2sr.contract.repair import LINES_UP, REPAIR_PASSES, agreement, check_passes, recover_passes
from d2sr.errors import ConfigError, InputError
from d2sr.runtime.settings import BACKENDS, RunSettings

__all__ = ["BACKENDS", "Backend", "Gated", "OnnxBackend", "open_backend"]


class Backend(Protocol):
    name: str
    threshold: float  # the detector's own probability threshold (stored with it; contract.THRESHOLD)
    passes: int  # recovery runs of the model per frame (contract.recover_passes)

    @property
    def mask_logit(self) -> float:
        """The recovery mask's threshold on its logits (0 without a recovery model)."""
        ...

    def scores(
        self, metres: np.ndarray, previous: np.ndarray | None = None, cut: float | None = None
    ) -> np.ndarray:
        """(N, H, W) float32 metres -> (N,) probability that each frame is interfered. ``previous``: the
        sensor's frame before each (N, H, W), which a temporal detector also weighs (others ignore it).
        ``cut``: the threshold the scores will be held to; a temporal detector then weighs the previous
        frame only for the frames that reach it alone, and the others' scores are upper bounds below it
        (``contract.gate``). None: every score exact."""
        ...

    @property
    def frames(self) -> int:
        """2: a temporal recovery model, which also takes the last clean frame; else 1."""
        ...

    def raw(self, metres: np.ndarray, previous: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """One run of the recovery model: (mask logits, predicted depth in metres), both (N, H, W)."""
        ...

    def recover(
        self, metres: np.ndarray, previous: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(N, H, W) float32 metres -> (predicted depth in metres, predicted mask bool), both (N, H, W).
        ``previous``: each frame's last clean frame (N, H, W), for temporal models (others ignore it).
        The model runs up to ``passes`` times (``d2sr.contract.recover_passes``)."""
        ...


@dataclass
class _Props:
    """What an exported model says about itself (``d2sr.models.onnx.export`` writes it as ONNX metadata)."""

    stride: int
    height: int | None
    frames: int
    mask_logit: float
    threshold: float
    code_stride: int  # a streaming two-frame model's (d2sr.models.streaming); 0 for the others


def _loaded(session: Any, what: str) -> Any:
    if session is None:
        raise InputError(f"no {what} loaded")
    return session


Code = TypeVar("Code")


class _Codes(Generic[Code]):
    """The frames a streaming model encoded last and their codes, looked up by value for the frames that
    follow (a stream's previous frame; its last clean one). Shared by the threads that repair at once."""

    def __init__(self, size: int = 2) -> None:
        self._items: list[tuple[np.ndarray, Code]] = []
        self._lock = threading.Lock()
        self._size = size

    def get(self, frame: np.ndarray, make: Callable[[np.ndarray], Code]) -> Code:
        with self._lock:
            for f, code in self._items:
                if f.shape == frame.shape and np.array_equal(f, frame):
                    return code
        code = make(frame)
        self.put(frame, code)
        return code

    def put(self, frame: np.ndarray, code: Code) -> None:
        with self._lock:
            self._items = [(frame.copy(), code), *self._items[: self._size - 1]]


class OnnxBackend:
    """onnxruntime sessions on exported models (``d2sr export``)."""

    name = "onnxruntime"

    def __init__(
        self,
        detector: Path | None,
        recovery: Path | None,
        threads: int | None = None,
        mask_logit: float | None = None,
        passes: int = REPAIR_PASSES,
        encoder: Path | None = None,
        pair: Path | None = None,
    ) -> None:
        """``threads``: onnxruntime's intra-op threads per session (default: the recovery model on up to 4
        cores, the detector on one: a second thread cut its wall time on a 640x480 frame by a third but
        raised its CPU time, docs/models.md). ``encoder``: a streaming temporal UNet's encoder file
        (default: ``contract.code_path`` of ``recovery``); ``pair``: a streaming temporal detector's pair
        file (default: ``contract.pair_path`` of ``detector``)."""
        self.passes = check_passes(passes)
        try:
            import onnxruntime as ort
        except ImportError:  # pragma: no cover - depends on the install
            raise InputError("onnxruntime is not installed: pip install '.[edge]'") from None

        def session(path: Path, cores: int = threads or min(os.cpu_count() or 1, 4)) -> ort.InferenceSession:
            opts = ort.SessionOptions()
            opts.intra_op_num_threads = cores
            opts.inter_op_num_threads = 1
            opts.log_severity_level = 3
            # Two sessions (detector, recovery) alternate on the same cores: idle threads that spin-wait for
            # work would steal the other session's time.
            opts.add_session_config_entry("session.intra_op.allow_spinning", "0")
            if not Path(path).is_file():
                raise InputError(f"{path}: no such model file (d2sr export writes it)")
            try:
                return ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
            except Exception as exc:  # onnxruntime raises its own untyped errors on corrupt files
                raise InputError(f"{path}: corrupt ONNX model ({str(exc).splitlines()[0][:120]})") from None

        self.det = session(detector, threads or 1) if detector is not None else None
        self.pair = None
        self.rec = session(recovery) if recovery is not None else None
        self._meta = {
            k: self._props(s) for k, s in (("detector", self.det), ("recovery", self.rec)) if s is not None
        }
        for kind, path, s in (("detector", detector, self.det), ("recovery", recovery, self.rec)):
            if s is None or self._meta[kind].frames == 1:
                continue
            alone = kind != "detector" or ALONE.items() <= s.get_modelmeta().custom_metadata_map.items()
            if tuple(i.name for i in s.get_inputs()) != STREAM_INPUTS[kind] or not alone:
                raise InputError(f"{path}: a two-frame model exported by an earlier d2sr; export it again")
        if detector is not None and self._meta["detector"].frames == 2:
            second = pair or pair_path(Path(detector))
            self.pair = session(second, threads or 1)
            if tuple(i.name for i in self.pair.get_inputs()) != PAIR_INPUTS:
                raise InputError(f"{second}: not a detector's pair file; export it again")
        self.enc = None
        if recovery is not None and self._meta["recovery"].code_stride:
            self.enc = session(encoder or code_path(Path(recovery)))
        self._rec_codes: _Codes[tuple[np.ndarray, np.ndarray]] = _Codes()
        if mask_logit is not None and "recovery" in self._meta:  # the caller's own trade-off
            self._meta["recovery"].mask_logit = mask_logit
        self.threshold = self._meta["detector"].threshold if "detector" in self._meta else THRESHOLD

    @staticmethod
    def _props(s: Any) -> _Props:
        meta = s.get_modelmeta().custom_metadata_map  # what d2sr export wrote into the file
        return _Props(
            stride=int(meta.get("stride", 1)),
            height=int(meta["height"]) if meta.get("height") else None,
            frames=int(meta.get("frames", 1)),
            mask_logit=float(meta.get("mask_logit", 0.0)),
            threshold=float(meta.get("threshold", THRESHOLD)),
            code_stride=int(meta.get("code_stride", 0)),
        )

    @property
    def frames(self) -> int:
        return self._meta["recovery"].frames if "recovery" in self._meta else 1

    def detector_feeds(self, metres: np.ndarray, previous: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """The detector file's inputs for (N, H, W) metres (a temporal detector's first file scores the frame
        alone: ``previous`` is for its pair file, ``scores``)."""
        _loaded(self.det, "detector")
        h, w = metres.shape[1:]
        p = self._meta["detector"]
        check_size(h, w, p.stride, p.height, "the detector")
        if self.pair is not None:
            return {"depth": metres[:, None].astype(np.float32, copy=False)}
        return {"depth": detector_input(metres, previous, p.frames)}

    def scores(
        self, metres: np.ndarray, previous: np.ndarray | None = None, cut: float | None = None
    ) -> np.ndarray:
        feeds = self.detector_feeds(metres, previous)
        alone: np.ndarray = _loaded(self.det, "detector").run(None, feeds)[0]
        if self.pair is None or previous is None:  # one file; or no earlier frame: the frame alone is exact
            return alone
        if previous.shape != metres.shape:
            raise InputError(f"the earlier frame is {previous.shape}, the frame {metres.shape}")
        pair, depth, before = self.pair, feeds["depth"], previous[:, None].astype(np.float32, copy=False)

        def paired(rows: np.ndarray) -> np.ndarray:
            out: np.ndarray = pair.run(None, {"depth": depth[rows], "previous": before[rows]})[0]
            return out

        return gate(alone, cut, paired)

    def recovery_feeds(self, metres: np.ndarray, previous: np.ndarray | None) -> dict[str, np.ndarray]:
        """The recovery model's inputs; a streaming one's code of the last clean frame (zeros when there is
        none) comes from the cache or its encoder."""
        _loaded(self.rec, "recovery model")
        h, w = metres.shape[1:]
        p = self._meta["recovery"]
        check_size(h, w, p.stride, p.height, "the recovery model")
        if self.enc is None:
            return {"depth": model_input(metres, previous, self.frames)}
        # Streaming: the frames as two inputs, never stacked into one full-resolution copy per pass.
        if previous is None:
            previous = np.zeros_like(metres)  # no last clean frame reads as 0
        elif previous.shape != metres.shape:
            raise InputError(f"the earlier frame is {previous.shape}, the frame {metres.shape}")
        last = previous.astype(np.float32, copy=False)
        enc = self.enc

        def encode(frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            code, head = enc.run(None, {"previous": frame[:, None]})
            return code, head

        code, head = self._rec_codes.get(last, encode)
        depth = metres[:, None].astype(np.float32, copy=False)
        return {"depth": depth, "previous": last[:, None], "code": code, "head_code": head}

    def raw(self, metres: np.ndarray, previous: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(mask logits, predicted depth), before any threshold."""
        feeds = self.recovery_feeds(metres, previous)
        logit, pred = _loaded(self.rec, "recovery model").run(None, feeds)
        return logit[:, 0], pred[:, 0]

    @property
    def mask_logit(self) -> float:
        return self._meta["recovery"].mask_logit if "recovery" in self._meta else 0.0

    def recover(
        self, metres: np.ndarray, previous: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        return recover_passes(self.raw, metres, previous, self.mask_logit, self.passes)


class Gated:
    """``--model auto``: a temporal recovery model for each frame whose last clean frame lines up with it (a
    sensor that held still: ``contract.agreement`` >= ``LINES_UP``), a single-frame one for the others.
    ``single`` also holds the detector; both are open backends of the same kind."""

    frames = 2  # the loop keeps the last clean frame for it

    def __init__(self, single: Backend, temporal: Backend) -> None:
        if single.frames != 1 or temporal.frames != 2:
            raise InputError("auto needs a single-frame and a temporal recovery model")
        self.single, self.temporal = single, temporal
        self.name, self.threshold, self.passes = single.name, single.threshold, single.passes

    def scores(
        self, metres: np.ndarray, previous: np.ndarray | None = None, cut: float | None = None
    ) -> np.ndarray:
        return self.single.scores(metres, previous, cut)

    def _each(
        self, run: str, metres: np.ndarray, previous: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``run`` ("raw" or "recover") of the model each frame gets, stacked."""
        outs = []
        for i in range(len(metres)):
            x, net, prev = metres[i : i + 1], self.single, None
            if previous is not None and agreement(x[0], previous[i]) >= LINES_UP:  # the sensor held still
                net, prev = self.temporal, previous[i : i + 1]
            outs.append(getattr(net, run)(x, prev))
        return np.concatenate([a for a, _ in outs]), np.concatenate([b for _, b in outs])

    @property
    def mask_logit(self) -> float:
        return self.single.mask_logit

    def raw(self, metres: np.ndarray, previous: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        return self._each("raw", metres, previous)

    def recover(
        self, metres: np.ndarray, previous: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        return self._each("recover", metres, previous)


# Opening models: onnxruntime where it is installed and the ONNX files exist, torch otherwise (imported only
# then, so the edge install never loads it).


# The torch backend lives with the torch models, a layer above the runtime: the runtime finds it by name,
# and only when torch is asked for, so the edge runtime never depends on it (docs/architecture.md).
TORCH_BACKEND = "d2sr.models.inference"


def _has(weights: Path, name: str) -> bool:
    """The folder holds model ``name`` (ONNX or safetensors)."""
    return any((weights / f"{name}{e}").is_file() for e in (".onnx", ".safetensors"))


def open_backend(
    settings: RunSettings | None = None, *, detector: bool = True, recovery: bool = True
) -> Backend:
    """The detector (``detector``) and the recovery model (``recovery``) that ``settings`` name, from its
    ``models`` folder [the shipped ones], on its ``backend``, with its ``threads``, ``int8``, ``mask_logit``
    (overrides the model's own mask threshold, a logit) and ``passes`` (runs of the recovery model per frame,
    ``contract.recover_passes``). ``model="auto"``: ``unet8-temporal`` where the last clean frame lines up,
    at auto's own mask logit (``AUTO_TEMPORAL_LOGIT``, unless ``mask_logit`` is given), ``unet8`` elsewhere
    (``Gated``); ``unet8`` alone in a folder without ``unet8-temporal`` (d2sr adapt's)."""
    s = settings if settings is not None else RunSettings()
    if s.model == AUTO_RECOVERY and recovery:
        single = open_backend(s.model_copy(update={"model": DEFAULT_RECOVERY}), detector=detector)
        if not _has(s.models, TEMPORAL_RECOVERY):
            return single
        own = AUTO_TEMPORAL_LOGIT if s.mask_logit is None else s.mask_logit
        pair = s.model_copy(update={"model": TEMPORAL_RECOVERY, "mask_logit": own})
        return Gated(single, open_backend(pair, detector=False))
    det = DETECTOR if detector else None
    model = s.model if recovery else None
    return _open(det, model, s)


def _open(detector: str | None, model: str | None, s: RunSettings) -> Backend:
    """The models named (None: not that one) of ``s.models``, on ``s.backend``."""
    backend, weights, int8, mask_logit = s.backend, s.models, s.int8, s.mask_logit
    own = CATALOG[model].passes if model in CATALOG else REPAIR_PASSES
    passes = s.passes if s.passes is not None else own
    if not weights.is_dir():
        raise InputError(f"{weights}: no such models folder")
    names = ([detector] if detector else []) + ([model] if model else [])
    if not names:
        raise ConfigError("open_backend needs a detector, a recovery model or both")
    for name in names:
        if not _has(weights, name):
            hint = f" (shipped: {', '.join(SHIPPED_RECOVERY)}; `make weights` trains the others)"
            raise InputError(f"no such model {name} in {weights}" + (hint if weights == WEIGHTS else ""))
    ext = ".int8.onnx" if int8 else ".onnx"  # int8: d2sr export --int8
    det_onnx = weights / f"{detector}{ext}" if detector else None
    rec_onnx = weights / f"{model}{ext}" if model else None
    onnx_files = [f for f in (det_onnx, rec_onnx) if f is not None]
    if int8 and backend == "torch":
        raise ConfigError("int8 models run on onnxruntime (backend onnx)", "int8")
    if int8:
        backend = "onnx"
    if backend == "auto":
        has_ort = importlib.util.find_spec("onnxruntime") is not None
        backend = "onnx" if has_ort and all(f.is_file() for f in onnx_files) else "torch"
    if backend == "onnx":
        return OnnxBackend(det_onnx, rec_onnx, s.threads, mask_logit, passes)
    if importlib.util.find_spec("torch") is None:
        raise InputError(f"no ONNX models in {weights} and torch is not installed")
    torch_backend = importlib.import_module(TORCH_BACKEND).TorchBackend
    rec = weights / f"{model}.safetensors" if model else None
    det = weights / f"{detector}.safetensors" if detector else None
    backend_: Backend = torch_backend(det, rec, mask_logit, passes)
    return backend_

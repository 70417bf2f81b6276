"""The ``d2sr`` command line (typer): one module per command group, each parsing its options and making
one call into the pipeline below it. Every D2SRError becomes one line on stderr and exit code 2."""

from __future__ import annotations

import contextlib
import os
import re
import signal
import sys
from collections.abc import Callable
from typing import Annotated, NoReturn

import typer

from d2sr.cli import (
    bench,
    data,
    desync,
    evaluate,
    fill,
    fleet,
    ros2,
    run,
    scenes,
    show,
    stages,
    train,
    trigger,
)
from d2sr.errors import D2SRError
from d2sr.ui import console, flush_warnings
from d2sr.version import __version__

__all__ = ["app", "main"]

app = typer.Typer(help="d2sr: keep depth sensors working when several share a room.", no_args_is_help=True)
desync_app = typer.Typer(
    help="Stage 2: decentralized de-synchronization experiments.\n\n"
    "Example: d2sr desync run --sensors 3 --active-frames 6 --out desync/",
    no_args_is_help=True,
)
eval_app = typer.Typer(
    help="Evaluations that write JSON and plots.\n\n"
    "Example: d2sr eval detector --real ../shared/data/l515 --out eval/detector",
    no_args_is_help=True,
)
trigger_app = typer.Typer(
    help="Stage 2's trigger lines: check a board, get its firmware.\n\n"
    "Example: d2sr trigger check serial:/dev/ttyACM0",
    no_args_is_help=True,
)
app.add_typer(desync_app, name="desync", rich_help_panel="Research: data, training, evaluations, benchmarks")
app.add_typer(eval_app, name="eval", rich_help_panel="Research: data, training, evaluations, benchmarks")
app.add_typer(trigger_app, name="trigger")
scene_app = typer.Typer(
    help="A still sensor's scene, learned once from a clean recording.\n\n"
    "Example: d2sr scene learn clean_room/ --depth-scale 4000 --out room.npz",
    no_args_is_help=True,
)
app.add_typer(scene_app, name="scene")
COMMANDS: dict[str, Callable[..., None]] = {
    "detect": stages.detect,
    "recover": stages.recover,
    "fleet": fleet.fleet,
    "fill": fill.fill,
    "run": run.run,
    "ros2": ros2.ros2,
    "demo": show.demo,
    "view": show.view,
    "simulate": data.simulate,
    "label": data.label,
    "calibrate": data.calibrate,
    "gallery": show.gallery,
    "train": train.train,
    "threshold": train.threshold,
    "export": train.export,
    "adapt": train.adapt,
    "bench": bench.bench,
}
DESYNC: dict[str, Callable[..., None]] = {
    "run": desync.run,
    "sweep": desync.sweep,
    "report": desync.report,
    "grid": desync.grid,
}
EVAL: dict[str, Callable[..., None]] = {
    "detector": evaluate.detector,
    "recovery": evaluate.recovery,
    "paper": evaluate.paper,
    "labels": evaluate.labels,
    "generalization": evaluate.generalization,
}
TRIGGER: dict[str, Callable[..., None]] = {"check": trigger.check, "firmware": trigger.firmware}
SCENE: dict[str, Callable[..., None]] = {"learn": scenes.learn}
GROUPS = ((app, COMMANDS), (desync_app, DESYNC), (eval_app, EVAL), (trigger_app, TRIGGER), (scene_app, SCENE))


def _first_sentence(fn: Callable[..., None]) -> str:
    """A command's line in its group's help: its docstring's first sentence, on one line."""
    para = " ".join((fn.__doc__ or "").strip().split("\n\n")[0].split())
    end = re.search(r"(?<!\.)\.\s(?=[A-Z])", para)  # not "OFFSET .. OFFSET+N-1"
    return para if end is None else para[: end.start() + 1]


#: The top-level help shows what users run apart from what builds and measures d2sr itself.
RESEARCH = "Research: data, training, evaluations, benchmarks"
RESEARCH_COMMANDS = {"simulate", "label", "calibrate", "gallery", "train", "threshold", "export", "bench"}
for group, commands in GROUPS:
    for name, fn in commands.items():
        panel = RESEARCH if group is app and name in RESEARCH_COMMANDS else None
        group.command(name, rich_help_panel=panel, short_help=_first_sentence(fn))(fn)


def _version(value: bool) -> None:
    if value:
        console.print(f"d2sr {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option(
            "--version", callback=_version, is_eager=True, metavar="", help="Print the version and exit."
        ),
    ] = False,
) -> None:
    """d2sr: decentralized detection, de-synchronization and recovery of depth-sensor interference."""


# Optional dependencies and the extra that brings each: an edge install (no torch) runs detect, recover, run
# and demo; training, export and evaluation need the train extra.
EXTRAS = {
    "torch": "train",
    "onnx": "train",
    "onnxscript": "train",
    "safetensors": "edge",
    "onnxruntime": "edge",
    "pyrealsense2": "realsense",
    "rerun": "viewer",
    "ray": "fleet",
}


def main() -> None:
    """Console entry point: one-line errors with exit code 2 instead of tracebacks (``D2SR_TRACEBACK=1``
    shows the traceback of an error d2sr did not foresee)."""
    with contextlib.suppress(ValueError):  # SIGTERM unwinds like Ctrl-C: temporaries go, commits finish
        signal.signal(signal.SIGTERM, _terminated)
    code: object = None
    try:
        code = app(standalone_mode=False)
    except typer.TyperException as exc:  # click's usage errors (typer vendors click): one line too
        ctx = getattr(exc, "ctx", None)
        if type(exc).__name__ == "NoArgsIsHelpError" and ctx is not None:  # `d2sr` or a group alone
            print(ctx.get_help())
            raise SystemExit(2) from None
        _fail(f"{exc.format_message()} (see {ctx.command_path if ctx else 'd2sr'} --help)")
    except typer.Abort:
        _fail("aborted")
    except D2SRError as exc:
        _fail(_with_flag(exc))
    except ModuleNotFoundError as exc:
        top = (exc.name or "").split(".")[0]
        if top not in EXTRAS:
            _unforeseen(exc)
        extra = EXTRAS[top]
        _fail(f"this command needs {top}, not installed: pip install '.[{extra}]' in a d2sr clone")
    except KeyboardInterrupt:
        _interrupted()
    except OSError as exc:  # the system refused (no permission, a full disk, a device gone)
        where = f"{exc.filename}: " if exc.filename else ""
        _fail(f"{where}{exc.strerror or type(exc).__name__}")
    except Exception as exc:
        _unforeseen(exc)
    finally:  # a command that ended well (or by typer's own usage error) shows what waited
        flush_warnings(show=code != 130)
    if code == 130:  # typer turns Ctrl-C (and SIGTERM, raised as one) inside a command into Exit(130)
        _interrupted()
    if isinstance(code, int) and code:  # typer.Exit(code), outside standalone mode, comes back as a value
        raise SystemExit(code)


def _interrupted() -> NoReturn:
    flush_warnings(show=False)
    print("d2sr: interrupted; nothing half-written was left at the output", file=sys.stderr)
    raise SystemExit(130) from None


def _terminated(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


# A run's setting and the flag that sets it, where the flag is not its name with dashes.
_FLAG = {"scene": "--scene/--no-scene", "fill": "--fill"}
_NO_FLAG = {"settings", "scene_settings"}
# The outputs the library names first in its refusals (``atomic.check_out``'s ``name``): their flags.
_OUTPUTS = re.compile(r"^(out|json|rerun|save)\b")


def _with_flag(exc: D2SRError) -> str:
    """The library's error as the command line says it: a setting it names (``max_range``) becomes the flag
    that sets it (``--max-range``), and the setting at fault gets its flag if the message does not name it.
    A settings field is named as its flag (with dashes), except those in ``_FLAG``."""
    from d2sr.runtime.settings import LoopSettings, RunSettings

    names = sorted(
        {n for n in (*RunSettings.model_fields, *LoopSettings.model_fields) if "_" in n} - _NO_FLAG
    )
    # A settings object's own one line ("RunSettings: repair: unknown ...") names its flag, not itself.
    text = re.sub(r"^\w+Settings: (\w+): ", lambda m: f"{_flag(m.group(1))}: ", str(exc))
    text = re.sub(r"\b(" + "|".join(names) + r")\b", lambda m: _flag(m.group(1)), text)
    text = _OUTPUTS.sub(lambda m: _flag(m.group(1)), text)
    name = exc.setting
    if name is None or name in _NO_FLAG or not name.isidentifier() or _flag(name) in text:
        return text
    return f"{text} (set by {_flag(name)})"


def _flag(name: str) -> str:
    return _FLAG.get(name, "--" + name.replace("_", "-"))


def _fail(line: str) -> NoReturn:
    flush_warnings(show=False)
    print(f"d2sr: error: {' '.join(line.split())}", file=sys.stderr)
    raise SystemExit(2) from None


def _unforeseen(exc: BaseException) -> NoReturn:
    """An error no check foresaw: one line that says so (a traceback on request), still exit 2."""
    if os.environ.get("D2SR_TRACEBACK"):
        raise exc
    what = str(exc).strip().splitlines()[0][:200] if str(exc).strip() else ""
    _fail(f"{type(exc).__name__}{': ' + what if what else ''} (unforeseen; D2SR_TRACEBACK=1 shows where)")

"""Console, warnings and progress bars shared by the CLI commands (rich)."""

from __future__ import annotations

import sys
from types import TracebackType

from rich.console import Console
from rich.progress import BarColumn, Progress, ProgressColumn, Task, TextColumn, TimeElapsedColumn
from rich.text import Text

__all__ = ["NA", "console", "flush_warnings", "print_line", "progress_bar", "take_warnings", "warn"]

console = Console()
if not console.is_terminal:  # a log or a pipe: tables print whole instead of cut at 80 columns ("0.01…")
    console.width = 200
NA = "n/a"  # where a figure does not apply (no ground truth, no timestamp)


_pending: list[str] = []


def print_line(line: str) -> None:
    """One line of output, never wrapped (paths stay whole)."""
    console.print(line, soft_wrap=True)


def warn(message: str) -> None:
    """One line on stderr for what may be a mistake but is not an error. It waits until the work starts
    (a progress bar opens) or the command ends well: a command that fails prints its error alone."""
    _pending.append(f"d2sr: warning: {message}")


def take_warnings() -> list[str]:
    """The warnings waiting, taken (a fleet's worker hands its recording's to the command that shows them)."""
    taken = list(_pending)
    _pending.clear()
    return taken


def flush_warnings(show: bool = True) -> None:
    """Print (or, after an error, drop) the warnings waiting."""
    if show:
        for line in _pending:
            print(line, file=sys.stderr)
    _pending.clear()


class _Progress(Progress):
    """A progress bar that leaves nothing behind when the block fails: the error stays the only line."""

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if kind is not None:
            self.live.transient = True
            self.disable = True
        super().__exit__(kind, exc, tb)


class _Done(ProgressColumn):
    """Frames done of all (M/N), or a share where the work is counted as one (a simulated room)."""

    def render(self, task: Task) -> Text:
        if task.total is None:
            return Text(f"{int(task.completed)}")
        if task.total <= 1:
            return Text(f"{100 * task.completed / max(task.total, 1e-9):3.0f}%")
        return Text(f"{int(task.completed)}/{int(task.total)}")


def progress_bar() -> Progress:
    flush_warnings()
    return _Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        _Done(),
        TimeElapsedColumn(),
        console=console,
    )

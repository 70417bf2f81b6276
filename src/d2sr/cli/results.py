"""``d2sr results``: the README's results table and the models' cards, written from docs/results."""

from __future__ import annotations

from typing import Annotated

import typer

from d2sr.errors import ConfigError, InputError
from d2sr.ui import console

__all__ = ["results"]


def results(
    check: Annotated[
        bool, typer.Option("--check", metavar="", help="Change nothing; exit 2 on any disagreement.")
    ] = False,
) -> None:
    """Write the README's results table and the shipped models' cards from the committed results under
    docs/results (in a d2sr checkout); with --check, report where they disagree instead.

    Example: d2sr results --check
    """
    from d2sr import results as r

    if not r.RESULTS.is_dir():
        raise ConfigError(f"d2sr results runs in a d2sr checkout: no {r.RESULTS}")
    if check:
        problems = r.check()
        for p in problems:
            console.print(p)
        if problems:
            raise InputError(f"{len(problems)} published figure(s) disagree with docs/results")
        bad, total = r.untraceable()
        console.print(
            f"README and cards agree with docs/results; {total - len(bad)} of {total} results record their "
            f"command and commit ({len(bad)} listed in {r.PENDING})"
        )
        return
    changed = r.write()
    console.print("Rewrote " + ", ".join(changed) if changed else "Nothing to change")

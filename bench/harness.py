"""What the benchmark scripts share: their --json / --plot / --overwrite options, checked before they run
(the output policy of every d2sr command). Results are written with ``d2sr.atomic.write_result``."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

__all__ = ["check_output", "measure_main", "output_args"]


def output_args(ap: argparse.ArgumentParser, plot: str | None = None) -> None:
    """The benchmark scripts' --json FILE and --overwrite (the output policy of every d2sr command); with
    ``plot`` (its help), also --plot FILE (a PNG)."""
    ap.add_argument("--json", type=Path, default=None, help="write the result to this JSON file")
    ap.add_argument("--overwrite", action="store_true", help="replace an existing --json (or --plot) file")
    if plot is not None:
        ap.add_argument("--plot", type=Path, default=None, help=plot)


def check_output(ap: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse, before the benchmark runs, a --json or --plot that would replace a file without --overwrite."""
    from d2sr.atomic import check_out
    from d2sr.errors import D2SRError

    for option in ("json", "plot"):
        path = getattr(args, option, None)
        if path is not None:
            try:
                check_out(path, is_dir=False, overwrite=args.overwrite, name=option)
            except D2SRError as exc:
                ap.error(str(exc).replace(option, f"--{option}", 1))


def measure_main(doc: str, measure: Callable[[Path], tuple[dict, list[Path]]], what: str) -> None:
    """A script's whole command line: --data (default ../shared/data), --json, --overwrite; ``measure(data)``
    gives (result, the files it read), written with their provenance as ``what`` and printed."""
    from d2sr.atomic import write_result
    from d2sr.provenance import data_read

    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data"))
    output_args(ap)
    args = ap.parse_args()
    check_output(ap, args)
    result, read = measure(args.data)
    print(write_result(result, args.json, data=data_read(what, read, args.data)))

"""The CLI only parses and calls: small modules, no threads or pools of its own (the library's jobs hold
them), and no import of another command module's internals."""

from __future__ import annotations

import ast
from pathlib import Path

CLI = Path(__file__).resolve().parents[1] / "src" / "d2sr" / "cli"


def test_cli_modules_are_small_and_hold_no_pools():
    for f in sorted(CLI.glob("*.py")):
        text = f.read_text()
        assert len(text.splitlines()) <= 250, f.name
        imported = set()
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.Import):
                imported |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.module:
                imported |= {node.module, *(f"{node.module}.{a.name}" for a in node.names)}
        pools = {m for m in imported if m.split(".")[0] in ("threading", "queue", "multiprocessing")}
        pools |= {m for m in imported if m.startswith("concurrent.futures")}
        assert not pools, (f.name, pools)


def test_help_texts_name_only_flags_the_command_has():
    import re

    from typer.main import get_command

    from d2sr.cli import app

    def walk(cmd, path):
        subs = getattr(cmd, "commands", None)
        if subs:
            for name, sub in subs.items():
                yield from walk(sub, [*path, name])
        else:
            yield " ".join(path), cmd

    # label's help says on purpose that --threshold means a detector score on every other command
    allowed = {"label": {"--threshold"}}
    for name, cmd in walk(get_command(app), []):
        have = {o for p in cmd.params for o in [*getattr(p, "opts", []), *getattr(p, "secondary_opts", [])]}
        text = " ".join([cmd.help or "", *(getattr(p, "help", "") or "" for p in cmd.params)])
        named = set(re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", text))
        assert named - have <= allowed.get(name, set()), (name, named - have)

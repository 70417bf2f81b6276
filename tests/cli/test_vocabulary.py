"""One vocabulary across the commands: one flag for one meaning, every command and group with an example,
and an output every command must be told."""

from __future__ import annotations

from typer.main import get_command

from d2sr.cli import app

# Spellings of one meaning: at most one of each group may be a (visible) flag of any command.
SYNONYMS = [
    {"--all", "--repair", "--every"},  # which frames are repaired
    {"--rgb", "--colour", "--color", "--colour-folder"},  # a folder of colour frames
    {"--duration", "--seconds"},
    {"--fps", "--active-frames"},
    {"--weights", "--models"},
    {"--scale", "--depth-scale", "--units"},
]


def _commands():
    def walk(cmd, path):
        yield " ".join(path), cmd
        for name, sub in (getattr(cmd, "commands", None) or {}).items():
            yield from walk(sub, [*path, name])

    return list(walk(get_command(app), ["d2sr"]))


def _flags(cmd) -> set[str]:
    return {o for p in cmd.params if not getattr(p, "hidden", False) for o in getattr(p, "opts", [])}


def test_one_flag_for_one_meaning_across_every_command():
    used = set().union(*(_flags(cmd) for _, cmd in _commands()))
    for group in SYNONYMS:
        assert len(used & group) <= 1, sorted(used & group)


def test_every_command_and_group_has_an_example_and_every_output_is_asked_for():
    for name, cmd in _commands():
        if name == "d2sr":
            continue
        example = (cmd.help or "").partition("Example:")[2]
        assert "d2sr " in example, name
        out = next((p for p in cmd.params if "--out" in getattr(p, "opts", [])), None)
        if out is not None:
            assert out.required, f"{name}: --out has a default"

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
    allowed = {"label": {"--threshold"}, "scene learn": {"--scene-from"}}  # names the flag of the others
    for name, cmd in walk(get_command(app), []):
        have = {o for p in cmd.params for o in [*getattr(p, "opts", []), *getattr(p, "secondary_opts", [])]}
        text = " ".join([cmd.help or "", *(getattr(p, "help", "") or "" for p in cmd.params)])
        named = set(re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", text))
        assert named - have <= allowed.get(name, set()), (name, named - have)


# The house (docs/architecture.md): each part of the package and its layer. A part imports only parts of
# lower layers; the torch backend, a layer above the runtime, is found by name where torch is asked for.
ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "d2sr"
LAYERS = {
    "version": 0, "errors": 0,
    "config": 1, "ui": 1, "provenance": 1, "graphs": 1,
    "atomic": 2,
    "frames": 3,
    "desync": 4, "scene": 4,
    "sim": 5, "synth": 5, "triggers": 5,
    "contract": 6,
    "runtime": 7,
    "jobs": 8, "models": 8,
    "ros2": 9, "fleet": 9,
    "train": 9,
    "eval": 10,
    "cli": 11,
    "__init__": 12, "__main__": 12,
}  # fmt: skip


def _part(path: Path) -> str:
    rel = path.relative_to(SRC)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def _imports(path: Path) -> set[str]:
    """The parts of d2sr a module imports (at module level or in a function)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module] if node.module != "d2sr" else [f"d2sr.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        out |= {n.split(".")[1] for n in names if n.startswith("d2sr.")}
    return out


def test_every_import_runs_down_the_layers():
    parts = {_part(f) for f in SRC.rglob("*.py")}
    assert parts == set(LAYERS), parts ^ set(LAYERS)  # a new part gets its layer here and in the doc
    upward = []
    for f in sorted(SRC.rglob("*.py")):
        me = _part(f)
        for other in _imports(f) - {me}:
            if LAYERS[other] >= LAYERS[me]:
                upward.append(f"{f.relative_to(SRC)} -> {other}")
    assert upward == []
    top = sorted(p.name for p in SRC.glob("*.py"))
    assert len(top) <= 8, top  # modules beside the subpackages


def test_no_function_outside_the_cli_takes_nine_parameters_and_the_scene_reference_three():
    many = []
    for f in sorted(SRC.rglob("*.py")):
        if _part(f) == "cli":
            continue
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                params = [*a.posonlyargs, *a.args, *a.kwonlyargs, *filter(None, (a.vararg, a.kwarg))]
                n = len([p for p in params if p.arg not in ("self", "cls")])
                if n >= 9:
                    many.append(f"{f.relative_to(SRC)}:{node.lineno} {node.name} ({n})")
    assert many == []
    from inspect import signature

    from d2sr.scene import SceneReference

    assert len(signature(SceneReference).parameters) <= 3


def test_no_line_of_the_product_cites_a_sealed_set_and_nothing_patches_the_path():
    cites = [
        f"{f.relative_to(SRC)}:{i}"
        for f in sorted(SRC.rglob("*.py"))
        for i, line in enumerate(f.read_text().splitlines(), 1)
        if "sealed" in line.lower()
    ]
    assert cites == []
    patched = [
        str(f.relative_to(ROOT))
        for where in ("src", "tests", "bench", "lab", "tools")
        for f in sorted((ROOT / where).rglob("*.py"))
        if "sys.path.insert" in f.read_text() and f != Path(__file__).resolve()
    ]
    assert patched == []


def test_every_subpackage_has_its_tests():
    packages = {p.name for p in SRC.iterdir() if (p / "__init__.py").is_file()}
    tested = {p.name for p in (ROOT / "tests").iterdir() if p.is_dir() and any(p.glob("test_*.py"))}
    assert packages <= tested, packages - tested

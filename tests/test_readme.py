"""The README is a manual a performer follows: its node snippet is run as a plugin folder and as an
installed package's entry point, every ``pointat`` command it shows is one the program has, every
shipped patch it runs by name ships, and it stays short."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from pointat import shipped
from pointat.cli import _parser

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")


def _section(title: str) -> str:
    start = README.index(f"\n## {title}\n")
    end = README.find("\n## ", start + 1)
    return README[start : end if end > 0 else None]


def _blocks(text: str, lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", text, flags=re.S)


def _pointat(*args: str, cwd: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "pointat.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )


PATCH = "node lb loadbang\nnode m msg 100\nnode near nearest step=30\nlb -> m -> near\n"
SAID = "near: the loudspeaker at 90°"  # 100 to the nearest of a loudspeaker every 30 degrees


def test_the_readme_is_a_manual_not_a_report():
    assert len(README.splitlines()) <= 280
    assert README.count("\n|") < 5, "tables of measurements belong in benchmarks/"
    for title in (
        "Quick start",
        "Connecting a renderer",
        "Calibrating a glove",
        "Seeing it live",
        "Gestures",
    ):
        _section(title)
    for title in (
        "Several gloves and bodies",
        "Several machines",
        "On stage",
        "Troubleshooting",
        "Writing a node",
    ):
        _section(title)
    (quick,) = _blocks(_section("Quick start"), "sh")
    assert len(quick.strip().splitlines()) == 2  # install and run; install and test


def test_the_readmes_node_runs_from_a_plugins_folder(tmp_path):
    (code,) = _blocks(_section("Writing a node"), "python")
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "nearest.py").write_text(code)
    (tmp_path / "my.pat").write_text(PATCH)
    ran = _pointat("run", "my.pat", "--plugins", "mine", "--for", "0.5", "--status", "0", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    assert SAID in ran.stdout.splitlines(), ran.stdout
    helped = _pointat("help", "nearest", "--plugins", "mine", cwd=tmp_path)
    assert helped.returncode == 0 and "step" in helped.stdout and "[deg]" in helped.stdout, helped


def test_the_readmes_node_arrives_through_the_entry_point_group_once_installed(tmp_path):
    """A package installed as pip installs one (a module and its dist-info with the README's entry
    point): every command finds the node with no --plugins."""
    (code,) = _blocks(_section("Writing a node"), "python")
    (toml,) = _blocks(_section("Writing a node"), "toml")
    site = tmp_path / "site"
    (site / "mine").mkdir(parents=True)
    (site / "mine" / "__init__.py").write_text("")
    (site / "mine" / "nearest.py").write_text(code)
    info = site / "mine-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: mine\nVersion: 0.1\n")
    group, entry = toml.strip().splitlines()
    assert group == '[project.entry-points."pointat.nodes"]'
    name, _, module = (w.strip().strip('"') for w in entry.partition("="))
    (info / "entry_points.txt").write_text(f"[pointat.nodes]\n{name} = {module}\n")  # as pip writes it
    (tmp_path / "my.pat").write_text(PATCH)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")])}
    listed = _pointat("nodes", cwd=tmp_path, env=env)
    assert listed.returncode == 0 and re.search(r"^\s*nearest\b", listed.stdout, flags=re.M), listed
    ran = _pointat("run", "my.pat", "--for", "0.5", "--status", "0", cwd=tmp_path, env=env)
    assert ran.returncode == 0 and SAID in ran.stdout.splitlines(), (ran.stdout, ran.stderr)


def _commands() -> list[list[str]]:
    """Every ``pointat ...`` command line of the README's shell blocks, as words (comments cut)."""
    lines = []
    for block in _blocks(README, "sh"):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split("  #")[0].strip()
            for part in line.split("&&"):
                words = part.split()
                while words and words[0] != "pointat" and not words[0].endswith("/pointat"):
                    words = words[1:]
                if words:
                    lines.append(words)
    return lines


def test_every_command_the_readme_shows_is_one_pointat_has():
    parser = _parser()
    commands = _commands()
    assert len(commands) > 20
    subcommands = next(a for a in parser._actions if a.dest == "command").choices
    names = set(shipped.patch_names())
    for words in commands:
        assert words[1] in subcommands, words
        if words[1] == "run" and not words[2].endswith((".pat", ".pd")):
            assert words[2] in names, words  # a shipped patch by name
        command = subcommands[words[1]]
        deeper = [a for a in command._actions if a.choices and isinstance(a.choices, dict)]
        if deeper:  # pointat gestures evaluate ...
            assert words[2] in deeper[0].choices, words
            command = deeper[0].choices[words[2]]
        bare = [w.strip("[]") for w in words[2:]]  # (an optional one shown in brackets is checked too)
        options = [w.split("=")[0] for w in bare if w.startswith("--")]
        known = {o for a in command._actions for o in a.option_strings}
        assert set(options) <= known, (words, set(options) - known)


@pytest.mark.parametrize("shown", ["pointat run glove_tqt --for 60 --monitor"])
def test_the_quick_start_runs_what_it_says(shown):
    (quick,) = _blocks(_section("Quick start"), "sh")
    assert shown in quick and "pip install ." in quick and 'pip install ".[test]"' in quick
    assert textwrap.dedent(quick).splitlines()[1].endswith(".venv/bin/python -m pytest")


def test_the_readmes_patch_runs_and_prints_where_the_glove_points(tmp_path):
    (text,) = re.findall(r"```\n(.*?)```", _section("Patches"), flags=re.S)
    (tmp_path / "my.pat").write_text(text)
    ran = _pointat("run", "my.pat", "--for", "3", "--status", "0", cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    assert any(line.startswith("azimuth: ") for line in ran.stdout.splitlines()), ran.stdout

"""pointat help NODE: a node's page as a terminal shows it, plain text."""

import re

import pytest

from pointat.cli import main
from pointat.registry import default_registry

MARKUP = re.compile(r"`|:[a-z]+:`|^\s*\.\. [\w:-]+::|::\s*$", re.M)


@pytest.mark.parametrize("cls", list(default_registry.load_builtins()), ids=lambda c: c.type_name)
def test_every_help_page_is_plain_text(cls):
    """No reStructuredText shows: roles (:func:`x`), literals (``k``), links, directives, Example::."""
    text = cls.help_text()
    assert not MARKUP.findall(text), [line for line in text.splitlines() if MARKUP.search(line)]


def test_pointat_help_tqt_shows_the_words(capsys):
    assert main(["help", "tqt"]) == 0
    out = capsys.readouterr().out
    assert "gain k (errors\ndecay as e^(-k t))" in out and "mode=paper is the seeds' filter" in out
    assert "``" not in out


@pytest.mark.parametrize("cls", list(default_registry.load_builtins()), ids=lambda c: c.type_name)
def test_the_parameters_defaults_line_up_however_long_a_name(cls):
    """Each parameter's line: its name, its type, then ``default`` or ``required`` in one column for the
    whole page (tqt's k_heading_unrested once pushed its own line out of it); only a type longer than
    22 characters (osc_out's list of profiles) may overflow its column."""
    text = cls.help_text()
    page = text.split("parameters (by name, or by position in this order):\n", 1)[1]
    rows = [ln for ln in page.splitlines() if ln.startswith("  ") and not ln.startswith("      ")]
    rows = [ln for ln in rows if not ln.startswith("  (none)") and not ln.startswith("  methods")]
    columns = {
        ln.index(" default ") if " default " in ln else ln.index(" required")
        for p, ln in zip(cls.params, rows, strict=False)
        if len(p.describe_type()) <= 22
    }
    assert len(columns) <= 1, rows

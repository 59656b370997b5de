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

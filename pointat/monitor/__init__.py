"""The monitor page served by ``pointat run --monitor`` (static files; see :mod:`pointat.webserver`)."""

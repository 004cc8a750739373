"""The bundled demo (the paper's) experiment with edits, shared by the inference tests."""

import tomllib

from bouncebayes.data import demo_campaign, parse_experiment


def experiment(**changes):
    """The demo (paper) experiment with ``section__key=value`` changes."""
    doc = tomllib.loads(demo_campaign().experiment.read_text(encoding="utf-8"))
    for path, value in changes.items():
        section, key = path.split("__")
        doc[section][key] = value
    return parse_experiment(doc)

"""The command line every bench script shares: `--help` prints the script's docstring (what it
measures, the figures to reach, how to run it) and an unknown argument is refused with exit
code 2 instead of starting a run of minutes."""

from __future__ import annotations

import argparse


def parser(doc: str | None) -> argparse.ArgumentParser:
    return argparse.ArgumentParser(
        description=doc, formatter_class=argparse.RawDescriptionHelpFormatter
    )

"""``nsrmp-bench challenge --evalai OUT``: an EvalAI challenge bundle scored by the public scorer.

Example::

    nsrmp-bench generate --split smoke-v2 --out data/smoke
    nsrmp-bench generate --spec private-test.json --out data/private --secret-file secret.txt
    nsrmp-bench challenge --evalai challenge/ --public data/smoke/test \\
        --private data/private/test --title "nsrmp-bench challenge 2027"

Writes ``challenge_config.yaml`` (the leaderboard schema with the headline columns and
their 95% intervals; a public-test and a private-test phase), ``evaluation_script/``
(EvalAI's ``evaluate``, which calls the public scorer) and its zip, the phases' gold as
annotation files, the pages, and ``participant_data/``: both parts packed inputs-only.
The private part must be a private part (its entropy a secret). See docs/challenge.md.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.evalai import write_bundle
from nsrmp_bench.plurals import counted
from nsrmp_bench.storage.atomic import output_dir

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("--evalai", type=output_dir, required=True, metavar="OUT",
                        help="folder to write the EvalAI challenge bundle into")
    parser.add_argument("--public", type=Path, required=True, metavar="PART",
                        help="the public test part's full data (e.g. data/smoke/test)")
    parser.add_argument("--private", type=Path, required=True, metavar="PART",
                        help="the private test part's full data (generated with its secret)")
    parser.add_argument("--title", default="nsrmp-bench challenge", help="challenge title")
    parser.add_argument("--start-date", default="2027-01-01 00:00:00",
                        help="phases' start, 'YYYY-MM-DD HH:MM:SS' (UTC)")
    parser.add_argument("--end-date", default="2027-12-31 23:59:59",
                        help="phases' end, 'YYYY-MM-DD HH:MM:SS' (UTC)")
    parser.add_argument("--wheel", type=Path, default=None,
                        help="the release's wheel: requirements.txt pins nsrmp-bench by its "
                             "sha256")


def run(args: argparse.Namespace) -> int:
    """Write the bundle and say what to upload."""
    written = write_bundle(args.evalai, args.public, args.private, title=args.title,
                           start_date=args.start_date, end_date=args.end_date,
                           wheel=args.wheel)
    print(f"wrote the EvalAI bundle ({counted(len(written), 'file')}) into {args.evalai}: "
          "upload challenge_config.yaml with evaluation_script.zip, annotations/ and "
          "templates/ (zipped together) to EvalAI; publish participant_data/")
    return 0

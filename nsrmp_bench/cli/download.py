"""``nsrmp-bench download --split ID --out DATA``: fetch a split from a mirror, verified.

Example::

    NSRMP_BENCH_MIRROR=https://host/release nsrmp-bench download --split paper-v2 --out data/paper

Every file's sha256 is checked against the registry (for official splits: the manifests
committed in the package). Files already present and correct are kept (resume); a
corrupted download is deleted and refused with a clear message. A registry path outside
``--out`` (absolute, ``..``, a link) is refused before anything is fetched, and a file
already there that differs is kept and refused unless ``--overwrite``.
"""

from __future__ import annotations

import argparse

from nsrmp_bench.plurals import counted
from nsrmp_bench.release import MIRROR_ENV, download
from nsrmp_bench.storage.atomic import output_dir

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("--split", required=True, help="split id, e.g. paper-v2")
    parser.add_argument("--out", type=output_dir, required=True, help="where the parts go")
    parser.add_argument("--base-url", default=None,
                        help=f"mirror base URL (default: ${MIRROR_ENV})")
    parser.add_argument("--trust-mirror-registry", action="store_true",
                        help="use the mirror's registry.txt even for an official split")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace files in --out that differ from the registry's "
                             "(default: keep them and stop)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")


def run(args: argparse.Namespace) -> int:
    """Download and print what arrived."""
    files = download(args.split, args.out, base_url=args.base_url,
                     trust_mirror_registry=args.trust_mirror_registry,
                     progress=not args.quiet, overwrite=args.overwrite)
    print(f"{args.split}: {counted(len(files), 'file')} verified in {args.out}")
    return 0

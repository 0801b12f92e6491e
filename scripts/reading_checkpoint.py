"""Write a v3 checkpoint: a v2 checkpoint's networks and vocabulary with the language front
end's settings (``nsrm-v2`` -> ``nsrm-v3``, ``nmn-v2`` -> ``nmn-v3``).

    python scripts/reading_checkpoint.py nsrm-v3 [--from PATH] [--set KEY=VALUE ...] --out PATH

The networks are not retrained: the v3 models are their v2 networks behind the front end
(``reference_model/language``), whose settings are config fields (``--set``, e.g.
``synonyms=true``). Without ``--from`` the shipped v2 checkpoint is read. The same input
writes the same bytes.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from nsrmp_bench.reference_model.checkpoints import (
    load_checkpoint,
    save_checkpoint,
    shipped_checkpoint,
)
from nsrmp_bench.reference_model.registry import get_model

SOURCES = {"nsrm-v3": "nsrm-v2", "nmn-v3": "nmn-v2"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", choices=sorted(SOURCES))
    parser.add_argument("--from", dest="source", type=Path, default=None)
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    source_id = SOURCES[args.model]
    payload = load_checkpoint(args.source or shipped_checkpoint(source_id), source_id)
    config_cls = get_model(args.model).config_cls()
    config = config_cls.from_dict(payload["config"]).with_overrides(args.set, args.model)
    extra = {**payload.get("extra", {}), "networks_of": source_id}
    save_checkpoint(args.out, args.model, config.to_dict(), list(payload["vocab"]),
                    payload["state"], extra)
    print(f"{args.model}: wrote {args.out} (networks of {source_id})")


if __name__ == "__main__":
    main()

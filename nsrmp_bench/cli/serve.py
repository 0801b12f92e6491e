"""``nsrmp-bench serve POLICY --port P``: serve a policy for ``rollout --server``.

Example::

    nsrmp-bench serve my_policy:policy --port 8765              # any callable
    nsrmp-bench serve oracle --data data/smoke/test --port 8765  # reads the gold program
    nsrmp-bench rollout --server ws://127.0.0.1:8765 --data data/smoke/test --out p.jsonl

``POLICY`` is any policy ``rollout`` takes (a registered predictor by id or bare name, or
``module:callable``). The policy runs in this process, with this environment's packages;
the rollout runs the simulation in its own. The privileged baselines (``oracle``,
``random``, ``noop``) read the instance's episode: give the part with ``--data`` (and
``--part``). ``--port 0`` picks a free port. The line ``serving POLICY on ws://HOST:PORT``
is printed once it listens; Ctrl-C stops it. It listens on 127.0.0.1 unless ``--host``
says otherwise (the protocol has no authentication: expose it only on a network you
trust). The protocol: ``docs/policy-server.md``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the verb."""
    parser.add_argument("policy", help="a registered policy (oracle, noop, random, nsrm, nmn, "
                                       "dense, a model id) or module:callable")
    parser.add_argument("--port", type=int, default=8765,
                        help="TCP port to listen on (default 8765; 0 picks a free one)")
    parser.add_argument("--host", default="127.0.0.1",
                        help="address to listen on (default 127.0.0.1: local connections only)")
    parser.add_argument("--data", type=Path, default=None,
                        help="the part the privileged baselines read episodes from")
    parser.add_argument("--part", default=None, help="with a split root as --data: the part")
    parser.add_argument("--observation-keys", default=None, metavar="KEY,...|all",
                        help="the observation entries the policy reads, e.g. "
                             "instruction,boxes,object_mask (the rollout sends only these; "
                             "default: all, or the instruction alone for the baselines, "
                             "which read the episode)")


def run(args: argparse.Namespace) -> int:
    """Serve until interrupted."""
    import nsrmp_bench.reference_model.registry  # noqa: F401  (registers the retired ids)
    from nsrmp_bench.errors import InvalidArgument
    from nsrmp_bench.predictors import refuse_retired
    from nsrmp_bench.serving.server import PolicyServer

    if ":" not in args.policy:
        refuse_retired(args.policy)
    if not 0 <= args.port <= 65535:
        msg = f"--port must be 0..65535, got {args.port}"
        raise InvalidArgument(msg)
    keys = args.observation_keys
    wanted: list[str] | None = None
    if keys is not None and keys != "all":
        wanted = [k.strip() for k in keys.split(",") if k.strip()]
    server = PolicyServer(args.policy, host=args.host, port=args.port, data=args.data,
                          part=args.part, observation_keys=wanted)
    if keys == "all":
        from dataclasses import replace

        server.offered = replace(server.offered, observation_keys=None)
    print(f"serving {server.offered.name} on {server.url}", file=sys.stderr, flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        server.shutdown()
    return 0

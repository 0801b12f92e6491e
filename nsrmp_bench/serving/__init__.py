"""Evaluating a policy that runs in another process: the policy-server protocol (the
``serve`` extra: websockets and msgpack).

* :mod:`~nsrmp_bench.serving.wire`: the envelope, the numpy codec, the version handshake;
* :mod:`~nsrmp_bench.serving.payloads`: observations and actions as payloads;
* :mod:`~nsrmp_bench.serving.server`: ``nsrmp-bench serve`` and :func:`nsrmp_bench.serve`;
* :mod:`~nsrmp_bench.serving.client`: the rollout's connection, with its timeouts;
* :mod:`~nsrmp_bench.serving.remote_rollout` and :mod:`~nsrmp_bench.serving.journal`:
  ``rollout --server``, its results written as they come, and resuming.

The protocol is documented for both ends, with its exact schema, in
``docs/policy-server.md``.
"""

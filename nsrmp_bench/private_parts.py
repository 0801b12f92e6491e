"""Private parts: a part whose entropy is a secret, with a commitment anyone can check later.

A split spec may give a part ``"entropy": "secret"``. Its instances are then drawn from an
entropy derived from a secret the maintainers give at generation (a file, or the
environment variable :data:`SECRET_ENV`); the secret and the derived entropy are never
written anywhere (episodes store a *sealed* seed: index and attempt, no entropy). The
part's manifest holds a **commitment**: the sha256 of the secret together with the split,
the part and the whole spec. Publishing the manifest (or only the commitment) fixes the
data without revealing it; after the reveal anyone checks the commitment
(``nsrmp-bench verify DATA --secret-file SECRET``) and regenerates the part with the same
secret to get the same root hash.

Both hashes are of canonical JSON with a scheme tag, so they are stable across Python
versions and platforms::

    entropy    = int(sha256({"scheme": ENTROPY_SCHEME, "split", "part", "secret"})[:16 bytes])
    commitment = sha256({"scheme": COMMITMENT_SCHEME, "split", "part", "spec", "secret"})
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
from collections import Counter
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from nsrmp_bench.canonical import canonical_json
from nsrmp_bench.errors import InvalidArgument
from nsrmp_bench.split_specs import SplitSpec

__all__ = [
    "COMMITMENT_SCHEME",
    "ENTROPY_SCHEME",
    "MIN_SECRET_BITS",
    "MIN_SECRET_CHARS",
    "SECRET_ENV",
    "bind_secret",
    "check_secret",
    "commitment",
    "commitment_problem",
    "commitment_record",
    "derived_entropy",
    "read_secret",
    "secret_bits",
]

SECRET_ENV = "NSRMP_BENCH_SECRET"
"""The environment variable a private part's secret may come from."""
ENTROPY_SCHEME = "nsrmp-bench-private-entropy-v1"
COMMITMENT_SCHEME = "nsrmp-bench-commitment-v1"
MIN_SECRET_CHARS = 32
"""A secret's least length: 32 hex digits are 128 bits, beyond guessing."""
MIN_SECRET_BITS = 80
"""A secret's least estimated entropy (:func:`secret_bits`): 32 random hex digits give
about 110, a letter repeated 0; a floor against mistakes, not a proof of randomness."""
_MAKE_ONE = 'python -c "import secrets; print(secrets.token_hex(32))" > secret.txt'


def secret_bits(secret: str) -> float:
    """An upper estimate of a secret's entropy in bits: its length times the empirical
    Shannon entropy of its characters; a secret that repeats a shorter period (``abab...``)
    counts as that period alone."""
    period = next((k for k in range(1, len(secret) // 2 + 1)
                   if len(secret) % k == 0 and secret[:k] * (len(secret) // k) == secret),
                  len(secret))
    unit = secret[:period]
    counts = Counter(unit)
    return max(0.0, -sum(n * math.log2(n / len(unit)) for n in counts.values()))


def check_secret(secret: str, where: str) -> str:
    """``secret`` without surrounding white space; a short, empty or low-entropy one (under
    :data:`MIN_SECRET_BITS` by :func:`secret_bits`: one letter repeated, a short pattern) is
    an error."""
    value = secret.strip()
    if len(value) < MIN_SECRET_CHARS:
        msg = (f"the secret from {where} has {len(value)} characters; a private part's secret "
               f"needs at least {MIN_SECRET_CHARS} (e.g. 64 random hex digits: {_MAKE_ONE})")
        raise InvalidArgument(msg)
    bits = secret_bits(value)
    if bits < MIN_SECRET_BITS:
        msg = (f"the secret from {where} has {len(value)} characters but about {bits:.0f} bits "
               f"of entropy (its characters repeat); a private part's secret needs at least "
               f"{MIN_SECRET_BITS} bits: draw it at random, e.g. {_MAKE_ONE}")
        raise InvalidArgument(msg)
    return value


def read_secret(secret_file: str | os.PathLike[str] | None = None,
                environ: Mapping[str, str] | None = None) -> str | None:
    """The secret from ``secret_file`` if given, else from :data:`SECRET_ENV` in
    ``environ`` (default ``os.environ``); None when neither is given."""
    if secret_file is not None:
        p = Path(secret_file)
        try:
            text = p.read_text("utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            msg = (f"secret file {str(p)!r} cannot be read ({exc}); give a text file holding "
                   f"the secret, e.g. made with {_MAKE_ONE}")
            raise InvalidArgument(msg) from exc
        return check_secret(text, f"file {p}")
    env = os.environ if environ is None else environ
    value = env.get(SECRET_ENV)
    if value is None or not value.strip():
        return None
    return check_secret(value, f"${SECRET_ENV}")


def _hash(data: Mapping[str, Any]) -> bytes:
    return hashlib.sha256(canonical_json(dict(data)).encode("utf-8")).digest()


def derived_entropy(secret: str, split_id: str, part: str) -> int:
    """The entropy of part ``part`` of ``split_id`` drawn from ``secret`` (128 bits)."""
    digest = _hash({"scheme": ENTROPY_SCHEME, "split": split_id, "part": part,
                    "secret": secret})
    return int.from_bytes(digest[:16], "big")


def commitment(spec: Mapping[str, Any], part: str, secret: str) -> str:
    """The commitment (hex sha256) to ``secret`` for part ``part`` of the spec ``spec`` (its
    JSON object, :meth:`SplitSpec.to_dict`)."""
    return _hash({"scheme": COMMITMENT_SCHEME, "split": str(spec.get("id")), "part": part,
                  "spec": dict(spec), "secret": secret}).hex()


def commitment_record(spec: SplitSpec, part: str, secret: str) -> dict[str, str]:
    """What a private part's manifest holds under ``"private"``."""
    return {"scheme": COMMITMENT_SCHEME, "commitment": commitment(spec.to_dict(), part, secret)}


def commitment_problem(record: Mapping[str, Any], spec: Mapping[str, Any], part: str,
                       secret: str) -> str | None:
    """Why ``secret`` does not open the manifest's commitment ``record``, or None."""
    scheme = record.get("scheme")
    if scheme != COMMITMENT_SCHEME:
        return (f"the manifest's commitment scheme is {scheme!r}; this nsrmp-bench checks "
                f"{COMMITMENT_SCHEME!r}: use the release that wrote it")
    want = str(record.get("commitment"))
    got = commitment(spec, part, secret)
    if got != want:
        return (f"the secret given does not open the manifest's commitment (it gives "
                f"{got[:16]}..., the manifest holds {want[:16]}...): it is not the secret "
                "this part was generated with, or the spec differs from the one committed")
    return None


def bind_secret(spec: SplitSpec, secret: str | None) -> SplitSpec:
    """``spec`` with every private part's entropy derived from ``secret``; unchanged when it
    has no private part. A private part without a secret stays unbound (generating it is
    then an error naming how to give the secret)."""
    if secret is None or not any(p.private for p in spec.parts.values()):
        return spec
    parts = {
        name: dataclasses.replace(p, entropy=derived_entropy(secret, spec.id, name))
        if p.private else p
        for name, p in spec.parts.items()
    }
    return dataclasses.replace(spec, parts=parts)

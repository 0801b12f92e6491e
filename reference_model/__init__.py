"""The learned models: NSRM (``nsrm/``) and what every learned model shares (crops and
object features, the tokeniser, the training loop, checkpoints, the predictions writer and
the registry of model ids). Needs the ``torch`` extra; :func:`load_model` is the entry."""

from nsrmp_bench.reference_model.registry import MODELS, get_model, load_model

__all__ = ["MODELS", "get_model", "load_model"]
